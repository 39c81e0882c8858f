"""Reversals, observed once per step over the lanes of a block: the spin's first
reversal (its crossing of zero, confirmed beyond a band on the other side) and the
heading's reversals (turns back by more than ``HEADING_BAND`` from the furthest the long
axis reached in its present sense), counted, with the stop rule that ends a lane at its
first reversal.
"""

from __future__ import annotations

import math

import numba

from . import models
from .jit import inline_kernel, kernel
from .workspace import (
    BEYOND,
    BLOCK,
    COS2_HEADING_BAND,
    CROSSED,
    DT,
    K_BAND,
    K_FIRST_REV,
    K_HEAD_EXT_X,
    K_HEAD_EXT_Y,
    K_HEAD_SENSE,
    K_HEAD_TURNS,
    K_MARK_REVERSAL,
    K_N_REV,
    K_PENDING,
    K_RUN,
    K_SIDE,
    K_SLIP_STEPS,
    K_SPIN_PREV,
    K_STOP,
    K_T_CAND,
    K_T_CROSS,
    K_WATCH_LOW,
    K_WIN0,
    K_WIN_CNT,
    K_WIN_SUM,
    NOT_MARKED,
    OFF_K,
    OFF_P,
    OFF_S,
    S_MODE,
    STOP_AT_REVERSAL,
    STOP_RULE,
    TURNED_BACK,
    at,
)

__all__ = ["cut_turns", "note_reversals", "observe"]


@kernel
def observe(W, model, step):
    """Update the run observables from the new state Y, and mark (a sum of the marks)
    the lanes whose spin crossed zero (CROSSED) or went beyond the reversal band on the
    other side (BEYOND), and those whose heading turned back by more than HEADING_BAND
    from the furthest it reached in its present sense (TURNED_BACK); returns how many it
    marked. Frozen lanes are updated too: harmless, nothing reads them."""
    numba.literally(model)
    n = 0
    for j in range(BLOCK):
        spin, watched = models.spin_and_watch(W, model, j)
        W[at(OFF_K, K_SLIP_STEPS, j)] += W[at(OFF_S, S_MODE, j)]
        W[at(OFF_K, K_WATCH_LOW, j)] = min(W[at(OFF_K, K_WATCH_LOW, j)], watched)
        window = 1.0 if step >= W[at(OFF_K, K_WIN0, j)] else 0.0
        W[at(OFF_K, K_WIN_SUM, j)] += window * spin
        W[at(OFF_K, K_WIN_CNT, j)] += window
        # the first reversal: the spin crossed zero and went beyond the band on the
        # other side; it is reported at the (linearly interpolated) crossing instant
        dt = W[at(OFF_P, DT, j)]
        side = W[at(OFF_K, K_SIDE, j)]
        spin_prev = W[at(OFF_K, K_SPIN_PREV, j)]
        W[at(OFF_K, K_T_CAND, j)] = (step + 1) * dt - dt * spin / (spin - spin_prev)
        crossed = (side * spin_prev > 0.0) & (side * spin <= 0.0)
        beyond = side * spin < -W[at(OFF_K, K_BAND, j)]
        W[at(OFF_K, K_SPIN_PREV, j)] = spin
        # the heading's reversals: the furthest direction in the present sense follows
        # the heading while it turns that way; a turn back by more than HEADING_BAND from
        # there is a reversal (angles from cross and dot products: no trigonometry per
        # step). The furthest direction stays within the band of the heading, so its
        # whole turns across the cut of atan2 (the half-line X < 0, Y = 0) unwrap both.
        hx, hy = models.heading(W, model, j)
        ex = W[at(OFF_K, K_HEAD_EXT_X, j)]
        ey = W[at(OFF_K, K_HEAD_EXT_Y, j)]
        sense = W[at(OFF_K, K_HEAD_SENSE, j)]
        turn = sense * (ex * hy - ey * hx)
        dot = ex * hx + ey * hy
        # (without a sense, for a launch without spin, it follows the heading throughout)
        ahead = ((turn > 0.0) & (dot > 0.0)) | (sense == 0.0)
        nx = hx if ahead else ex
        ny = hy if ahead else ey
        W[at(OFF_K, K_HEAD_EXT_X, j)] = nx
        W[at(OFF_K, K_HEAD_EXT_Y, j)] = ny
        W[at(OFF_K, K_HEAD_TURNS, j)] += cut_turns(ex, ey, nx, ny)
        back = (turn < 0.0) & (
            (dot <= 0.0)
            | (dot * dot < COS2_HEADING_BAND * (ex * ex + ey * ey) * (hx * hx + hy * hy))
        )
        W[at(OFF_K, K_MARK_REVERSAL, j)] = (
            (float(CROSSED) if crossed else NOT_MARKED)
            + (float(BEYOND) if beyond else NOT_MARKED)
            + (float(TURNED_BACK) if back else NOT_MARKED)
        )
        n += 1 if crossed | beyond | back else 0
    return n


@inline_kernel
def cut_turns(ox, oy, nx, ny):
    """+1 when a direction moving from (ox, oy) to (nx, ny) (a small turn) crosses the
    cut of atan2 at +-pi counter-clockwise, -1 clockwise, else 0 (a direction with
    Y = -0.0 counts as above the cut, as ``atan2(y + 0.0, x)`` puts it)."""
    cut = (nx < 0.0) & (ox < 0.0)
    return (1.0 if cut & (oy >= 0.0) & (ny < 0.0) else 0.0) - (
        1.0 if cut & (oy < 0.0) & (ny >= 0.0) else 0.0
    )


@kernel
def note_reversals(W, model, step):
    """Act on the marks :func:`observe` left in the step that reached step ``step``:
    the spin's first reversal time, and the heading's reversals, counted, each of which
    turns the sense the heading is followed in. A lane whose stop rule is
    STOP_AT_REVERSAL ends at the step where it has both a first reversal time and a
    heading reversal (whichever came second): its last step becomes ``step``. Returns
    how many lanes it so ended. A first reversal the heading has not confirmed stays
    pending until the spin crosses back to its launch side."""
    numba.literally(model)
    n = 0
    for j in range(BLOCK):
        mark = int(W[at(OFF_K, K_MARK_REVERSAL, j)])
        if mark & CROSSED:
            W[at(OFF_K, K_T_CROSS, j)] = W[at(OFF_K, K_T_CAND, j)]
            W[at(OFF_K, K_PENDING, j)] = 0.0
        if mark & BEYOND:
            if math.isnan(W[at(OFF_K, K_FIRST_REV, j)]):
                W[at(OFF_K, K_FIRST_REV, j)] = W[at(OFF_K, K_T_CROSS, j)]
                W[at(OFF_K, K_PENDING, j)] = 1.0 if W[at(OFF_K, K_N_REV, j)] == 0.0 else 0.0
            W[at(OFF_K, K_SIDE, j)] = -W[at(OFF_K, K_SIDE, j)]
        if mark & TURNED_BACK:
            W[at(OFF_K, K_N_REV, j)] += 1.0
            W[at(OFF_K, K_PENDING, j)] = 0.0
            W[at(OFF_K, K_HEAD_SENSE, j)] = -W[at(OFF_K, K_HEAD_SENSE, j)]
            hx, hy = models.heading(W, model, j)
            W[at(OFF_K, K_HEAD_TURNS, j)] += cut_turns(
                W[at(OFF_K, K_HEAD_EXT_X, j)], W[at(OFF_K, K_HEAD_EXT_Y, j)], hx, hy
            )
            W[at(OFF_K, K_HEAD_EXT_X, j)] = hx
            W[at(OFF_K, K_HEAD_EXT_Y, j)] = hy
        if (
            mark != 0
            and W[at(OFF_P, STOP_RULE, j)] == STOP_AT_REVERSAL
            and W[at(OFF_K, K_RUN, j)] > 0.5
            and W[at(OFF_K, K_STOP, j)] > step
            and W[at(OFF_K, K_N_REV, j)] > 0.0
            and not math.isnan(W[at(OFF_K, K_FIRST_REV, j)])
        ):
            W[at(OFF_K, K_STOP, j)] = step
            n += 1
    return n
