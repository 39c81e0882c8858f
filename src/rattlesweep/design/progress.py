"""What a design run says as it goes, and whether the simulation kernels are compiled.

numba compiles the engine's kernels on their first call in a fresh installation (one to
three minutes on a small machine) and caches them on disk; later runs load them. A run
that says nothing during that minute looks frozen, so :func:`design` says when it
expects to compile.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

__all__ = ["Progress", "kernels_cached", "quiet"]

Progress = Callable[[str], None]
"""Takes one line of progress (no newline)."""

_ENTRY_POINTS = ("advance_block", "integrate_parallel")
"""The stepper's kernels every batch runs through: cached, the rest is cached too."""


def quiet(line: str) -> None:
    """A :data:`Progress` that says nothing."""


def kernels_cached() -> bool:
    """Whether numba's on-disk cache holds the stepper's entry kernels (their index
    files, ``stepper.<kernel>-<line>.py<version>.nbi``, where numba caches the module's
    kernels)."""
    from ..core import stepper
    from ..core.jit import _numba_cache_dir

    try:
        cache = _numba_cache_dir(Path(stepper.__file__))
    except (RuntimeError, OSError):
        return False
    return all(any(cache.glob(f"stepper.{name}-*.nbi")) for name in _ENTRY_POINTS)
