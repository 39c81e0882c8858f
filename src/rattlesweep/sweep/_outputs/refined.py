"""The output of a refined sweep (:mod:`~rattlesweep.sweep._refinement`): a resumable
directory.

The directory holds ``sweep.toml``, ``levels/level-K/tile-NNNNNN.nc`` (the simulated
points of level K, a tile of at most ``tile_size`` of them per file, written atomically
as it finishes, with each point's flat index into the finest grid) and ``sweep.nc``,
the result on the finest grid, written at the end. Which points a level simulates
follows from the levels before it alone, so a resume replays the levels from their
files, computes only the tiles missing, and reaches the same result.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterator

import netCDF4
import numpy as np
import xarray as xr

from ...io import (
    NETCDF_LOCK,
    stale_temporaries,
    unreadable_files,
    write_text_atomic,
)
from ...rattleback import batch
from .._config.spec import Sweep
from .._execution.stage import Stage
from .._execution.tiles import (
    NOT_COMPUTED,
    LevelTile,
    LevelTileResult,
    extra_vars,
    result_dtypes,
    result_names,
    variable_attrs,
)
from .directory import CONFIG_NAME, RESULT_NAME, SweepDirectory
from .merge import grid_coords, result_attrs

__all__ = [
    "COMPUTED_ATTRS",
    "LEVELS_DIR",
    "RefinedDirectory",
    "level_tile_path",
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


def level_tile_path(levels_dir: Path, level: int, tile: int) -> Path:
    return Path(levels_dir) / f"level-{level}" / f"tile-{tile:06d}.nc"


class RefinedDirectory(SweepDirectory):
    """The output directory of a refined sweep (see the module's description): tiles per
    level, and the results known so far over the finest grid (``values``, ``computed``),
    from which the next level is planned and the result is made."""

    def __init__(
        self, sweep: Sweep, out_dir: str | os.PathLike[str], *, command: str | None = None
    ) -> None:
        super().__init__(sweep, out_dir, command=command)
        self.tiles_dir = self.out / LEVELS_DIR
        self.fine = sweep.finest()
        self.values = _empty_values(self.fine)
        self.computed = np.zeros(self.fine.shape, dtype=bool)

    def _prepare(self) -> list[int]:
        config = self._check_config()
        self.make_tiles_dir()
        self.check_digests_in_way()
        levels = (d for d in self.tiles_dir.glob("level-*") if d.is_dir())
        for stale in (p for d in levels for p in stale_temporaries(d, "tile-*.nc")):
            stale.unlink(missing_ok=True)
        if config.exists():  # a merge of this sweep killed before its rename
            for stale in stale_temporaries(self.out, RESULT_NAME):
                stale.unlink(missing_ok=True)
        if not config.exists():
            write_text_atomic(config, self.sweep.to_toml())
        self.written = len(list(self.tiles_dir.glob("level-*/tile-*.nc")))
        return []

    def scan(self, items: list[LevelTile]) -> tuple[list[LevelTileResult], list[LevelTile]]:
        """The tiles of a level already written (read back and taken into the results)
        and those still to compute. Unreadable files, and files of other points, are
        deleted to be computed again; files of another configuration are refused."""
        done, todo, foreign = [], [], []
        paths = [level_tile_path(self.tiles_dir, i.level, i.tile) for i in items]
        # before the netCDF library opens them: damaged metadata can crash it
        unread = unreadable_files([p for p in paths if p.exists()])
        for item, path in zip(items, paths):
            if not path.exists():
                state: LevelTileResult | str = "missing"
            elif path in unread:
                state = "damaged"
            else:
                state = self._read(path, item)
            if isinstance(state, LevelTileResult):
                self._apply(state)
                done.append(state)
                continue
            todo.append(item)
            if state == "foreign":
                foreign.append(path)
            elif state == "damaged":
                path.unlink()
        if foreign:
            raise ValueError(
                f"{self.tiles_dir} holds {len(foreign)} tiles of another configuration "
                "(the "
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

    def stages(self) -> Iterator[Stage]:
        """One stage per level (:func:`~rattlesweep.sweep._refinement.stages.level_stages`),
        each planned from the results of the levels before it."""
        from .._refinement.stages import level_stages

        yield from level_stages(self)

    def _apply(self, result: LevelTileResult) -> None:
        for name, v in self.values.items():
            v.ravel()[result.index] = result.data[name]
        self.computed.ravel()[result.index] = True

    def write(self, result: LevelTileResult) -> None:
        """Write one finished tile of a level and take it into the results."""
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
        self._apply(result)

    def finish(self) -> xr.Dataset:
        """Write the result on the finest grid, ``sweep.nc`` (atomically), and return it."""
        ds = _dataset(self.sweep, self.fine, self.values, self.computed, self.command)
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
