"""A sweep's result as one labelled dataset over its axes: coordinates, attributes, and
the merge of its tiles."""

from __future__ import annotations

import datetime
import platform
import sys
from typing import Any, Iterable

import dask
import netCDF4
import numba
import numpy as np
import xarray as xr

from ... import __version__
from ..._results import run_attrs
from .._config.params import resolve, result_name, result_values
from .._config.spec import Sweep, fixed_value
from .._execution.tiles import variable_attrs

__all__ = ["grid_coords", "merge_arrays", "result_attrs", "sweep_attrs", "versions"]


def versions() -> dict[str, str]:
    """Versions of rattlesweep and the libraries that shape its results."""
    return {
        "rattlesweep_version": __version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "xarray_version": xr.__version__,
        "dask_version": dask.__version__,
        "netCDF4_version": netCDF4.__version__,
        "netcdf_library_version": netCDF4.__netcdf4libversion__,
        "python_version": platform.python_version(),
    }


def sweep_attrs(sweep: Sweep, title: str, command: str | None) -> dict[str, Any]:
    """Global attributes of a result on a sweep's grid: title, the configuration and its
    hash, the dimensions, versions, and ``history`` (UTC date and ``command``, by default
    the process's command line)."""
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return {
        **versions(),
        "title": title,
        "sweep_name": sweep.name,
        "sweep_config": sweep.to_toml(),
        "sweep_config_hash": sweep.config_hash(),
        "sweep_dims": list(sweep.dims),
        "history": f"{now} {command or ' '.join(sys.argv)}",
    }


def grid_coords(sweep: Sweep) -> dict[str, Any]:
    """Coordinates of a result on the sweep's grid: the axes (in the user's units, angles
    in degrees), the ``repeat`` index when there are random draws, and the fixed values
    as scalars, each named as in :func:`rattlesweep.run_batch` results
    (:func:`~rattlesweep.sweep._config.params.result_name`)."""
    coords: dict[str, Any] = {}
    for ax in sweep.grid_axes:
        attrs = {"long_name": ax.long_name}
        values, units = ax.coordinate()
        if ax.param != "body":
            attrs["units"] = units
        coords[ax.name] = (ax.name, values, attrs)
    if sweep.random:
        coords["repeat"] = (
            "repeat",
            np.arange(sweep.repeats),
            {"long_name": "repeat of the grid cell (random draws)"},
        )
    for key, value in sweep.fixed.items():
        if key == "body":
            name = (
                value
                if isinstance(value, str)
                else value.get("name", value.get("body_name", "custom"))
            )
            coords["body"] = (
                (),
                name,
                {
                    "long_name": "body (preset name or label); full "
                    "description in sweep_config"
                },
            )
            continue
        number, given_units = fixed_value(value)
        param, factor, cf = resolve(key, given_units, f"fixed.{key}")
        number, cf = result_values(key, number, factor, cf)
        coords[result_name(key)] = (
            (),
            float(number),
            {"units": cf, "long_name": param.long_name},
        )
    return coords


def result_attrs(sweep: Sweep, command: str | None) -> dict[str, Any]:
    """Global attributes of a sweep's result: the run's settings, the configuration,
    versions and ``history``."""
    attrs = run_attrs(
        sweep.method, None, sweep.reversal_band, sweep.stop, lyapunov=sweep.lyapunov
    )
    del attrs["record_every"]
    attrs.update(sweep_attrs(sweep, f"rattlesweep parameter sweep: {sweep.name}", command))
    return attrs


def merge_arrays(
    sweep: Sweep,
    tiles: Iterable[tuple[tuple[int, int], dict[str, np.ndarray]]],
    *,
    command: str | None = None,
) -> xr.Dataset:
    """A Dataset over the sweep's dimensions, with CF attributes and the configuration
    and versions as global attributes, from every tile's ``((start, stop), arrays)``.

    Memory: one array per variable over the whole grid (about 120 bytes per point).
    """
    flat: dict[str, np.ndarray] = {}
    for (start, stop), arrays in tiles:
        for name, values in arrays.items():
            if name not in flat:
                flat[name] = np.empty(sweep.size, dtype=values.dtype)
            flat[name][start:stop] = values
    data = {
        name: (sweep.dims, values.reshape(sweep.shape), variable_attrs(sweep, name))
        for name, values in flat.items()
    }
    return xr.Dataset(data, coords=grid_coords(sweep), attrs=result_attrs(sweep, command))
