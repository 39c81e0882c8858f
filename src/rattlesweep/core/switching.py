"""Coulomb stick/slip switching (MODEL.md section 4) in the shared rows of every model
(:mod:`.workspace`): which lanes change mode, in one vector pass per step.

* sticking → slipping where the friction sticking needs leaves the cone, |F_t| > μ_s N
  (μ_s finite, N ≥ 0): the cone margin g = μ_s N − |F_t| turned negative over the last
  step;
* slipping → sticking where the slip velocity u reaches zero. That is a zero of a
  2-vector, which no sign change of one function marks on a curved path, so each
  evaluation at a step start predicts it instead: the time to stop at the present
  deceleration, |u|² / (−u · u̇) (``X_TSTOP``). A slip whose slip velocity turned
  against its value at the start of the last step stopped inside it (exact for a model
  whose held slip continues smoothly past the stop, as the planar one's does); where
  modes change at step starts, a slip whose prediction at the last step start fell
  within ``STOP_HORIZON`` steps sticks too.

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
    BLOCK, DT, EPS_U, K_MARK_SWITCH, K_RUN, MU_S, OFF_K, OFF_P, OFF_S, OFF_X, NOT_MARKED,
    S_MODE, S_TSTOP, S_UHX, S_UHY, S_USX, S_USY, SWITCHES, X_FX, X_FY, X_N, X_TSTOP, X_UX,
    X_UY, at,
)

__all__ = [
    "STOP_HORIZON", "any_slipping", "cone_margin", "flag_switches", "note_slip",
    "start_slip", "stop_time",
]

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
    W[at(OFF_S, S_TSTOP, j)] = W[at(OFF_X, X_TSTOP, j)] if note else W[at(OFF_S, S_TSTOP, j)]
    turn = note & (uu > W[at(OFF_P, EPS_U, j)])
    W[at(OFF_S, S_UHX, j)] = ux / uu if turn else W[at(OFF_S, S_UHX, j)]
    W[at(OFF_S, S_UHY, j)] = uy / uu if turn else W[at(OFF_S, S_UHY, j)]


@kernel
def note_slip(W, j):
    """Remember lane j's slip velocity at the start of this step (and its direction)."""
    remember_slip(W, j, True)


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


@kernel
def flag_switches(W, stops, horizon):
    """Mark (``SWITCHES`` in ``K_MARK_SWITCH``) the sticking lanes whose friction left the
    cone and, when ``stops`` (a literal), the slipping lanes (μ_s > 0) that may have
    stopped inside the last step: their slip velocity turned against its value at the
    step start, or their predicted stop time there was at most ``horizon`` steps (0 for
    a model whose held slip continues smoothly past a stop, so that the turn marks every
    stop). In the same pass the unmarked slipping lanes then remember this step's slip
    velocity and stop time (as :func:`note_slip`). Returns how many lanes it marked."""
    numba.literally(stops)
    n = 0
    for j in range(BLOCK):
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        leaves_cone = ((not slipping) & (W[at(OFF_X, X_N, j)] >= 0.0)
                       & (cone_margin(W, j) < 0.0))
        turned = (W[at(OFF_X, X_UX, j)] * W[at(OFF_S, S_USX, j)]
                  + W[at(OFF_X, X_UY, j)] * W[at(OFF_S, S_USY, j)]) < 0.0
        stopped = slipping & (W[at(OFF_P, MU_S, j)] > 0.0) & (
            (W[at(OFF_S, S_TSTOP, j)] <= horizon * W[at(OFF_P, DT, j)]) | turned)
        mark = run & (leaves_cone | (stops & stopped))
        W[at(OFF_K, K_MARK_SWITCH, j)] = SWITCHES if mark else NOT_MARKED
        n += 1 if mark else 0
        if stops:
            remember_slip(W, j, run & slipping & (not mark))
    return n
