"""Numba compile policy for every kernel in :mod:`rattlesweep._core`.

All kernels are compiled with the same options so that the whole engine has one
behaviour:

* ``nogil=True`` so callers may run kernels from their own threads (the sweep layer).
* ``cache=True`` so the first call in a new process loads machine code from disk.
* ``error_model="numpy"``: division by zero gives inf/NaN instead of raising. Besides
  matching the "bad trajectories get a status flag" rule, the Python error model puts a
  branch on every division, which stops LLVM vectorising the lane loops.
* fast-math reduced to ``nsz`` (no signed zeros), :data:`FASTMATH`. Never ``nnan``/``ninf``:
  they would let LLVM drop the non-finite checks that give trajectories their
  ``non_finite`` status. Never ``reassoc``, ``contract`` or ``arcp``: the right-hand side
  is compiled in two variants (with and without slip work, chosen per block), and with
  those flags LLVM may round the same stick-lane arithmetic differently in each, so a
  trajectory's result would depend on its neighbours in the batch. Without them every
  operation is IEEE-exact in every variant and lane, and results do not depend on the
  position in the batch or the batch size (a test checks this).
* Two kinds of function. Only the block drivers own arrays: they allocate the block
  workspace with NumPy, so they are compiled with :data:`allocating_kernel` (or
  :data:`parallel_kernel`) and use numba's reference-counting runtime (NRT). Every helper
  they call only reads and writes arrays it is given, and is compiled without NRT
  (``_nrt=False``), so it takes no references: with NRT each helper call would increment
  and decrement its array arguments' reference counts with atomic instructions, and the
  threads of the parallel entry point would contend for the shared observables array's
  count. Such a helper cannot allocate an array or return one it was not given: numba
  refuses to compile either without NRT. The option is set explicitly on both kinds,
  because a function that leaves it unset inherits its caller's.
* The model hooks of :mod:`.models` and the accessor ``workspace.at`` are numba
  overloads compiled with :data:`OVERLOAD_OPTIONS`, the helpers' options.

Numba's on-disk cache is keyed on each kernel's own source file only, but the stepper's
cached machine code contains every model hook it calls from other files: after an edit
of a model, numba would load a stepper compiled with the old one. So
:func:`drop_stale_cache` runs when this package is imported: when any source file of
``rattlesweep._core`` changed since the cache was written, it deletes the package's
cached kernels, and they are compiled afresh. It looks for them where numba keeps them:
next to the sources, or outside the package (``NUMBA_CACHE_DIR``, or the user's cache
directory when the package is read-only, where an upgrade in place would otherwise
meet the kernels of the previous version). Kernels elsewhere that inline this package's,
such as the tests' own, are dropped the same way by naming it in ``depends_on``.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path
from typing import Any

import numba
from numba.core.caching import FunctionCache

__all__ = [
    "FASTMATH",
    "JIT_OPTIONS",
    "OVERLOAD_OPTIONS",
    "allocating_kernel",
    "drop_stale_cache",
    "inline_kernel",
    "kernel",
    "on_disk",
    "parallel_kernel",
]

FASTMATH = {"nsz"}  # see the module docstring for what is left out, and why

JIT_OPTIONS = dict(
    nogil=True, cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False
)
"""Options of every helper kernel."""

# Any: numba's stubs type an overload's jit_options as a TypedDict of the public options,
# which lacks _nrt
OVERLOAD_OPTIONS: Any = {k: v for k, v in JIT_OPTIONS.items() if k != "cache"}
"""Options of the overloads (``at``, the model hooks): they are compiled into their
callers, which are cached themselves."""

kernel = functools.partial(numba.njit, **JIT_OPTIONS)
"""Decorator for helpers and scalar functions: no NRT, so no allocation (see above)."""

allocating_kernel = functools.partial(
    numba.njit, nogil=True, cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=True
)
"""Decorator for a serial function that allocates a block workspace (with NRT)."""

inline_kernel = functools.partial(
    numba.njit,
    nogil=True,
    cache=True,
    error_model="numpy",
    fastmath=FASTMATH,
    inline="always",
    _nrt=False,
)
"""Decorator for a lane body that callers specialise with literal flags: inlined in numba
IR, so LLVM folds the flag's branches away in each copy."""

parallel_kernel = functools.partial(
    numba.njit,
    nogil=True,
    cache=True,
    error_model="numpy",
    fastmath=FASTMATH,
    parallel=True,
    _nrt=True,
)
"""Decorator for the one entry point that spreads blocks over numba threads."""


def _numba_cache_dir(source: Path) -> Path:
    """The directory numba caches the kernels of the module file ``source`` in, chosen as
    numba chooses it for a kernel of that file (the first of its locators that can
    write there); RuntimeError when none can."""
    namespace: dict = {}
    exec(compile("def probe(): pass", str(source), "exec"), namespace)
    return Path(FunctionCache(namespace["probe"]).cache_path)


def drop_stale_cache(
    root: Path = Path(__file__).parent, depends_on: tuple[Path, ...] = ()
) -> bool:
    """Delete the cached kernels (``*.nbi``/``*.nbc``) of the package at ``root``, in
    the directories numba caches its modules in, unless they were written from its
    current sources and those of the packages at ``depends_on`` (whose kernels its own
    inline); True when it deleted them. A read-only installation is left as it is
    (numba caches its kernels elsewhere)."""
    sources = sorted(root.rglob("*.py"))
    digest = hashlib.sha256()
    for base, paths in [(root, sources)] + [
        (d, sorted(d.rglob("*.py"))) for d in depends_on
    ]:
        for path in paths:
            digest.update(path.relative_to(base).as_posix().encode())
            digest.update(path.read_bytes())
    try:
        # root's own directory first: it holds the stamp
        caches = [
            _numba_cache_dir(next(directory.glob("*.py")))
            for directory in sorted({path.parent for path in sources})
        ]
    except (RuntimeError, OSError):  # numba cannot cache there at all: nothing to drop
        return False
    stamp = caches[0] / "kernel-sources.sha256"
    try:
        if stamp.read_text() == digest.hexdigest():
            return False
    except OSError:
        pass
    try:
        for cache in caches:
            for cached in cache.glob("*.nb[ic]"):
                cached.unlink(missing_ok=True)
        tmp = stamp.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(digest.hexdigest())
        tmp.replace(stamp)
    except OSError:
        return False
    return True


def on_disk(dispatcher: Any, *literals: int) -> bool:
    """True when numba's on-disk cache holds machine code of the cached kernel
    ``dispatcher`` for a signature whose leading arguments are the literal integers
    ``literals`` (any signature when none are given), written from the current sources,
    so that its first call in a process loads it rather than compiling it: callers use
    it to say so before a first call that would compile."""
    index = dispatcher._cache._cache_file._load_index()  # {} when absent or stale
    wanted = tuple(numba.types.literal(value) for value in literals)
    return any(tuple(key[0][: len(wanted)]) == wanted for key in index)


drop_stale_cache()
