"""Results as labelled data: what the kernel returns for a batch or a single run, as an
xarray Dataset with CF attributes from the model's row tables (:mod:`rattlesweep._run`
runs the kernel)."""

from __future__ import annotations

import json
import warnings
from typing import Any, Callable, Mapping

import numba
import numpy as np
import xarray as xr

from ._version import __version__
from ._core.workspace import O_STATUS, O_T_END, OK, STATUS_NAMES
from ._model import Model, Prepared, Raw
from ._shadows import lyapunov_attrs

__all__ = [
    "MAX_DEFAULT_SAMPLES",
    "VECTOR_COORDS",
    "batch_dataset",
    "default_record_every",
    "observables_dataset",
    "run_attrs",
    "run_dataset",
    "series_dataset",
]

AttrsFor = Callable[[str], dict[str, Any]]
"""The CF attributes of an input or coordinate by name (a model's ``attrs_for``)."""

_DTYPES = {"status": np.int8, "steps": np.int64, "n_reversals": np.int64}

VECTOR_COORDS = {
    "quaternion_component": ["w", "x", "y", "z"],
    "body_axis": ["x", "y", "z"],
    "axis": ["X", "Y", "Z"],
    "horizontal": ["X", "Y"],
}
"""Labels of the vector dimensions of results."""

MAX_DEFAULT_SAMPLES = 10_000
"""A single run records at most this many samples unless ``record_every`` is given."""


def observables_dataset(
    model: Model, obs: np.ndarray, dim: str | None
) -> dict[str, xr.DataArray]:
    """Per-run observables (n_obs, n) as labelled DataArrays over ``dim`` (scalars for
    None)."""
    pick = (lambda row: obs[row]) if dim else (lambda row: obs[row, 0])
    values: dict[str, np.ndarray] = {}
    for name in model.observables:
        if name in model.derived:
            values[name] = model.derived[name][0](values)
        else:
            values[name] = pick(model.observable_row(name)).astype(_DTYPES.get(name, float))
    dims = (dim,) if dim else ()
    return {k: xr.DataArray(v, dims=dims, attrs=model.attrs(k)) for k, v in values.items()}


def series_dataset(
    model: Model, rec: np.ndarray, dims: tuple[str, ...]
) -> dict[str, xr.DataArray]:
    """Recorded time series (..., n_rec, n_record) as labelled DataArrays, one per row of
    the model's record table, plus ``slip_speed``, the magnitude of ``slip_velocity``."""
    out: dict[str, xr.DataArray] = {}
    for row in model.layout.RECORD:
        values = rec[..., model.layout.RECORD.slice(row.name)]
        extra = (row.dim,) if row.width > 1 else ()
        out[row.name] = xr.DataArray(
            values if extra else values[..., 0],
            dims=dims + extra,
            attrs={"units": row.units, "long_name": row.long_name},
        )
    u = out["slip_velocity"].values
    speed = np.hypot(u[..., 0], u[..., 1]) if u.ndim > len(dims) else np.abs(u)
    out["slip_speed"] = xr.DataArray(
        speed,
        dims=dims,
        attrs={"units": "m s-1", "long_name": "speed of the material contact point"},
    )
    return out


def _sample_times(prep: Prepared, records: np.ndarray, record_every: int) -> np.ndarray:
    return np.arange(records.shape[1]) * record_every * float(prep.coords["dt"][1][0])


def batch_dataset(
    prep: Prepared,
    raw: Raw,
    record_every: int | None,
    attrs_for: AttrsFor,
    global_attrs: Mapping[str, Any],
) -> xr.Dataset:
    """A batch's results over ``trajectory`` (and ``time`` when recorded), with every
    input as a coordinate; ``attrs_for(name)`` gives the CF attributes of an input."""
    data = observables_dataset(prep.model, raw.observables, "trajectory")
    coords: dict[str, Any] = {
        "trajectory": (
            "trajectory",
            np.arange(prep.n),
            {"long_name": "launch number within the batch", "units": "1"},
        )
    }
    if raw.records is not None:
        assert record_every is not None  # the kernel records only with a record_every
        data.update(series_dataset(prep.model, raw.records, ("trajectory", "time")))
        coords["time"] = (
            "time",
            _sample_times(prep, raw.records, record_every),
            attrs_for("time"),
        )
    ds = xr.Dataset(data, coords=coords)
    ds = ds.assign_coords(
        {
            name: (dims, values, attrs_for(name))
            for name, (dims, values) in prep.coords.items()
        }
    )
    ds = ds.assign_coords({k: v for k, v in VECTOR_COORDS.items() if k in ds.dims})
    ds.attrs.update(global_attrs)
    ds.attrs["batch_shape"] = list(prep.shape)
    return ds


def default_record_every(prep: Prepared, record_every: int | None) -> int:
    """``record_every``, or the smallest stride that keeps at most
    :data:`MAX_DEFAULT_SAMPLES` samples of a single run."""
    if record_every is not None:
        return record_every
    return max(1, -(-int(prep.nsteps[0, 0]) // MAX_DEFAULT_SAMPLES))


def run_dataset(
    prep: Prepared,
    raw: Raw,
    record_every: int,
    attrs_for: AttrsFor,
    global_attrs: Mapping[str, Any],
    config: Mapping[str, Any],
) -> xr.Dataset:
    """A single run's results over ``time``: its series, its observables as scalars,
    every input as an attribute (units in ``<name>_units``, long name in
    ``<name>_long_name``) and the configuration as
    JSON in ``config``. A status other than ok raises a RuntimeWarning."""
    assert raw.records is not None  # a single run always records
    # a copy: raw.records[0] is a view into the record of the whole block (BLOCK lanes)
    data = series_dataset(prep.model, raw.records[0].copy(), ("time",))
    data.update(observables_dataset(prep.model, raw.observables, None))
    ds = xr.Dataset(
        data,
        coords={
            "time": (
                "time",
                _sample_times(prep, raw.records, record_every),
                attrs_for("time"),
            )
        },
    )
    ds = ds.assign_coords({k: v for k, v in VECTOR_COORDS.items() if k in ds.dims})
    ds.attrs.update(global_attrs)
    for name, (_, values) in prep.coords.items():
        value = values[0]
        if name == "body_name":
            ds.attrs[name] = str(value)
            continue
        ds.attrs[name] = value.tolist() if isinstance(value, np.ndarray) else float(value)
        ds.attrs[f"{name}_units"] = attrs_for(name)["units"]
        ds.attrs[f"{name}_long_name"] = attrs_for(name)["long_name"]
    ds.attrs["config"] = json.dumps(config)
    status = int(raw.observables[O_STATUS, 0])
    if status != OK:
        warnings.warn(
            f"simulation stopped at t = {raw.observables[O_T_END, 0]:.6g} s with status "
            f"{STATUS_NAMES[status]!r}",
            RuntimeWarning,
            stacklevel=3,
        )
    return ds


def run_attrs(
    method: str,
    record_every: int | None,
    band: float | None,
    stop: str | None = None,
    *,
    lyapunov: bool = False,
) -> dict[str, Any]:
    """Global attributes common to every result (``band`` None: no reversal tracking;
    ``stop`` the stop rule, recorded when one is given; ``lyapunov`` True: how the
    exponents were computed)."""
    attrs = {
        "title": "rattlesweep rattleback simulation",
        "source": f"rattlesweep {__version__}",
        "rattlesweep_version": __version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "method": method,
        "record_every": -1 if record_every is None else record_every,
        "reversal_band": band,
        "Conventions": "CF-1.8",
        "references": "S. Jones and H. E. M. Hunt, Am. J. Phys. 87, 699 (2019), "
        "doi:10.1119/1.5115498",
    }
    if band is None:
        del attrs["reversal_band"]
    if stop is not None:
        attrs["stop"] = stop
    if lyapunov:
        attrs.update(lyapunov_attrs())
    return attrs
