"""Running a refined sweep (:mod:`.plan`) level by level into its output
(:class:`~rattlesweep.sweep._outputs.refined.RefinedDirectory`)."""

from __future__ import annotations

import os
from typing import Any

import xarray as xr

from ..._run import kernels_compiled
from .._config.spec import Sweep
from .._execution.execute import run_tiles
from .._execution.progress import Progress
from .._execution.tiles import LevelTile, LevelTileResult, compute_level_tile
from .._outputs.refined import RefinedDirectory
from .._outputs.store import TileStore
from .plan import Levels, plan_level

__all__ = ["run_refined"]


def run_refined(
    sweep: Sweep,
    out: str | os.PathLike[str],
    *,
    client: Any = None,
    workers: int = 1,
    progress: bool = True,
    command: str | None = None,
) -> xr.Dataset:
    """Run the refined sweep ``sweep`` into the directory ``out`` and return its result
    on the finest grid (arguments as for :func:`rattlesweep.sweep.run_sweep`, which
    calls this for a sweep with ``refine``)."""
    refine = sweep.refine
    assert refine is not None, "run_refined runs a sweep with refine"
    fine = sweep.finest()
    levels = Levels(
        fine.shape,
        tuple(list(fine.axes).index(k) for k in refine["axes"]),
        refine["levels"],
    )
    directory = RefinedDirectory(sweep, out, command=command)
    # written and finished through the interface every output has
    store: TileStore[LevelTileResult] = directory
    store.open()
    try:
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
            size = sweep.tile_size
            items = [
                LevelTile(level, t, index[a : a + size])
                for t, a in enumerate(range(0, len(index), size))
            ]
            done, todo = directory.scan(items)
            bar = Progress(
                len(items),
                len(index),
                len(done),
                sum(len(r.index) for r in done),
                enabled=progress,
                compiling=client is None
                and not kernels_compiled(parallel=False, level=sweep.friction_level),
            )

            def write(result: LevelTileResult) -> None:
                store.write(result)
                bar.update(result.summary())

            try:
                run_tiles(
                    fine,
                    todo,
                    write,
                    client=client,
                    workers=workers,
                    compute=compute_level_tile,
                    on_wait=bar.tick,
                )
            except KeyboardInterrupt:
                bar.interrupted(store.location)
                raise
            bar.close(f"level {level} of {levels.levels}")
        return store.finish()
    finally:
        store.close()
