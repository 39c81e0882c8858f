"""The stages of a refined sweep (:mod:`.plan`): one per level, whose points are planned
from the results of the levels before it, held by its output
(:class:`~rattlesweep.sweep._outputs.refined.RefinedDirectory`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterator

from .._execution.stage import Stage
from .._execution.tiles import LevelTile, compute_level_tile
from .plan import Levels, plan_level

if TYPE_CHECKING:
    from .._outputs.refined import RefinedDirectory

__all__ = ["level_stages"]


def level_stages(directory: RefinedDirectory) -> Iterator[Stage]:
    """The levels of the refined sweep of ``directory``, each a stage of tiles of at most
    ``tile_size`` points on the finest grid. A level's points follow from the results the
    directory holds when it is asked for the level, so each is planned only once the
    levels before it are written; tiles an earlier run wrote are read back, not run."""
    sweep, fine = directory.sweep, directory.fine
    refine = sweep.refine
    assert refine is not None, "a refined sweep's directory"
    levels = Levels(
        fine.shape,
        tuple(list(fine.axes).index(k) for k in refine["axes"]),
        refine["levels"],
    )
    size = sweep.tile_size
    for level in range(levels.levels + 1):
        index = (
            levels.level0()
            if level == 0
            else plan_level(
                directory.values,
                directory.computed,
                levels,
                level,
                refine.get("reversal_time_jump"),
            )
        )
        items = [
            LevelTile(level, t, index[a : a + size])
            for t, a in enumerate(range(0, len(index), size))
        ]
        done, todo = directory.scan(items)
        yield Stage(
            fine,
            todo,
            len(items),
            len(index),
            len(done),
            sum(len(r.index) for r in done),
            compute=compute_level_tile,
            label=f"level {level} of {levels.levels}",
        )
