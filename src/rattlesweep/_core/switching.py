"""Coulomb stick/slip switching (docs/model.md: dynamics) in the shared rows of every model
(:mod:`.workspace`): which lanes change mode, in one vector pass per step.

* sticking → slipping where the friction sticking needs leaves the cone, |F_t| > μ_s N
  (μ_s finite, N ≥ 0): the cone margin g = μ_s N − |F_t| turned negative over the last
  step;
* slipping → sticking where the slip velocity u reaches zero. That is a zero of a
  2-vector, which no sign change of one function marks on a curved path, so each
  evaluation at a step start predicts it instead: the time to stop at the present
  deceleration, |u|² / (−u · u̇) (``X_TSTOP``). A slip whose slip velocity turned
  against its value at the start of the last step stopped inside it, and so may one
  whose prediction at the last step start fell within the step (``LOCATED_STOP_HORIZON``;
  a 2-D slip velocity can pass by zero without turning in a step that ignores the stop);
  where modes change at step starts, a slip predicted to stop within ``STOP_HORIZON``
  steps sticks.

:func:`flag_switches` marks these lanes. With RK4 the stepper then redoes each marked
lane's last step with the switch located inside it (:mod:`.events`) for the models that
locate switches (``LOCATES_SWITCHES`` of each model); at the launch, with the
semi-implicit Euler method (first order anyway) and for the other models, the mode
changes at the step start instead.
"""

from __future__ import annotations

import math

import numba

from .jit import inline_kernel, kernel
from .workspace import (
    BLOCK,
    DT,
    EPS_U,
    K_MARK_SWITCH,
    K_RUN,
    MU_S,
    NOT_MARKED,
    OFF_K,
    OFF_P,
    OFF_S,
    OFF_X,
    ROLL_SWITCHES,
    S_DCX,
    S_DCY,
    S_DPX,
    S_DPY,
    S_MODE,
    S_ROLL,
    S_ROLL_SENSE,
    S_SPIN,
    S_SPIN_SENSE,
    S_TSTOP,
    S_TURN,
    S_TURN_BEFORE,
    S_UHX,
    S_UHY,
    S_USX,
    S_USY,
    SPIN_SWITCHES,
    SWITCHES,
    X_FX,
    X_FY,
    X_N,
    X_DCX,
    X_DCY,
    X_ROLL_COUPLE,
    X_ROLL_EVENT,
    X_SPIN_COUPLE,
    X_SPIN_EVENT,
    X_TSTOP,
    X_TURN,
    X_UX,
    X_UY,
    at,
)

__all__ = [
    "LOCATED_STOP_HORIZON",
    "STOP_HORIZON",
    "any_slipping",
    "cone_margin",
    "couple_margin",
    "flag_switches",
    "keep_directions",
    "note_slip",
    "pass_step",
    "start_slip",
    "stop_time",
    "switch_couples",
]

LOCATED_STOP_HORIZON = 1.0
"""Where switches are located, a slip predicted (at the last step start) to stop within
this many steps has its step redone with the stop located; one that then does not stop
slips on to the end of the step unchanged."""

STOP_HORIZON = 1.5
"""Where modes change at step starts, a slip predicted (at the last step start) to stop
within this many steps sticks: the margin covers a deceleration that grows during the
step."""


@kernel
def any_slipping(W):
    """True when some lane still being stepped is in slip mode."""
    for j in range(BLOCK):
        if W[at(OFF_K, K_RUN, j)] > 0.5 and W[at(OFF_S, S_MODE, j)] > 0.5:
            return True
    return False


@inline_kernel
def remember_slip(W, j, note):
    """When ``note``, remember lane j's slip velocity at the start of this step, its stop
    time and (when not negligible) its direction; otherwise leave them. Written as
    selects, so that a vector pass over the lanes stays branch-free."""
    ux = W[at(OFF_X, X_UX, j)]
    uy = W[at(OFF_X, X_UY, j)]
    uu = math.sqrt(ux * ux + uy * uy)
    W[at(OFF_S, S_USX, j)] = ux if note else W[at(OFF_S, S_USX, j)]
    W[at(OFF_S, S_USY, j)] = uy if note else W[at(OFF_S, S_USY, j)]
    W[at(OFF_S, S_TSTOP, j)] = (
        W[at(OFF_X, X_TSTOP, j)] if note else W[at(OFF_S, S_TSTOP, j)]
    )
    turn = note & (uu > W[at(OFF_P, EPS_U, j)])
    W[at(OFF_S, S_UHX, j)] = ux / uu if turn else W[at(OFF_S, S_UHX, j)]
    W[at(OFF_S, S_UHY, j)] = uy / uu if turn else W[at(OFF_S, S_UHY, j)]


@kernel
def note_slip(W, j):
    """Remember lane j's slip velocity at the start of this step (and its direction)."""
    remember_slip(W, j, True)


@kernel
def pass_step(W):
    """At the end of a step, every lane's consistent slip direction at its start becomes
    the one of the step before: the turn rate measured at the next step start is over
    one step, however often that start is evaluated."""
    for j in range(BLOCK):
        W[at(OFF_S, S_DPX, j)] = W[at(OFF_S, S_DCX, j)]
        W[at(OFF_S, S_DPY, j)] = W[at(OFF_S, S_DCY, j)]
        W[at(OFF_S, S_TURN_BEFORE, j)] = W[at(OFF_S, S_TURN, j)]


@kernel
def keep_directions(W):
    """After a step-start evaluation of the block with slip work, every slipping lane's
    consistent slip direction and its turn rate (contact outputs) become its switching
    state: the one place they are written, once per evaluation of a step start."""
    for j in range(BLOCK):
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        W[at(OFF_S, S_DCX, j)] = (
            W[at(OFF_X, X_DCX, j)] if slipping else W[at(OFF_S, S_DCX, j)]
        )
        W[at(OFF_S, S_DCY, j)] = (
            W[at(OFF_X, X_DCY, j)] if slipping else W[at(OFF_S, S_DCY, j)]
        )
        W[at(OFF_S, S_TURN, j)] = (
            W[at(OFF_X, X_TURN, j)] if slipping else W[at(OFF_S, S_TURN, j)]
        )


@kernel
def start_slip(W, j):
    """Stick → slip from rest, sliding opposite the friction sticking would need."""
    fx = W[at(OFF_X, X_FX, j)]
    fy = W[at(OFF_X, X_FY, j)]
    ft = math.sqrt(fx * fx + fy * fy)
    ux = -fx / ft
    uy = -fy / ft
    W[at(OFF_S, S_MODE, j)] = 1.0
    W[at(OFF_S, S_UHX, j)] = ux
    W[at(OFF_S, S_UHY, j)] = uy
    W[at(OFF_S, S_USX, j)] = ux  # the slip starts from rest in this direction
    W[at(OFF_S, S_USY, j)] = uy
    W[at(OFF_S, S_TSTOP, j)] = math.inf
    W[at(OFF_S, S_DCX, j)] = ux
    W[at(OFF_S, S_DCY, j)] = uy
    W[at(OFF_S, S_DPX, j)] = ux
    W[at(OFF_S, S_DPY, j)] = uy
    W[at(OFF_S, S_TURN, j)] = 0.0
    W[at(OFF_S, S_TURN_BEFORE, j)] = 0.0


@inline_kernel
def stop_time(ux, uy, dux, duy, uhx, uhy, eps):
    """Time (s) until a slip velocity u (m/s) reaches zero at a constant slip
    acceleration u̇ (m/s²) along it, |u|² / (−u · u̇); inf when it does not decelerate.
    A slip speed at or below ``eps`` (m/s) is at rest along the friction's direction
    û: stopped (0) when u̇ points against û, starting (inf) when along it."""
    speed2 = ux * ux + uy * uy
    closing = -(ux * dux + uy * duy)
    moving = speed2 > eps * eps
    t_moving = speed2 / closing if closing > 0.0 else math.inf
    t_rest = 0.0 if uhx * dux + uhy * duy < 0.0 else math.inf
    return t_moving if moving else t_rest


@inline_kernel
def cone_margin(W, j):
    """μ_s N − |F_t| of a sticking lane j, from the contact outputs of an evaluation at
    its state (N); inf when its static friction is infinite."""
    mu_s = W[at(OFF_P, MU_S, j)]
    fx = W[at(OFF_X, X_FX, j)]
    fy = W[at(OFF_X, X_FY, j)]
    margin = mu_s * W[at(OFF_X, X_N, j)] - math.sqrt(fx * fx + fy * fy)
    return math.inf if mu_s == math.inf else margin


@inline_kernel
def couple_margin(W, j):
    """The smaller of lane j's couples' switching functions (inf without couples), from
    the contact outputs of an evaluation at its state."""
    return min(W[at(OFF_X, X_SPIN_EVENT, j)], W[at(OFF_X, X_ROLL_EVENT, j)])


@kernel
def flag_switches(W, stops, horizon, couples):
    """Mark (in ``K_MARK_SWITCH``) the lanes whose contact modes may have changed over the
    last step: ``SWITCHES`` for the sticking lanes whose friction left the cone and, when
    ``stops`` (a literal), the slipping lanes (μ_s > 0) that may have stopped inside it
    (their slip velocity turned against its value at the step start, or their predicted
    stop time there was at most ``horizon`` steps); when ``couples``, plus
    ``SPIN_SWITCHES`` and ``ROLL_SWITCHES`` for the couples whose switching function
    (``X_SPIN_EVENT``, ``X_ROLL_EVENT``) turned negative. In the same pass the slipping
    lanes not marked for their sliding remember this step's slip velocity and stop time
    (as :func:`note_slip`). Returns how many lanes it marked."""
    numba.literally(stops)
    n = 0
    for j in range(BLOCK):
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        leaves_cone = (
            (not slipping) & (W[at(OFF_X, X_N, j)] >= 0.0) & (cone_margin(W, j) < 0.0)
        )
        turned = (
            W[at(OFF_X, X_UX, j)] * W[at(OFF_S, S_USX, j)]
            + W[at(OFF_X, X_UY, j)] * W[at(OFF_S, S_USY, j)]
        ) < 0.0
        stopped = (
            slipping
            & (W[at(OFF_P, MU_S, j)] > 0.0)
            & ((W[at(OFF_S, S_TSTOP, j)] <= horizon * W[at(OFF_P, DT, j)]) | turned)
        )
        slide = run & (leaves_cone | (stops & stopped))
        mark = SWITCHES if slide else NOT_MARKED
        if couples:
            mark += SPIN_SWITCHES if run & (W[at(OFF_X, X_SPIN_EVENT, j)] < 0.0) else 0.0
            mark += ROLL_SWITCHES if run & (W[at(OFF_X, X_ROLL_EVENT, j)] < 0.0) else 0.0
        W[at(OFF_K, K_MARK_SWITCH, j)] = mark
        n += 1 if mark != NOT_MARKED else 0
        if stops:
            remember_slip(W, j, run & slipping & (not slide))
    return n


@kernel
def toggle_couple(W, j, mode_row, sense_row, couple_row):
    """A couple's stick ↔ slip at a switch: a slipping couple sticks; a stuck one slips
    in the sense opposite the couple that held it (so the couple keeps its sign)."""
    if W[at(OFF_S, mode_row, j)] > 0.5:
        W[at(OFF_S, mode_row, j)] = 0.0
    else:
        W[at(OFF_S, mode_row, j)] = 1.0
        W[at(OFF_S, sense_row, j)] = -1.0 if W[at(OFF_X, couple_row, j)] > 0.0 else 1.0


@kernel
def switch_couples(W, j, mark):
    """Switch the couples of lane j that ``mark`` (a ``K_MARK_SWITCH`` value) names."""
    if mark >= ROLL_SWITCHES:
        toggle_couple(W, j, S_ROLL, S_ROLL_SENSE, X_ROLL_COUPLE)
        mark -= ROLL_SWITCHES
    if mark >= SPIN_SWITCHES:
        toggle_couple(W, j, S_SPIN, S_SPIN_SENSE, X_SPIN_COUPLE)
