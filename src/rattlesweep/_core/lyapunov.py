"""The largest finite-time Lyapunov exponent of a lane, from a renormalised shadow lane.

A lane j of the first half of a block whose parameter ``lyapunov_steps`` is positive has
a shadow: lane ``j + HALF`` of the same block, launched at a nearby state (the batch
layer places it there). Both are stepped by the same arithmetic. Every ``lyapunov_steps``
steps of lane j, and once at the launch, :func:`renormalise` measures the distance d
between the two in the model's phase-space metric (:func:`.models.separation`), adds
ln(d / D0) to lane j's tally (not at the launch) and moves the shadow back along the
line joining them to the distance D0. At the end of the run the exponent is the tally,
with the last partial interval, over the time run: ``lyapunov = Σ ln(d_i / D0) / t``.

A shadow lane needs no arithmetic of its own: a renormalised finite difference is the
tangent-linear lane to within O(D0), and the same model code serves every model. D0 is
small enough that the separation stays linear over an interval (a growth of e^λτ for an
interval τ), large enough that rounding in a difference of states stays far below it.
The exponent of a lane depends on that lane and its shadow alone, which the batch layer
launches from the lane's own inputs: not on the neighbours, the tiling or the threads.

A shadow whose run ends before its lane's (non-finite, capsized or lifted off) loses the
exponent: the lane's tally becomes NaN. The exponent is meaningful only where every step
follows one smooth flow (rolling contact): the batch layer refuses it with stick/slip
friction, where the shadow could switch mode at another instant than its lane.
"""

from __future__ import annotations

import math

import numba

from . import models
from .jit import kernel
from .workspace import BLOCK, DT, K_LYAP_LOG, K_OPEN, K_RUN, LYAP_STEPS, OFF_K, OFF_P, at

__all__ = ["D0", "HALF", "exponent", "renormalise", "tracked"]

HALF = BLOCK // 2
"""Lane j < HALF of a block has its shadow at lane j + HALF."""

D0 = 1e-8
"""The distance the shadow is held at, after each renormalisation (dimensionless
phase-space metric of :func:`.models.separation`)."""


@kernel
def tracked(W):
    """True when some lane of the block has a shadow."""
    for j in range(HALF):
        if W[at(OFF_P, LYAP_STEPS, j)] > 0.0:
            return True
    return False


@kernel
def renormalise(W, model, steps, launch):
    """Renormalise the shadow of every running tracked lane whose ``steps`` (steps taken)
    is a multiple of its interval; at the ``launch`` every such shadow, without adding
    to the tally. The whole state of the shadow moves, so that its position (which the
    metric leaves out) stays with it."""
    numba.literally(model)
    off_y, _, _, _, n_state, _ = models.state_regions(model)
    for j in range(HALF):
        every = W[at(OFF_P, LYAP_STEPS, j)]
        if every <= 0.0 or W[at(OFF_K, K_RUN, j)] < 0.5:
            continue
        if not launch and steps % int(every) != 0:
            continue
        k = j + HALF
        d = models.separation(W, model, j, k)
        if W[at(OFF_K, K_OPEN, k)] < 0.5 or not (d > 0.0 and math.isfinite(d)):
            W[at(OFF_K, K_LYAP_LOG, j)] = math.nan
            continue
        if launch:
            W[at(OFF_K, K_LYAP_LOG, j)] = 0.0
        else:
            W[at(OFF_K, K_LYAP_LOG, j)] += math.log(d / D0)
        s = D0 / d
        for r in range(n_state):
            base = W[at(off_y, r, j)]
            W[at(off_y, r, k)] = base + s * (W[at(off_y, r, k)] - base)


@kernel
def exponent(W, model, j, steps):
    """Lane j's exponent (1/s) over its ``steps`` steps, the last partial interval
    included; NaN for a lane without a shadow, one that took no step, or one whose
    shadow was lost."""
    numba.literally(model)
    if j >= HALF or W[at(OFF_P, LYAP_STEPS, j)] <= 0.0 or steps <= 0:
        return math.nan
    k = j + HALF
    if W[at(OFF_K, K_OPEN, k)] < 0.5:
        return math.nan
    d = models.separation(W, model, j, k)
    if not (d > 0.0 and math.isfinite(d)):
        return math.nan
    return (W[at(OFF_K, K_LYAP_LOG, j)] + math.log(d / D0)) / (steps * W[at(OFF_P, DT, j)])
