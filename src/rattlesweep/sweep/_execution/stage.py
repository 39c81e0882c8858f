"""A stage of a sweep's execution: one round of tile tasks the runner hands to its
workers and whose results it writes into the output. A uniform sweep is one stage; a
refined sweep one stage per level, each planned from the results of those before it
(:mod:`~rattlesweep.sweep._refinement.stages`). The output says what its stages are
(``stages()`` of each output), and the runner
(:func:`~rattlesweep.sweep._execution.run.run_sweep`) runs them all the same way."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from .._config.spec import Sweep
from .tiles import compute_tile

__all__ = ["Stage", "uniform_stage"]


@dataclass(frozen=True)
class Stage:
    """The tasks ``todo`` of one stage, each computed as ``compute(sweep, task)``; the
    stage's size in tiles and points, and how much of it an earlier run wrote already
    (for the progress bar, whose last line starts with ``label``, or "done")."""

    sweep: Sweep
    todo: list[Any]
    tiles: int
    points: int
    tiles_done: int
    points_done: int
    compute: Callable[[Sweep, Any], Any] = compute_tile
    label: str = ""


def uniform_stage(sweep: Sweep, todo: list[int]) -> Stage:
    """The only stage of a uniform sweep: the tiles ``todo`` still to compute."""
    left = set(todo)
    done = [t for t in range(sweep.n_tiles) if t not in left]
    points = 0
    for tile in done:
        start, stop = sweep.tile_range(tile)
        points += stop - start
    return Stage(sweep, todo, sweep.n_tiles, sweep.size, len(done), points)
