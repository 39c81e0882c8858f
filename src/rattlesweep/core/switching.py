"""Coulomb stick/slip switching (MODEL.md section 4), decided once per step and per lane,
in the shared rows of every model (:mod:`.workspace`).

* slip → stick when the slip velocity reversed over the last step, or a decaying slip is
  about to die (|u| < μ_k g dt and smaller than a step earlier): the model's plastic
  contact impulse sets u = 0 exactly;
* stick → slip when |F_t| > μ_s N, starting with the slip direction û = −F_t/|F_t|.

Each decision is a vector pass over the lanes that marks the few lanes needing scalar
work in a row of its own (``K_MARK_SWITCH``) and returns how many it marked (an integer
sum that vectorises with the pass); the scalar work runs only when that is not zero.
"""

from __future__ import annotations

import math

import numba

from . import models
from .jit import kernel
from .workspace import (
    BLOCK, DT, EPS_U, GRAV, K_MARK_SWITCH, K_RUN, MU_K, MU_S, OFF_K, OFF_P, OFF_S, OFF_X,
    NOT_MARKED, S_JX, S_JY, S_MODE, S_UHX, S_UHY, S_UPREV, S_USX, S_USY, SWITCHES, X_FX, X_FY,
    X_N, X_UX, X_UY, at,
)

__all__ = [
    "any_slipping", "flag_restick", "flag_slip_start", "note_slip", "start_slip",
    "stick_marked", "slip_marked",
]


@kernel
def any_slipping(W):
    """True when some lane still being stepped is in slip mode."""
    for j in range(BLOCK):
        if W[at(OFF_K, K_RUN, j)] > 0.5 and W[at(OFF_S, S_MODE, j)] > 0.5:
            return True
    return False


@kernel
def note_slip(W, j):
    """Remember lane j's slip velocity at the start of this step (and its direction)."""
    ux = W[at(OFF_X, X_UX, j)]
    uy = W[at(OFF_X, X_UY, j)]
    uu = math.sqrt(ux * ux + uy * uy)
    W[at(OFF_S, S_USX, j)] = ux
    W[at(OFF_S, S_USY, j)] = uy
    W[at(OFF_S, S_UPREV, j)] = uu
    if uu > W[at(OFF_P, EPS_U, j)]:
        W[at(OFF_S, S_UHX, j)] = ux / uu
        W[at(OFF_S, S_UHY, j)] = uy / uu


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
    W[at(OFF_S, S_UPREV, j)] = 0.0  # an onset slip grows: never "decaying" at once


@kernel
def flag_restick(W):
    """Mark the slipping lanes that stick again: their slip velocity reversed over the
    last step, or a decaying slip would die within the next one (|u| < μ_k g dt and
    smaller than a step earlier). Returns how many."""
    n = 0
    for j in range(BLOCK):
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        reversed_ = ux * W[at(OFF_S, S_USX, j)] + uy * W[at(OFF_S, S_USY, j)] < 0.0
        dying = ((uu < W[at(OFF_P, MU_K, j)] * W[at(OFF_P, GRAV, j)] * W[at(OFF_P, DT, j)])
                 & (uu < W[at(OFF_S, S_UPREV, j)]))
        mark = ((W[at(OFF_K, K_RUN, j)] > 0.5) & (W[at(OFF_S, S_MODE, j)] > 0.5)
                & (W[at(OFF_P, MU_S, j)] > 0.0) & (reversed_ | dying))
        W[at(OFF_K, K_MARK_SWITCH, j)] = SWITCHES if mark else NOT_MARKED
        n += 1 if mark else 0
    return n


@kernel
def stick_marked(W, model):
    """Slip → stick for every marked lane: a plastic contact impulse brings its contact
    point to rest. The impulse is friction too, and is kept for the record."""
    numba.literally(model)
    for j in range(BLOCK):
        if W[at(OFF_K, K_MARK_SWITCH, j)] == SWITCHES:
            W[at(OFF_S, S_MODE, j)] = 0.0
            jx, jy = models.stick_impulse(W, model, j)
            W[at(OFF_S, S_JX, j)] += jx
            W[at(OFF_S, S_JY, j)] += jy


@kernel
def flag_slip_start(W):
    """Mark the sticking lanes whose friction leaves the cone, |F_t| > μ_s N (μ_s
    finite, N ≥ 0); in the same pass the slipping lanes remember this step's slip
    velocity (as :func:`note_slip`). Returns how many lanes it marked."""
    n = 0
    for j in range(BLOCK):
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        normal = W[at(OFF_X, X_N, j)]
        fx = W[at(OFF_X, X_FX, j)]
        fy = W[at(OFF_X, X_FY, j)]
        mu_s = W[at(OFF_P, MU_S, j)]
        mark = (run & (not slipping) & (mu_s < math.inf) & (normal >= 0.0)
                & (math.sqrt(fx * fx + fy * fy) > mu_s * normal))
        W[at(OFF_K, K_MARK_SWITCH, j)] = SWITCHES if mark else NOT_MARKED
        n += 1 if mark else 0

        note = run & slipping
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        W[at(OFF_S, S_USX, j)] = ux if note else W[at(OFF_S, S_USX, j)]
        W[at(OFF_S, S_USY, j)] = uy if note else W[at(OFF_S, S_USY, j)]
        W[at(OFF_S, S_UPREV, j)] = uu if note else W[at(OFF_S, S_UPREV, j)]
        turn = note & (uu > W[at(OFF_P, EPS_U, j)])
        W[at(OFF_S, S_UHX, j)] = ux / uu if turn else W[at(OFF_S, S_UHX, j)]
        W[at(OFF_S, S_UHY, j)] = uy / uu if turn else W[at(OFF_S, S_UHY, j)]
    return n


@kernel
def slip_marked(W):
    """Stick → slip for every marked lane."""
    for j in range(BLOCK):
        if W[at(OFF_K, K_MARK_SWITCH, j)] == SWITCHES:
            start_slip(W, j)
