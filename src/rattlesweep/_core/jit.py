"""Numba compile policy for every kernel in :mod:`rattlesweep._core`.

All kernels are compiled with the same options so that the whole engine has one
behaviour:

* ``nogil=True`` so callers may run kernels from their own threads (a parallel batch
  spreads its blocks over threads; so does the sweep layer its tiles).
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
  workspace with NumPy, so they are compiled with :data:`allocating_kernel` and use
  numba's reference-counting runtime (NRT). Every helper they call only reads and writes
  arrays it is given, and is compiled without NRT (``_nrt=False``), so it takes no
  references: with NRT each helper call would increment and decrement its array
  arguments' reference counts with atomic instructions, which threads stepping blocks
  of one batch at once would contend for. Such a helper cannot allocate an array or
  return one it was not given: numba refuses to compile either without NRT. The option
  is set explicitly on both kinds, because a function that leaves it unset inherits its
  caller's.
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

Several processes may compile into one cache at once (``rattlesweep compile`` runs
several; so may a cluster's workers sharing ``NUMBA_CACHE_DIR``). Numba writes each file
atomically, but it numbers a new signature's data file by reading the index, and two
processes adding different signatures of one kernel at once would both pick the same
number: the index would then name the other signature's machine code. So every cached
kernel here saves through :class:`LockedCacheFile`, which holds an exclusive lock on a
file beside the index for the whole read-choose-write, and writes the data before the
index that names it, so that a reader never finds an entry whose data is not there yet.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import itertools
import os
from pathlib import Path
from typing import Any, Callable, Iterator

import numba
from numba.core.caching import FunctionCache, IndexDataCacheFile

__all__ = [
    "FASTMATH",
    "JIT_OPTIONS",
    "LockedCacheFile",
    "OVERLOAD_OPTIONS",
    "allocating_kernel",
    "cache_directories",
    "drop_stale_cache",
    "inline_kernel",
    "kernel",
    "on_disk",
]

FASTMATH = {"nsz"}  # see the module docstring for what is left out, and why

_COMMON = dict(nogil=True, cache=True, error_model="numpy", fastmath=FASTMATH)

JIT_OPTIONS = dict(**_COMMON, _nrt=False)
"""Options of every helper kernel."""

# Any: numba's stubs type an overload's jit_options as a TypedDict of the public options,
# which lacks _nrt
OVERLOAD_OPTIONS: Any = {k: v for k, v in JIT_OPTIONS.items() if k != "cache"}
"""Options of the overloads (``at``, the model hooks): they are compiled into their
callers, which are cached themselves."""


class LockedCacheFile(IndexDataCacheFile):
    """numba's index-and-data cache file, saved under an exclusive lock (``fcntl.flock``
    on ``<index>.lock``) so that processes compiling into one cache at once never give
    two signatures the same data file; the data is written before the index names it."""

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        os.makedirs(self._cache_path, exist_ok=True)
        with open(self._index_path + ".lock", "a") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)

    def save(self, key: Any, data: Any) -> None:
        with self._locked():
            overloads = self._load_index()
            data_name = overloads.get(key)
            if data_name is None:
                used = set(overloads.values())
                data_name = next(
                    name
                    for name in map(self._data_name, itertools.count(1))
                    if name not in used
                )
            self._save_data(data_name, data)
            if overloads.get(key) != data_name:
                overloads[key] = data_name
                self._save_index(overloads)


def _jit(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """A decorator compiling with ``options`` whose on-disk cache saves through
    :class:`LockedCacheFile`."""

    def decorate(function: Callable[..., Any]) -> Any:
        dispatcher = numba.njit(**options)(function)
        cache_file = dispatcher._cache._cache_file
        if type(cache_file) is IndexDataCacheFile:  # the same file, saved under the lock
            cache_file.__class__ = LockedCacheFile
        return dispatcher

    return decorate


kernel = _jit(**JIT_OPTIONS)
"""Decorator for helpers and scalar functions: no NRT, so no allocation (see above)."""

allocating_kernel = _jit(**_COMMON, _nrt=True)
"""Decorator for a serial function that allocates a block workspace (with NRT)."""

inline_kernel = _jit(**_COMMON, inline="always", _nrt=False)
"""Decorator for a lane body that callers specialise with literal flags: inlined in numba
IR, so LLVM folds the flag's branches away in each copy."""


def _numba_cache_dir(source: Path) -> Path:
    """The directory numba caches the kernels of the module file ``source`` in, chosen as
    numba chooses it for a kernel of that file (the first of its locators that can
    write there); RuntimeError when none can."""
    namespace: dict = {}
    exec(compile("def probe(): pass", str(source), "exec"), namespace)
    return Path(FunctionCache(namespace["probe"]).cache_path)


NOT_COMPILED = ("specialisations.py",)
"""Modules of this package that hold no kernel code (the list of what to compile): an
edit of one keeps the cached kernels."""


def _kernel_sources(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*.py") if p.name not in NOT_COMPILED)


def cache_directories(root: Path = Path(__file__).parent) -> list[Path]:
    """The directories numba caches the kernels of the package at ``root`` in, one per
    source directory, root's own first (it holds the stamp of :func:`drop_stale_cache`);
    RuntimeError when numba can cache in none of them."""
    directories = sorted({path.parent for path in root.rglob("*.py")})
    return [_numba_cache_dir(next(directory.glob("*.py"))) for directory in directories]


def drop_stale_cache(
    root: Path = Path(__file__).parent, depends_on: tuple[Path, ...] = ()
) -> bool:
    """Delete the cached kernels (``*.nbi``/``*.nbc``) of the package at ``root``, in
    the directories numba caches its modules in, unless they were written from its
    current sources and those of the packages at ``depends_on`` (whose kernels its own
    inline); True when it deleted them. A read-only installation is left as it is
    (numba caches its kernels elsewhere)."""
    sources = _kernel_sources(root)
    digest = hashlib.sha256()
    for base, paths in [(root, sources)] + [(d, _kernel_sources(d)) for d in depends_on]:
        for path in paths:
            digest.update(path.relative_to(base).as_posix().encode())
            digest.update(path.read_bytes())
    try:
        caches = cache_directories(root)
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


def on_disk(dispatcher: Any, signature: tuple[Any, ...]) -> bool:
    """True when numba's on-disk cache holds machine code of the cached kernel
    ``dispatcher`` for a signature beginning with the numba types ``signature`` (a
    whole signature, or its leading literal arguments), written from the current
    sources, so that its first call in a process loads it rather than compiling it:
    callers use it to say so before a first call that would compile."""
    index = dispatcher._cache._cache_file._load_index()  # {} when absent or stale
    wanted = tuple(signature)
    return any(tuple(key[0][: len(wanted)]) == wanted for key in index)


drop_stale_cache()
