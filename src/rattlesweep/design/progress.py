"""What a design run says as it goes.

numba compiles the engine's kernels on their first call in a fresh installation (one to
three minutes on a small machine) and caches them on disk; later runs load them. A run
that says nothing during that minute looks frozen, so :func:`design` says when it
expects to compile (:func:`rattlesweep._run.kernels_compiled`).
"""

from __future__ import annotations

from typing import Callable

__all__ = ["Progress", "quiet"]

Progress = Callable[[str], None]
"""Takes one line of progress (no newline)."""


def quiet(line: str) -> None:
    """A :data:`Progress` that says nothing."""
