"""The classic RK4 stage arithmetic, fused into each model's derivative loop.

A model's right-hand side computes the derivative ``dk`` of state row k of lane j and
hands it to :func:`put_derivative`, which uses it as the stage asks, so that the
derivative never goes to memory on its own (Y is the state at the start of the step,
T the stage state, A the accumulator, h the time step):

* ``STAGE_START`` and ``STAGE_FIRST``: A = d and T = Y + (h/2) d (the semi-implicit Euler
  step also starts from A = d);
* ``STAGE_MID``, the second and third stages: A += 2d and T = Y + c d, with c = h/2 in
  the second and h in the third (:func:`set_mid_stage` sets it): one compiled variant for
  both;
* ``STAGE_4``: Y = Y + (h/6)(A + d), the new state, in place, and B = the old Y, kept
  for a lane whose step fails or whose contact mode changed inside the step.

The two first stages differ only in which contact outputs the model writes (see
:mod:`.workspace`).
"""

from __future__ import annotations

import numba

from .jit import kernel
from .workspace import (
    DT,
    H_HALF_DT,
    H_SIXTH_DT,
    H_STAGE_DT,
    OFF_H,
    OFF_P,
    STAGE_FIRST,
    STAGE_MID,
    STAGE_START,
    at,
    lane_range,
)

__all__ = ["first_stage", "put_derivative", "set_mid_stage", "set_step_fractions"]


@kernel
def first_stage(stage):
    """True for the stages that evaluate the step-start state, region Y."""
    return stage == STAGE_START or stage == STAGE_FIRST


@kernel
def put_derivative(W, j, row, stage, dk, stage_state, off_y, off_t, off_a, off_b):
    """Use lane j's derivative ``dk`` of a state row as ``stage`` asks. ``row`` is
    k·BLOCK + j for state row k; ``stage_state`` says whether the stage state T has row
    k (a row no stage reads, such as a position, needs none); ``off_y``, ``off_t``,
    ``off_a`` and ``off_b`` are the model's offsets of regions Y, T, A and B.

    The row comes as a number that depends on j, not as the literal k: numba compiles a
    function once per combination of literal arguments, and a literal k would make a
    copy per state row of each stage's variant (seconds of compile time). The compiled
    calls are inlined into the lane loop all the same.
    """
    a = at(off_a, 0, row)
    t = at(off_t, 0, row)
    y = at(off_y, 0, row)
    if first_stage(stage):
        W[a] = dk
        if stage_state:
            W[t] = W[y] + W[at(OFF_H, H_HALF_DT, j)] * dk
    elif stage == STAGE_MID:
        W[a] += 2.0 * dk
        if stage_state:
            W[t] = W[y] + W[at(OFF_H, H_STAGE_DT, j)] * dk
    else:
        y_old = W[y]
        W[y] = y_old + W[at(OFF_H, H_SIXTH_DT, j)] * (W[a] + dk)
        W[at(off_b, 0, row)] = y_old


@kernel
def set_step_fractions(W, j):
    """Fill lane j's fractions of the time step (region H) from its DT."""
    h = W[at(OFF_P, DT, j)]
    W[at(OFF_H, H_HALF_DT, j)] = 0.5 * h
    W[at(OFF_H, H_SIXTH_DT, j)] = h / 6.0


@kernel
def set_mid_stage(W, third, one_lane, lane):
    """Make the next ``STAGE_MID`` the third stage of RK4 (``third``, stage state at a
    whole step) or the second (half a step), for every lane or (``one_lane``, a literal)
    lane ``lane`` alone."""
    numba.literally(one_lane)
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        W[at(OFF_H, H_STAGE_DT, j)] = (
            W[at(OFF_P, DT, j)] if third else W[at(OFF_H, H_HALF_DT, j)]
        )
