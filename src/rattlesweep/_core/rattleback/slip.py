"""The friction direction of a slipping rattleback (docs/model.md: dynamics): the slip's own
direction, or for a slow slip the consistent direction d*, from the contact's response
to a contact force; the phase of :func:`.dynamics.eval_block` between the kinematics
and the accelerations.
"""

from __future__ import annotations

import math

import numba
from numba import types
from numba.core.errors import TypingError
from numba.extending import overload

from ..jit import OVERLOAD_OPTIONS, inline_kernel, kernel
from ..workspace import (
    DT,
    EPS_U,
    GRAV,
    MU_K,
    OFF_P,
    OFF_S,
    OFF_X,
    ROLLING,
    S_DPX,
    S_DPY,
    S_MODE,
    S_TURN,
    S_UHX,
    S_UHY,
    X_DCX,
    X_DCY,
    X_TURN,
    at,
    lane_range,
)
from .consistent import (
    RELAX_STEPS,
    block_directions,
    consistent_direction,
    solve_inputs,
)
from .layout import (
    DSTAR_SLOPE,
    DSTAR_X,
    DSTAR_Y,
    JI_XX,
    JI_YY,
    JI_ZZ,
    OFF_E,
    OFF_G,
    RHO_X,
    RHO_Y,
    RHO_Z,
    SLIP_KIND,
    SLIP_X,
    SLIP_Y,
    UHAT_X,
    UHAT_Y,
)

__all__ = [
    "FAST_SLIP",
    "RELAX_STEPS",
    "SLOW_SLIP",
    "slip_direction",
    "steer",
]


FAST_SLIP = 1.0
"""``SLIP_KIND`` of a slipping lane whose friction acts along its slip velocity."""

SLOW_SLIP = 2.0
"""``SLIP_KIND`` of a slip slow enough to be steered (:func:`slip_direction`)."""

VECTOR_SLOW = 10
"""From this many slow slips in a block evaluation on, their consistent directions are
solved for in one vector pass over the block (:func:`.consistent.block_directions`)
rather than lane by lane."""

SLOPE_BOUND = 4.0
"""A slip faster than this many times μ g (1 + |ρ|² tr J⁻¹) dt / ``RELAX_STEPS`` is not
steered, without computing d*: the bound exceeds the relaxation's s (μ N times the
contact's response, at most 1 + |ρ|² tr J⁻¹ per unit mass) with a margin for N > m g."""


@inline_kernel
def turn_rate(W, j, x, y, h):
    """Rate (rad/s) at which lane j's consistent slip direction turned over the last step
    (h, s), to (x, y) from the one at the step before's start; 0 where there is none yet
    (a zero vector)."""
    px = W[at(OFF_S, S_DPX, j)]
    py = W[at(OFF_S, S_DPY, j)]
    return math.atan2(px * y - py * x, px * x + py * y) / h


@kernel
def slip_direction(W, state, one_lane, lane, history, ahead):
    """Phase between :func:`contact_kinematics` and :func:`accelerations`: the friction
    direction û of every slipping lane, world horizontal, into UHAT.

    A slip whose direction relaxes slowly enough for the step, τ = |u| / s ≥ dt /
    ``RELAX_STEPS`` (s from :mod:`.consistent`), uses û = u/|u|. A faster one lies on
    a slow manifold: u's direction trails the consistent direction d* by τ φ̇* (φ̇* the
    rate at which d* turns), and the friction acts along u. There the friction is steered,
    û ∝ w u/|u| + (1 − w) t̂ with t̂ = d* turned back by τ φ̇* and w = ``RELAX_STEPS`` τ /
    dt < 1: on the manifold û is unchanged, and off it u's direction relaxes onto it at
    the rate ``RELAX_STEPS`` / dt, which the step follows. φ̇* is measured over the last
    step: ``history`` (a literal, True for the block's step-start evaluation) measures it
    afresh and puts d* and φ̇* into the contact outputs, which
    :func:`.switching.keep_directions` makes the lane's switching state; the evaluation
    itself writes no switching state.

    A first, branch-free pass gives every lane u/|u| (a sticking lane, or a slip too
    slow to have a direction, keeps its stored one) and sorts the slipping lanes into
    fast and slow ones (``SLIP_KIND``); the scalar work, steering and the history, then
    visits only the lanes that need it. d* is solved for lane by lane, or, from
    ``VECTOR_SLOW`` slow slips on, for the whole block in one vector pass
    (:mod:`.consistent`). ``ahead`` is the number of steps from the step start whose d*
    the solve's guess starts from (the one before for a step-start evaluation, this
    one's otherwise) to the state evaluated (0 where unknown: a located step's pieces).
    Sticking lanes keep their stored direction;
    the stepper reads it only in slip.
    """
    numba.literally(state)
    numba.literally(one_lane)
    numba.literally(history)
    first, stop = lane_range(one_lane, lane)
    n_slow = 0
    n_slip = 0
    for j in range(first, stop):
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        ux = W[at(OFF_G, SLIP_X, j)]
        uy = W[at(OFF_G, SLIP_Y, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        moving = slipping & (uu > W[at(OFF_P, EPS_U, j)])
        W[at(OFF_G, UHAT_X, j)] = ux / uu if moving else W[at(OFF_S, S_UHX, j)]
        W[at(OFF_G, UHAT_Y, j)] = uy / uu if moving else W[at(OFF_S, S_UHY, j)]
        mu = W[at(OFF_P, MU_K, j)]
        slow = (
            slipping
            & (mu > 0.0)
            & (
                RELAX_STEPS * uu
                < SLOPE_BOUND
                * mu
                * W[at(OFF_P, GRAV, j)]
                * (
                    1.0
                    + (
                        W[at(OFF_G, RHO_X, j)] ** 2
                        + W[at(OFF_G, RHO_Y, j)] ** 2
                        + W[at(OFF_G, RHO_Z, j)] ** 2
                    )
                    * (
                        W[at(OFF_E, JI_XX, j)]
                        + W[at(OFF_E, JI_YY, j)]
                        + W[at(OFF_E, JI_ZZ, j)]
                    )
                )
                * W[at(OFF_P, DT, j)]
            )
        )
        W[at(OFF_G, SLIP_KIND, j)] = SLOW_SLIP if slow else (FAST_SLIP if slipping else 0.0)
        n_slow += 1 if slow else 0
        n_slip += 1 if slipping else 0
    if n_slow == 0 and not (history and n_slip > 0):
        return
    # enough slow slips for one pass over the block to cost less than a solve each
    vector = (not one_lane) and n_slow >= VECTOR_SLOW
    if vector:
        block_directions(W, state, history, ahead)
    for j in range(first, stop):
        kind = W[at(OFF_G, SLIP_KIND, j)]
        if kind == 0.0:
            continue
        dx = W[at(OFF_G, UHAT_X, j)]
        dy = W[at(OFF_G, UHAT_Y, j)]
        h = W[at(OFF_P, DT, j)]
        if kind == FAST_SLIP:
            if history:  # its direction stands in for d*
                W[at(OFF_X, X_TURN, j)] = turn_rate(W, j, dx, dy, h)
                W[at(OFF_X, X_DCX, j)] = dx
                W[at(OFF_X, X_DCY, j)] = dy
            continue
        ux = W[at(OFF_G, SLIP_X, j)]
        uy = W[at(OFF_G, SLIP_Y, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        turn = W[at(OFF_S, S_TURN, j)]
        slope = W[at(OFF_G, DSTAR_SLOPE, j)] if vector else math.nan
        if not math.isnan(slope):  # solved for by the vector pass
            cx = W[at(OFF_G, DSTAR_X, j)]
            cy = W[at(OFF_G, DSTAR_Y, j)]
        else:
            mu, gx, gy, sx, sy, wanted = solve_inputs(W, j, history, ahead)
            cx, cy, slope = consistent_direction(W, j, state, mu, gx, gy, sx, sy, wanted)
        if history:
            turn = turn_rate(W, j, cx, cy, h) if slope > 0.0 else 0.0
            W[at(OFF_X, X_TURN, j)] = turn
            W[at(OFF_X, X_DCX, j)] = cx
            W[at(OFF_X, X_DCY, j)] = cy
        if slope > 0.0 and RELAX_STEPS * uu < slope * h:
            lag = -turn * uu / slope  # the manifold's angle from d*, rad
            lag = min(max(lag, -0.5), 0.5)
            tx = cx - lag * cy
            ty = cy + lag * cx
            scale = RELAX_STEPS / (slope * h)
            bx = scale * ux + (1.0 - scale * uu) * tx
            by = scale * uy + (1.0 - scale * uu) * ty
            bb = math.sqrt(bx * bx + by * by)
            W[at(OFF_G, UHAT_X, j)] = bx / bb if bb > 1e-3 else cx
            W[at(OFF_G, UHAT_Y, j)] = by / bb if bb > 1e-3 else cy


def steer(W, slip_possible, state, one_lane, lane, history, ahead):
    """:func:`slip_direction` where lanes may slip (``slip_possible``, a literal, not
    ``ROLLING``); nothing, and nothing compiled, where every lane sticks."""


@overload(steer, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _steer(W, slip_possible, state, one_lane, lane, history, ahead):
    if not isinstance(slip_possible, (types.IntegerLiteral, types.BooleanLiteral)):
        raise TypingError("slip_possible must be a literal (numba.literally)")
    if slip_possible.literal_value == ROLLING:
        return lambda W, slip_possible, state, one_lane, lane, history, ahead: None
    return lambda W, slip_possible, state, one_lane, lane, history, ahead: slip_direction(
        W, state, one_lane, lane, history, ahead
    )
