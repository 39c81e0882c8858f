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

__all__ = ["level_stages", "level_tiles", "sweep_levels"]


def sweep_levels(directory: RefinedDirectory) -> Levels:
    """The levels of the refined sweep of ``directory`` over its finest grid."""
    refine = directory.sweep.refine
    assert refine is not None, "a refined sweep's directory"
    fine = directory.fine
    return Levels(
        fine.shape,
        tuple(list(fine.axes).index(k) for k in refine["axes"]),
        refine["levels"],
    )


def level_tiles(directory: RefinedDirectory, levels: Levels, level: int) -> list[LevelTile]:
    """Level ``level``'s tiles of at most ``tile_size`` points on the finest grid,
    planned from the results ``directory`` holds (those of the levels before it)."""
    refine = directory.sweep.refine
    assert refine is not None, "a refined sweep's directory"
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
    size = directory.sweep.tile_size
    return [
        LevelTile(level, t, index[a : a + size])
        for t, a in enumerate(range(0, len(index), size))
    ]


def level_stages(directory: RefinedDirectory) -> Iterator[Stage]:
    """The levels of the refined sweep of ``directory``, each a stage of tiles of at most
    ``tile_size`` points on the finest grid. A level's points follow from the results the
    directory holds when it is asked for the level, so each is planned only once the
    levels before it are written; tiles an earlier run wrote are read back, not run."""
    levels = sweep_levels(directory)
    for level in range(levels.levels + 1):
        items = level_tiles(directory, levels, level)
        done, todo = directory.scan(items)
        yield Stage(
            directory.fine,
            todo,
            len(items),
            sum(len(item.index) for item in items),
            len(done),
            sum(len(r.index) for r in done),
            compute=compute_level_tile,
            label=f"level {level} of {levels.levels}",
        )
