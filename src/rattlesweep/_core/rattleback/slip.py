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
    S_DCX,
    S_DCY,
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
from .contact import horizontal_rows
from .geometry import cross
from .layout import (
    DAMPING_PM,
    INV_QQ,
    J_XX,
    J_XY,
    J_XZ,
    J_YY,
    J_YZ,
    J_ZZ,
    JI_XX,
    JI_XY,
    JI_XZ,
    JI_YY,
    JI_YZ,
    JI_ZZ,
    OFF_E,
    OFF_G,
    OMEGA_X,
    OMEGA_Y,
    OMEGA_Z,
    Q0,
    Q1,
    Q2,
    Q3,
    RHO_X,
    RHO_Y,
    RHO_Z,
    SLIP_KIND,
    SLIP_X,
    SLIP_Y,
    UHAT_X,
    UHAT_Y,
    UP_X,
    UP_Y,
    UP_Z,
    WW_X,
    WW_Y,
    WW_Z,
)

__all__ = [
    "FAST_SLIP",
    "RELAX_STEPS",
    "SLOW_SLIP",
    "consistent_direction",
    "slip_direction",
    "steer",
]


FAST_SLIP = 1.0
"""``SLIP_KIND`` of a slipping lane whose friction acts along its slip velocity."""

SLOW_SLIP = 2.0
"""``SLIP_KIND`` of a slip slow enough to be steered (:func:`slip_direction`)."""

CONSISTENT_ITERATIONS = 5
"""Newton iterations for the consistent slip direction, from the one at the last step
start (usually a few hundredths of a radian away; quadratic convergence reaches rounding
in three)."""

NEWTON_TOL = 1e-8
"""The consistent direction's Newton iteration stops after a step (rad) below this: the
error left is of order its square."""

SLOPE_BOUND = 4.0
"""A slip faster than this many times μ g (1 + |ρ|² tr J⁻¹) dt / ``RELAX_STEPS`` is not
steered, without computing d*: the bound exceeds the relaxation's s (μ N times the
contact's response, at most 1 + |ρ|² tr J⁻¹ per unit mass) with a margin for N > m g."""

RELAX_STEPS = 2.0
"""A slip whose direction relaxes within fewer than ``1 / RELAX_STEPS`` steps is steered
(:func:`slip_direction`): its relaxation is slowed to this many per step, inside the
interval (−2.79, 0) of the real axis on which classic RK4 is stable."""


@inline_kernel
def consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey):
    """(f, f′, D) of the consistent slip direction's equation at the direction (ex, ey):
    u̇ / N = V(d) = a D(d) + K_hz − μ K_hh d with D = K_zz − μ K_zh · d (a the free
    horizontal acceleration over what the normal force holds up), f = V × d, zero at
    consistency, and f′ its derivative along the angle of d."""
    dd = k_zz - mu * (k_xz * ex + k_yz * ey)
    vx = ax * dd + k_xz - mu * (k_xx * ex + k_xy * ey)
    vy = ay * dd + k_yz - mu * (k_xy * ex + k_yy * ey)
    # derivatives along d⊥ = (−e_y, e_x)
    ddd = -mu * (k_yz * ex - k_xz * ey)
    dvx = ax * ddd - mu * (k_xy * ex - k_xx * ey)
    dvy = ay * ddd - mu * (k_yy * ex - k_xy * ey)
    return vx * ey - vy * ex, (dvx * ey - dvy * ex) + (vx * ex + vy * ey), dd


@kernel
def consistent_direction(W, j, state, mu, gx, gy, dx, dy):
    """The consistent slip direction of lane j at its state, and its normal force.

    With friction −μ N d (d a horizontal unit vector, world), the contact point's
    acceleration is u̇ = A_h + N (K_hz − μ K_hh d), N = −A_z / (K_zz − μ K_zh · d), where
    A is its acceleration without contact force and K (per unit mass, 𝟙 + [ρ]ᵀ J⁻¹ [ρ])
    its response to one, both in the world axes. The consistent direction d* is the one
    along which the slip speed grows or shrinks without turning, u̇ ∥ d*: Newton's method
    on the angle, from the guess (gx, gy), the root taken only within 60° of the slip's
    direction (dx, dy). A slow slip's direction locks onto it on the time scale
    |u| / (μ N k), far below the step (docs/model.md: dynamics).

    Returns (d*_x, d*_y, s) with s (m/s²) such that u's direction relaxes onto d* at the
    rate s / |u|; s ≤ 0 where d* does not attract it or no consistent slip exists (then
    d* = (dx, dy)).
    """
    q0 = W[at(state, Q0, j)]
    q1 = W[at(state, Q1, j)]
    q2 = W[at(state, Q2, j)]
    q3 = W[at(state, Q3, j)]
    inv_q = W[at(OFF_G, INV_QQ, j)]
    e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
    x0 = e00 * inv_q  # world x, y and up in body components
    x1 = e01 * inv_q
    x2 = e02 * inv_q
    y0 = e10 * inv_q
    y1 = e11 * inv_q
    y2 = e12 * inv_q
    n0 = W[at(OFF_G, UP_X, j)] * inv_q
    n1 = W[at(OFF_G, UP_Y, j)] * inv_q
    n2 = W[at(OFF_G, UP_Z, j)] * inv_q
    r0 = W[at(OFF_G, RHO_X, j)]
    r1 = W[at(OFF_G, RHO_Y, j)]
    r2 = W[at(OFF_G, RHO_Z, j)]
    kxx = W[at(OFF_E, JI_XX, j)]
    kyy = W[at(OFF_E, JI_YY, j)]
    kzz = W[at(OFF_E, JI_ZZ, j)]
    kxy = W[at(OFF_E, JI_XY, j)]
    kxz = W[at(OFF_E, JI_XZ, j)]
    kyz = W[at(OFF_E, JI_YZ, j)]
    px0, px1, px2 = cross(r0, r1, r2, x0, x1, x2)
    py0, py1, py2 = cross(r0, r1, r2, y0, y1, y2)
    pn0, pn1, pn2 = cross(r0, r1, r2, n0, n1, n2)
    jn0 = kxx * pn0 + kxy * pn1 + kxz * pn2
    jn1 = kxy * pn0 + kyy * pn1 + kyz * pn2
    jn2 = kxz * pn0 + kyz * pn1 + kzz * pn2
    jy0 = kxx * py0 + kxy * py1 + kxz * py2
    jy1 = kxy * py0 + kyy * py1 + kyz * py2
    jy2 = kxz * py0 + kyz * py1 + kzz * py2
    k_xx = 1.0 + (
        px0 * (kxx * px0 + kxy * px1 + kxz * px2)
        + px1 * (kxy * px0 + kyy * px1 + kyz * px2)
        + px2 * (kxz * px0 + kyz * px1 + kzz * px2)
    )
    k_yy = 1.0 + (py0 * jy0 + py1 * jy1 + py2 * jy2)
    k_zz = 1.0 + (pn0 * jn0 + pn1 * jn1 + pn2 * jn2)
    k_xy = px0 * jy0 + px1 * jy1 + px2 * jy2
    k_xz = px0 * jn0 + px1 * jn1 + px2 * jn2
    k_yz = py0 * jn0 + py1 * jn1 + py2 * jn2
    # acceleration of the contact point without contact force: −g n̂ + α₀ × ρ + w, with
    # α₀ = J⁻¹(−ω × Jω − (c_v/m) ω)
    w0 = W[at(state, OMEGA_X, j)]
    w1 = W[at(state, OMEGA_Y, j)]
    w2 = W[at(state, OMEGA_Z, j)]
    jxx = W[at(OFF_E, J_XX, j)]
    jyy = W[at(OFF_E, J_YY, j)]
    jzz = W[at(OFF_E, J_ZZ, j)]
    jxy = W[at(OFF_E, J_XY, j)]
    jxz = W[at(OFF_E, J_XZ, j)]
    jyz = W[at(OFF_E, J_YZ, j)]
    cvm = W[at(OFF_E, DAMPING_PM, j)]
    g0, g1, g2 = cross(
        w0,
        w1,
        w2,
        jxx * w0 + jxy * w1 + jxz * w2,
        jxy * w0 + jyy * w1 + jyz * w2,
        jxz * w0 + jyz * w1 + jzz * w2,
    )
    g0 = -g0 - cvm * w0
    g1 = -g1 - cvm * w1
    g2 = -g2 - cvm * w2
    a0, a1, a2 = cross(
        kxx * g0 + kxy * g1 + kxz * g2,
        kxy * g0 + kyy * g1 + kyz * g2,
        kxz * g0 + kyz * g1 + kzz * g2,
        r0,
        r1,
        r2,
    )
    g = W[at(OFF_P, GRAV, j)]
    a0 += W[at(OFF_G, WW_X, j)] - g * n0
    a1 += W[at(OFF_G, WW_Y, j)] - g * n1
    a2 += W[at(OFF_G, WW_Z, j)] - g * n2
    press = -(a0 * n0 + a1 * n1 + a2 * n2)  # −A_z, what the normal force must hold up
    ax = (a0 * x0 + a1 * x1 + a2 * x2) / press
    ay = (a0 * y0 + a1 * y1 + a2 * y2) / press
    ex = gx
    ey = gy
    for _ in range(CONSISTENT_ITERATIONS):
        f, df, _ = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
        # the direction of u turns at a rate ∝ −f: only roots where f rises attract it.
        # Newton towards those; elsewhere the largest step along the turn
        step = -f / df if df > 0.0 else (-0.5 if f > 0.0 else 0.5)
        step = min(max(step, -0.5), 0.5)
        ex, ey = ex - step * ey, ey + step * ex
        norm = 1.0 / math.sqrt(ex * ex + ey * ey)
        ex *= norm
        ey *= norm
        if abs(step) < NEWTON_TOL:  # quadratic convergence: the next step is far smaller
            break
        if ex * dx + ey * dy <= 0.5:  # out of the cone searched: no root taken there
            break
    _, df, dd = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
    nm = press / dd
    # |u| times the rate at which u's direction relaxes onto d*: N f'(φ*) for the angle φ
    # of u, whose rate is −N f(φ) / |u|, m/s²
    slope = nm * df
    found = (press > 0.0) & (dd > 0.0) & (slope > 0.0) & (ex * dx + ey * dy > 0.5)
    if not found:
        return dx, dy, -1.0
    return ex, ey, slope


@inline_kernel
def turn_rate(W, j, x, y, h):
    """Rate (rad/s) at which lane j's consistent slip direction turned over the last step
    (h, s), to (x, y) from the one at the step before's start; 0 where there is none yet
    (a zero vector)."""
    px = W[at(OFF_S, S_DPX, j)]
    py = W[at(OFF_S, S_DPY, j)]
    return math.atan2(px * y - py * x, px * x + py * y) / h


@kernel
def slip_direction(W, state, one_lane, lane, history):
    """Phase between :func:`contact_kinematics` and :func:`accelerations`: the friction
    direction û of every slipping lane, world horizontal, into UHAT.

    A slip whose direction relaxes slowly enough for the step, τ = |u| / s ≥ dt /
    ``RELAX_STEPS`` (:func:`consistent_direction`), uses û = u/|u|. A faster one lies on
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
    visits only the lanes that need it. Sticking lanes keep their stored direction; the
    stepper reads it only in slip.
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
        # the guess: the last step start's d* (at this step's start, where the block may
        # be evaluated again, the one before, so that each evaluation solves alike)
        gx = W[at(OFF_S, S_DPX, j)] if history else W[at(OFF_S, S_DCX, j)]
        gy = W[at(OFF_S, S_DPY, j)] if history else W[at(OFF_S, S_DCY, j)]
        dx = W[at(OFF_S, S_UHX, j)]
        dy = W[at(OFF_S, S_UHY, j)]
        none = gx * gx + gy * gy < 0.5  # no d* yet: the launch's step
        cx, cy, slope = consistent_direction(
            W,
            j,
            state,
            W[at(OFF_P, MU_K, j)],
            dx if none else gx,
            dy if none else gy,
            dx,
            dy,
        )
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


def steer(W, slip_possible, state, one_lane, lane, history):
    """:func:`slip_direction` where lanes may slip (``slip_possible``, a literal, not
    ``ROLLING``); nothing, and nothing compiled, where every lane sticks."""


@overload(steer, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _steer(W, slip_possible, state, one_lane, lane, history):
    if not isinstance(slip_possible, (types.IntegerLiteral, types.BooleanLiteral)):
        raise TypingError("slip_possible must be a literal (numba.literally)")
    if slip_possible.literal_value == ROLLING:
        return lambda W, slip_possible, state, one_lane, lane, history: None
    return lambda W, slip_possible, state, one_lane, lane, history: slip_direction(
        W, state, one_lane, lane, history
    )
