"""A finished zarr store written as one netCDF file (``rattlesweep export``)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Mapping

from .verify import finish_advice
from .zarr_store import (
    check_coords,
    check_tiles,
    damage_report,
    open_result,
    stored_sweep,
    metadata_damage,
    tiles_done,
)

__all__ = ["export_netcdf"]


def export_netcdf(
    location: str, out: str | os.PathLike, storage_options: Mapping[str, Any] | None = None
) -> Path:
    """Write a finished store as one netCDF file (what a netCDF sweep writes as
    ``sweep.nc``), atomically, reading one tile at a time. An unfinished store is
    refused, and so is one with a tile missing or damaged (naming it), as every chunk is
    verified first."""
    import dask

    from ...io import write_netcdf

    sweep = stored_sweep(location, storage_options)
    done = tiles_done(location, sweep.n_tiles, storage_options)
    if done is None or not done.all():
        missing = sweep.n_tiles if done is None else int((~done).sum())
        raise ValueError(
            f"{location} is unfinished ({missing} of {sweep.n_tiles} tiles "
            "not computed); "
            + finish_advice(location, f"complete it with `rattlesweep resume {location}`")
        )
    bad = check_tiles(location, sweep, None, storage_options)
    if bad:
        raise ValueError(
            f"{location}: {damage_report(bad, sweep.n_tiles)}; nothing was "
            f"exported. `rattlesweep resume {location}` recomputes them"
        )
    coords = check_coords(location, sweep, storage_options)
    coords += metadata_damage(location, sweep, storage_options)
    if coords:
        raise ValueError(
            f"{location}: {'; '.join(coords)}; nothing was exported. "
            f"`rattlesweep resume {location}` writes them again"
        )
    ds = open_result(location, storage_options)
    for var in ds.variables.values():
        var.encoding = {}
    with dask.config.set(scheduler="synchronous"):
        return write_netcdf(ds, out)
