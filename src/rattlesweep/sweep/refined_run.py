"""Running a refined sweep (:mod:`.refine`) level by level into a resumable directory.

The directory holds ``sweep.toml``, ``levels/level-K/tile-NNNNNN.nc`` (the simulated
points of level K, a tile of at most ``tile_size`` of them per file, written atomically
as it finishes, with each point's flat index into the finest grid) and ``sweep.nc``,
the result on the finest grid, written at the end. Which points a level simulates
follows from the levels before it alone, so a resume replays the levels from their
files, computes only the tiles missing, and reaches the same result.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import xarray as xr

from ..rattleback import batch
from .._run import kernels_compiled
from ..io import NETCDF_LOCK, stale_temporaries
from .directory import CONFIG_NAME, RESULT_NAME, TileDirectory, write_text_atomic
from .execute import run_tiles
from .merge import grid_coords, result_attrs
from .progress import Progress
from .refine import Levels, plan_level
from .spec import Sweep
from .tiles import (
    NOT_COMPUTED,
    compute_points,
    extra_vars,
    result_dtypes,
    result_names,
    variable_attrs,
)

__all__ = [
    "COMPUTED_ATTRS",
    "LEVELS_DIR",
    "LevelTile",
    "LevelTileResult",
    "RefinedDirectory",
    "compute_level_tile",
    "level_tile_path",
    "run_refined",
]

LEVELS_DIR = "levels"

COMPUTED_ATTRS = {
    "long_name": "point simulated or filled",
    "flag_values": [0, 1],
    "flag_meanings": "filled simulated",
    "comment": "simulated: the launch was run. filled: it was not; the point lies in a "
    "cell of the refined grid whose simulated corners agree (same outcome, and "
    "first reversal times within reversal_time_jump when given), and has "
    "their outcome, status, n_reversals and steps from the nearest corner and "
    "the other results interpolated between them.",
}
"""CF attributes of a refined result's ``computed`` flag."""


@dataclass(frozen=True)
class LevelTile:
    """A task: the points ``index`` (flat indices into the finest grid) of tile ``tile``
    of refinement level ``level``."""

    level: int
    tile: int
    index: np.ndarray

    @property
    def key(self) -> str:
        return f"level{self.level}-{self.tile}"


@dataclass(frozen=True)
class LevelTileResult:
    """A finished :class:`LevelTile`: every per-point variable, the trajectory-steps
    taken and the task's wall time (s)."""

    level: int
    tile: int
    index: np.ndarray
    data: dict[str, np.ndarray]
    steps: int
    seconds: float

    def summary(self) -> dict[str, Any]:
        return {
            "tile": self.tile,
            "n": len(self.index),
            "steps": self.steps,
            "seconds": self.seconds,
        }


def compute_level_tile(fine: Sweep, item: LevelTile) -> LevelTileResult:
    """Simulate the points of one level's tile on the finest grid ``fine``."""
    t0 = time.perf_counter()
    data, steps = compute_points(fine, item.index)
    return LevelTileResult(
        item.level, item.tile, item.index, data, steps, time.perf_counter() - t0
    )


def level_tile_path(levels_dir: Path, level: int, tile: int) -> Path:
    return Path(levels_dir) / f"level-{level}" / f"tile-{tile:06d}.nc"


class RefinedDirectory(TileDirectory):
    """The output directory of a refined sweep (see the module's description): the
    configuration check and lock of :class:`.TileDirectory`, tiles per level."""

    def __init__(
        self, sweep: Sweep, out_dir: str | os.PathLike[str], *, command: str | None = None
    ) -> None:
        super().__init__(sweep, out_dir, command=command)
        self.tiles_dir = self.out / LEVELS_DIR
        self.fine = sweep.finest()

    def _prepare(self) -> list[int]:
        config = self._check_config()
        self.make_tiles_dir()
        levels = (d for d in self.tiles_dir.glob("level-*") if d.is_dir())
        for stale in (p for d in levels for p in stale_temporaries(d, "tile-*.nc")):
            stale.unlink(missing_ok=True)
        if not config.exists():
            write_text_atomic(config, self.sweep.to_toml())
        self.written = len(list(self.tiles_dir.glob("level-*/tile-*.nc")))
        return []

    def scan(self, items: list[LevelTile]) -> tuple[list[LevelTileResult], list[LevelTile]]:
        """The tiles of a level already written (read back) and those still to compute.
        Unreadable files, and files of other points, are deleted to be computed again;
        files of another configuration are refused."""
        done, todo, foreign = [], [], []
        for item in items:
            path = level_tile_path(self.tiles_dir, item.level, item.tile)
            state = self._read(path, item) if path.exists() else "missing"
            if isinstance(state, LevelTileResult):
                done.append(state)
                continue
            todo.append(item)
            if state == "foreign":
                foreign.append(path)
            elif state == "damaged":
                path.unlink()
        if foreign:
            raise ValueError(
                f"{self.tiles_dir} holds {len(foreign)} tiles of another configuration (the "
                f"first: {foreign[0]}), so {self.out / CONFIG_NAME} does not describe "
                "them: restore the configuration, or use a new directory"
            )
        return done, todo

    def _read(self, path: Path, item: LevelTile) -> LevelTileResult | str:
        names = result_names(self.fine)
        try:
            with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
                if nc.getncattr("config_hash") != self.sweep.config_hash():
                    return "foreign"
                nc.set_auto_mask(False)
                if (
                    int(nc.getncattr("level")) != item.level
                    or int(nc.getncattr("tile")) != item.tile
                    or not np.array_equal(nc.variables["point"][:], item.index)
                ):
                    return "damaged"
                data = {name: nc.variables[name][:] for name in names}
        except Exception:  # any failure to read means: recompute
            return "damaged"
        return LevelTileResult(
            item.level, item.tile, item.index, data, int(np.sum(data["steps"])), 0.0
        )

    # The ignores: a refined directory keeps TileDirectory's configuration check and lock
    # but holds other tiles and result; it is never used as a TileDirectory.
    def write(self, result: LevelTileResult) -> None:  # type: ignore[override]
        path = level_tile_path(self.tiles_dir, result.level, result.tile)
        ds = xr.Dataset(
            {k: ("point", v, variable_attrs(self.fine, k)) for k, v in result.data.items()},
            coords={
                "point": (
                    "point",
                    result.index,
                    {"long_name": "flat index into the finest grid"},
                )
            },
        )
        ds.attrs.update(
            {
                "config_hash": self.sweep.config_hash(),
                "level": result.level,
                "tile": result.tile,
            }
        )
        self._write_file(ds, path)
        self.written += 1

    def finish(self, ds: xr.Dataset) -> xr.Dataset:  # type: ignore[override]
        """Write the result ``sweep.nc`` (atomically) and return it."""
        self._write_file(ds, self.out / RESULT_NAME)
        return ds


def _empty_values(fine: Sweep) -> dict[str, np.ndarray]:
    """The kernel's results and ``outcome`` over the finest grid, none known yet."""
    out = {}
    for name, dtype in result_dtypes(fine).items():
        if name in extra_vars(fine):
            continue
        fill = NOT_COMPUTED if dtype.kind in "iu" else np.nan
        out[name] = np.full(fine.shape, fill, dtype=dtype)
    return out


def _inputs(fine: Sweep) -> dict[str, np.ndarray]:
    """The per-point inputs a result holds (default time step, random draws) at every
    point of the finest grid: computed, never filled."""
    index = np.arange(fine.size, dtype=np.int64)
    out = {}
    if "dt" in extra_vars(fine):
        bodies, kwargs = fine.points_at(index)
        out["dt"] = (
            batch.launch_inputs(bodies, announce=False, **kwargs)
            .flat["dt"]
            .reshape(fine.shape)
        )
    for rp in fine.random_params:
        out[rp.name] = rp.result_draw(fine.seed, index).reshape(fine.shape)
    return out


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
    values = _empty_values(fine)
    computed = np.zeros(fine.shape, dtype=bool)

    def apply(result: LevelTileResult) -> None:
        for name, v in values.items():
            v.ravel()[result.index] = result.data[name]
        computed.ravel()[result.index] = True

    store = RefinedDirectory(sweep, out, command=command)
    store.open()
    try:
        for level in range(levels.levels + 1):
            index = (
                levels.level0()
                if level == 0
                else plan_level(
                    values, computed, levels, level, refine.get("reversal_time_jump")
                )
            )
            size = sweep.tile_size
            items = [
                LevelTile(level, t, index[a : a + size])
                for t, a in enumerate(range(0, len(index), size))
            ]
            done, todo = store.scan(items)
            for result in done:
                apply(result)
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
                apply(result)
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
        return store.finish(_dataset(sweep, fine, values, computed, command))
    finally:
        store.close()


def _dataset(
    sweep: Sweep,
    fine: Sweep,
    values: dict[str, np.ndarray],
    computed: np.ndarray,
    command: str | None,
) -> xr.Dataset:
    arrays = {**values, **_inputs(fine)}
    data = {
        name: (fine.dims, arrays[name], variable_attrs(fine, name))
        for name in result_names(fine)
    }
    data["computed"] = (fine.dims, computed.astype(np.int8), COMPUTED_ATTRS)
    ds = xr.Dataset(data, coords=grid_coords(fine), attrs=result_attrs(sweep, command))
    ds.attrs["points_simulated"] = int(computed.sum())
    return ds
