"""Reading results: flags as names (:func:`decode`), tidy tables (:func:`to_table`,
:func:`to_csv`) and a batch back on its broadcast shape (:func:`unstack`).

These work on any result of :func:`rattlesweep.simulate`, :func:`rattlesweep.run_batch`,
a sweep or a stability map, in memory or read back from a file. They use pandas, which
xarray itself requires.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Hashable, Sequence, TypeVar

import numpy as np
import xarray as xr

from ._results import VECTOR_COORDS

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["COMPONENT_DIMS", "decode", "to_csv", "to_table", "unstack"]

COMPONENT_DIMS = (*VECTOR_COORDS, "eigenvalue")
"""Dimensions whose elements are the components of one quantity (a vector, a quaternion,
the eigenvalues of a stability map): a table gives each component its own column."""

Result = TypeVar("Result", xr.Dataset, xr.DataArray)


def _flags(attrs: dict[Hashable, Any]) -> tuple[list[int], list[str]] | None:
    if "flag_values" not in attrs or "flag_meanings" not in attrs:
        return None
    values = [int(v) for v in np.atleast_1d(attrs["flag_values"])]
    return values, str(attrs["flag_meanings"]).split()


def _decode_array(da: xr.DataArray) -> xr.DataArray:
    flags = _flags(da.attrs)
    if flags is None:
        return da
    values, names = flags
    codes = np.asarray(da.values)
    out = np.full(codes.shape, "unknown", dtype=object)
    for value, name in zip(values, names):
        out[codes == value] = name
    width = max(len(n) for n in [*names, "unknown"])
    attrs = {k: v for k, v in da.attrs.items() if k not in ("flag_values", "flag_meanings")}
    attrs["flag_meanings"] = " ".join(names)  # the order of the categories
    decoded = da.copy(data=out.astype(f"<U{width}"))
    decoded.attrs = attrs
    return decoded


def decode(result: Result) -> Result:
    """``result`` with every CF flag variable (``status``, ``outcome``, ``mode``: integer
    codes with ``flag_values`` and ``flag_meanings``) replaced by the names of its codes
    (strings such as ``"ok"``, ``"reversed"``; ``"unknown"`` for a code the flags do
    not list). The codes' order stays in the ``flag_meanings`` attribute. A DataArray
    is decoded alone; other variables are returned as they are."""
    if isinstance(result, xr.DataArray):
        return _decode_array(result)
    out = result.copy()
    for name in list(out.variables):
        if name not in out.dims and _flags(out[name].attrs) is not None:
            out[name] = _decode_array(out[name])
    return out


def _component_columns(name: str, da: xr.DataArray) -> list[tuple[str, xr.DataArray]]:
    """One column per component of ``da`` along its component dimensions: ``omega_x``,
    ``quaternion_w``, ``eigenvalue_real_2``."""
    dims = [d for d in da.dims if d in COMPONENT_DIMS]
    if not dims:
        return [(name, da)]
    dim = dims[0]
    labels = da[dim].values if dim in da.coords else np.arange(da.sizes[dim])
    out = []
    for i, label in enumerate(labels):
        out += _component_columns(f"{name}_{label}", da.isel({dim: i}, drop=True))
    return out


def to_table(result: xr.Dataset) -> "pd.DataFrame":
    """A tidy table of a result: one row per element of its non-component dimensions
    (time samples of a run, trajectories of a batch, points of a sweep), a column for
    each of those dimensions, for each input and for each result, flags as names
    (:func:`decode`, as pandas categoricals), and each component of a vector quantity in
    a column of its own (``omega_x``, ``omega_y``, ``omega_z``; ``position_X``), so
    that nothing multiplies the rows. A value without one of the row dimensions (a
    run's observables, a sweep's fixed inputs) repeats on every row. Units and long
    names are in ``DataFrame.attrs["units"]`` and ``["long_names"]``."""
    import pandas as pd

    if not isinstance(result, xr.Dataset):
        raise ValueError(f"to_table takes an xarray Dataset, got {type(result).__name__}")
    ds = decode(result)
    rows = [d for d in ds.dims if d not in COMPONENT_DIMS]
    shape = tuple(ds.sizes[d] for d in rows)
    template = xr.DataArray(np.zeros(shape, dtype=np.int8), dims=rows)
    columns: dict[str, Any] = {}
    units: dict[str, str] = {}
    long_names: dict[str, str] = {}
    grids = np.meshgrid(
        *(
            np.asarray(ds[d].values) if d in ds.coords else np.arange(n)
            for d, n in zip(rows, shape)
        ),
        indexing="ij",
    )
    for dim, grid in zip(rows, grids):
        columns[str(dim)] = grid.reshape(-1)
    names = [n for n in ds.coords if n not in ds.dims] + list(ds.data_vars)
    for name in names:
        da = ds[name]
        flags = _flags(result[name].attrs)  # decode keeps the names, not the codes
        for column, part in _component_columns(str(name), da):
            if column in columns:
                raise ValueError(f"to_table: column {column!r} would appear twice")
            values = part.broadcast_like(template).transpose(*rows).values.reshape(-1)
            if flags is not None:
                values = pd.Categorical(values, categories=[*flags[1], "unknown"])
            columns[column] = values
            if "units" in part.attrs:
                units[column] = str(part.attrs["units"])
            if "long_name" in part.attrs:
                long_names[column] = str(part.attrs["long_name"])
    table = pd.DataFrame(columns)
    table.attrs["units"] = units
    table.attrs["long_names"] = long_names
    return table


def to_csv(result: xr.Dataset, path: str | os.PathLike[str]) -> None:
    """Write :func:`to_table` of ``result`` as CSV (header: the column names; no index
    column)."""
    to_table(result).to_csv(path, index=False)


def _along_one_axis(
    values: np.ndarray, shape: tuple[int, ...], i: int
) -> np.ndarray | None:
    """The values of a flat input along axis ``i`` of ``shape`` when it varies along that
    axis alone with distinct values (so it can index it), else None."""
    grid = values.reshape(shape)
    along = grid[tuple(slice(None) if j == i else 0 for j in range(len(shape)))]
    spread = np.broadcast_to(
        along.reshape([n if j == i else 1 for j, n in enumerate(shape)]), shape
    )
    if np.array_equal(grid, spread, equal_nan=True) and len(np.unique(along)) == shape[i]:
        return along
    return None


def _axis_names(ds: xr.Dataset, shape: tuple[int, ...]) -> list[str]:
    """A name for each axis of a batch's broadcast shape: the first input (the launch's
    ``launch_*`` first, then in the order of the coordinates) that varies along that axis
    alone with distinct values, else ``batch_axis_<i>``."""
    names = [f"batch_axis_{i}" for i in range(len(shape))]
    order = sorted(ds.coords, key=lambda n: not str(n).startswith("launch_"))
    for name in order:
        var = ds.coords[name]
        if (
            var.dims != ("trajectory",)
            or name == "trajectory"
            or var.dtype.kind not in "fiu"
        ):
            continue
        for i, n in enumerate(shape):
            if (
                names[i].startswith("batch_axis_")
                and n > 1
                and _along_one_axis(var.values, shape, i) is not None
            ):
                names[i] = str(name)
                break
    return names


def unstack(batch: xr.Dataset, dims: Sequence[str] | None = None) -> xr.Dataset:
    """A :func:`rattlesweep.run_batch` result (or a planar one) on its broadcast shape
    (the ``batch_shape`` attribute) instead of the flat ``trajectory`` dimension.

    ``dims`` names the new dimensions; by default each is named after the input that
    varies along it alone (``launch_spin`` first, then ``roll_deg``, ``mu``... in the
    order of the coordinates), which becomes its index, or
    ``batch_axis_<i>`` where no single input does. Every other input keeps all its
    values, as a coordinate over the new dimensions, and ``trajectory`` keeps the flat
    index of each launch.
    """
    if not isinstance(batch, xr.Dataset) or "trajectory" not in batch.dims:
        raise ValueError(
            "unstack takes a batch result: a Dataset with a trajectory dimension"
        )
    if "batch_shape" not in batch.attrs:
        raise ValueError(
            "unstack: the dataset has no batch_shape attribute (is it a run_batch result?)"
        )
    shape = tuple(int(n) for n in np.atleast_1d(batch.attrs["batch_shape"]))
    if int(np.prod(shape)) != batch.sizes["trajectory"]:
        raise ValueError(
            f"unstack: batch_shape {list(shape)} does not hold "
            f"{batch.sizes['trajectory']} trajectories"
        )
    names = list(dims) if dims is not None else _axis_names(batch, shape)
    if len(names) != len(shape) or len(set(names)) != len(names):
        raise ValueError(
            f"unstack: dims must name each of the {len(shape)} axes of "
            f"batch_shape {list(shape)} once, got {names!r}"
        )
    clash = [n for n in names if n in batch.dims and n != "trajectory"]
    if clash:
        raise ValueError(f"unstack: {clash} already name dimensions of the batch")

    def reshaped(var: xr.Variable) -> tuple[tuple[str, ...], np.ndarray]:
        i = var.dims.index("trajectory")
        values = var.values.reshape(var.shape[:i] + shape + var.shape[i + 1 :])
        return tuple(map(str, var.dims[:i])) + tuple(names) + tuple(
            map(str, var.dims[i + 1 :])
        ), values

    data = {}
    for name, var in batch.data_vars.items():
        data[name] = (
            reshaped(var.variable) if "trajectory" in var.dims else (var.dims, var.values)
        ) + (var.attrs,)
    coords: dict[Hashable, Any] = {}
    for name, var in batch.coords.items():
        if "trajectory" not in var.dims:
            coords[name] = var.variable
            continue
        new_dims, values = reshaped(var.variable)
        if name in names:  # the index of its own axis: its values along that axis
            along = _along_one_axis(var.values, shape, names.index(str(name)))
            if var.dims != ("trajectory",) or along is None:
                raise ValueError(
                    f"unstack: {name!r} cannot name an axis: it does not vary "
                    "along that axis alone with distinct values"
                )
            new_dims, values = (str(name),), along
        coords[name] = (new_dims, values, var.attrs)
    return xr.Dataset(data, coords=coords, attrs=batch.attrs)
