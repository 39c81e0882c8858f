"""Tiles: contiguous runs of flat grid points, each computed by one task on one core and
written atomically to its own netCDF file, so an interrupted sweep loses at most the tiles
in flight."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import netCDF4
import numpy as np
import xarray as xr

from .. import engine, results
from ..batch import MODEL, prepare
from ..engine import check_method
from ..io import NETCDF_LOCK, write_netcdf
from .outcomes import OUTCOME_ATTRS, classify
from .spec import Sweep

__all__ = ["CANCEL", "RESULT_VARS", "compute_tile", "extra_vars", "read_tile",
           "tile_is_valid", "tile_path", "variable_attrs"]

RESULT_VARS = MODEL.observables
"""Kernel observables kept for every point, besides ``outcome``."""

CANCEL = threading.Event()
"""Set to make tiles not yet started return at once (Ctrl-C on the local scheduler)."""


def tile_path(tiles_dir: Path, tile: int) -> Path:
    return Path(tiles_dir) / f"tile-{tile:06d}.nc"


def extra_vars(sweep: Sweep) -> tuple[str, ...]:
    """Per-point variables besides the observables: the default time step when dt is not
    given, and the random draws."""
    given = {k[:-4] if k.endswith("_deg") else k for k in (*sweep.axes, *sweep.fixed)}
    return (("dt",) if "dt" not in given else ()) + tuple(r.key for r in sweep.random_params)


def variable_attrs(sweep: Sweep, name: str) -> dict:
    """CF attributes of a per-point result variable."""
    if name == "outcome":
        return dict(OUTCOME_ATTRS)
    if name == "dt":
        return {"units": "s", "long_name": "time step (the body's default)"}
    for rp in sweep.random_params:
        if rp.key == name:
            return {"units": rp.units, "long_name": f"{rp.long_name} (random draw, "
                    f"{rp.kind} {rp.a:g}, {rp.b:g})"}
    return MODEL.attrs(name)


def compute_tile(sweep: Sweep, tile: int, tiles_dir: str) -> dict:
    """Run one tile through the kernel on the calling thread (numba's serial ``nogil``
    entry, so tasks on different threads run in parallel without nesting threads) and
    write its file atomically. Returns a small summary."""
    if CANCEL.is_set():
        return {"tile": tile, "n": 0, "skipped": True}
    t0 = time.perf_counter()
    start, stop = sweep.tile_range(tile)
    bodies, kwargs = sweep.points(start, stop)
    prep = prepare(bodies, **kwargs)
    raw = engine.execute(prep, method=check_method(sweep.method), record_every=None,
                        band=sweep.reversal_band, parallel=False)
    data = results.observables_dataset(MODEL, raw.observables, "point")
    ds = xr.Dataset({k: data[k] for k in RESULT_VARS})
    ds["outcome"] = ("point", classify(ds.status.values, ds.n_reversals.values,
                                       ds.mean_final_spin.values, ds.initial_spin.values,
                                       sweep.reversal_band), variable_attrs(sweep, "outcome"))
    index = np.arange(start, stop, dtype=np.int64)
    if "dt" in extra_vars(sweep):
        ds["dt"] = ("point", prep.coords["dt"][1], variable_attrs(sweep, "dt"))
    for rp in sweep.random_params:
        ds[rp.key] = ("point", rp.draw(sweep.seed, index), variable_attrs(sweep, rp.key))
    ds = ds.assign_coords(point=("point", index))
    ds.attrs.update({"config_hash": sweep.config_hash(), "tile": tile, "start": start,
                     "stop": stop})
    write_netcdf(ds, tile_path(Path(tiles_dir), tile))
    steps = int(np.sum(prep.nsteps))
    return {"tile": tile, "n": stop - start, "steps": steps,
            "seconds": time.perf_counter() - t0, "skipped": False}


def tile_is_valid(path: Path, sweep: Sweep, tile: int) -> bool:
    """True when ``path`` is a complete tile file of this sweep (a truncated, corrupt or
    foreign file is not)."""
    start, stop = sweep.tile_range(tile)
    try:
        with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
            if nc.getncattr("config_hash") != sweep.config_hash():
                return False
            if int(nc.getncattr("tile")) != tile:
                return False
            for name in (*RESULT_VARS, "outcome", "point", *extra_vars(sweep)):
                var = nc.variables[name]
                if var.shape != (stop - start,):
                    return False
                var[:]  # read the data: a truncated file fails here
            return bool(nc.variables["point"][0] == start)
    except Exception:  # any failure to read means: recompute
        return False


def read_tile(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The named variables of a tile file as plain arrays."""
    with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        return {name: nc.variables[name][:] for name in names}
