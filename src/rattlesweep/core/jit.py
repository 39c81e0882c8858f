"""Numba compile policy for every kernel in :mod:`rattlesweep.core`.

All kernels are compiled with the same options so that the whole engine has one
behaviour:

* ``nogil=True`` so callers may run kernels from their own threads (the sweep layer).
* ``cache=True`` so the first call in a new process loads machine code from disk.
* ``error_model="numpy"``: division by zero gives inf/NaN instead of raising. Besides
  matching the "bad trajectories get a status flag" rule, the Python error model puts a
  branch on every division, which stops LLVM vectorising the lane loops.
* a restricted fast-math set, :data:`FASTMATH`: fused multiply-add contraction, reciprocal
  multiplication and no signed zeros. Never ``nnan``/``ninf`` (they would let LLVM drop
  the non-finite checks that give trajectories their ``non_finite`` status) and never
  ``reassoc`` (re-ordered sums would make results depend on the code path). Every lane
  of a block runs the same vector instructions (the block size is a compile-time
  constant), so a trajectory's result does not depend on its position in the batch.
"""

from __future__ import annotations

import functools

import numba

FASTMATH = {"contract", "arcp", "nsz"}

kernel = functools.partial(
    numba.njit, nogil=True, cache=True, error_model="numpy", fastmath=FASTMATH
)
"""Decorator for serial kernels and scalar helpers."""

parallel_kernel = functools.partial(
    numba.njit, nogil=True, cache=True, error_model="numpy", fastmath=FASTMATH,
    parallel=True,
)
"""Decorator for the one entry point that spreads blocks over numba threads."""
