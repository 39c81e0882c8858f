"""What a design run says as it goes.

A first run after installing compiles the engine's kernels; the engine says so itself,
once, through the logger ``rattlesweep`` (:mod:`rattlesweep._cold_start`).
"""

from __future__ import annotations

from typing import Callable

__all__ = ["Progress", "quiet"]

Progress = Callable[[str], None]
"""Takes one line of progress (no newline)."""


def quiet(line: str) -> None:
    """A :data:`Progress` that says nothing."""
