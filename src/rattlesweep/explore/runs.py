"""One run for the page: :func:`rattlesweep.simulate` of checked settings, and the JSON the
page draws (3-D pose, floor track, linked plots, slip intervals, the Python behind it)."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import xarray as xr

from ..rattleback.contact import contact_dataset
from ..rattleback.simulate import simulate
from .caps import Caps
from .settings import RunSpec, python_code

__all__ = ["run", "payload", "slip_intervals"]


def run(spec: RunSpec, caps: Caps) -> tuple[xr.Dataset, list[str]]:
    """Simulate a checked run (serially, on the calling thread) recording at most
    ``caps.max_frames`` samples; return it and the warnings it gave."""
    record_every = max(1, math.ceil(spec.steps / (caps.max_frames - 1)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = simulate(spec.body, record_every=record_every, **spec.kwargs)
    # the series are views into the kernel's record buffer, one lane of a block of
    # trajectories (5.8 MB for a 1000-sample run); a session keeps its run, so copy them
    return ds.copy(deep=True), [str(w.message) for w in caught]


def slip_intervals(time: np.ndarray, slipping: np.ndarray) -> list[list[float]]:
    """[start, end] times (s) of the runs of samples where the contact slips."""
    s = np.asarray(slipping, dtype=bool)
    if not s.any():
        return []
    edges = np.diff(np.concatenate([[0], s.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [[float(time[a]), float(time[b])] for a, b in zip(starts, ends)]


class _Raw(str):
    """Preformatted JSON (a number array), inserted as it is by :func:`to_json`."""


def numbers(values: Any) -> _Raw:
    """A float array as a JSON list at 6 significant digits (null for NaN and inf)."""
    import json

    flat = np.asarray(values, dtype=float).ravel()
    with np.errstate(all="ignore"):
        scale = 10.0 ** (5 - np.floor(np.log10(np.abs(flat))))
        scale[~np.isfinite(scale)] = 1.0
        short = np.round(flat * scale) / scale  # shortest repr of a 6-digit value is short
    short[~np.isfinite(flat)] = np.nan
    return _Raw(json.dumps(short.tolist()).replace("NaN", "null"))


def to_json(obj: Any) -> str:
    """JSON text of plain data in which :class:`_Raw` values are already JSON."""
    import json

    if isinstance(obj, _Raw):
        return str(obj)
    if isinstance(obj, dict):
        return (
            "{"
            + ",".join(f"{json.dumps(str(k))}:{to_json(v)}" for k, v in obj.items())
            + "}"
        )
    if isinstance(obj, (list, tuple)):
        return "[" + ",".join(to_json(v) for v in obj) + "]"
    if isinstance(obj, float) and not math.isfinite(obj):
        return "null"
    return json.dumps(obj)


def payload(spec: RunSpec, ds: xr.Dataset, messages: list[str]) -> dict[str, Any]:
    """What the page needs of a run; series over ``t`` (s)."""
    # only the samples that hold motion: a run stopped early (capsized, lifted off at
    # t = 0) records NaN after its stop, which the page cannot pose the body in; the
    # netCDF download keeps every sample
    position = ds.position.transpose("time", "axis").values
    held = np.flatnonzero(np.isfinite(ds.spin.values) & np.isfinite(position).all(axis=-1))
    keep = int(held[-1]) + 1 if held.size else 1
    ds = ds.isel(time=slice(0, keep))
    t = ds.time.values
    contact = contact_dataset(ds)
    status = ds.status.attrs["flag_meanings"].split()[int(ds.status)]
    body = spec.body
    return {
        "t": numbers(t),
        "quaternion": numbers(ds.quaternion.transpose("time", "quaternion_component")),
        "position": numbers(ds.position.transpose("time", "axis")),
        "contact": numbers(contact.contact_floor.transpose("time", "horizontal")),
        "spin": numbers(ds.spin),
        "tilt_deg": numbers(np.degrees(ds.tilt.values)),
        "energy": numbers(ds.energy),
        "slip_speed": numbers(ds.slip_speed),
        "slips": slip_intervals(t, np.nan_to_num(ds.slipping.values) > 0),
        "summary": {
            "first_reversal_time": float(ds.first_reversal_time),
            "n_reversals": int(ds.n_reversals),
            "final_spin": float(ds.final_spin),
            "status": status,
            "slip_fraction": float(ds.slip_fraction),
            "steps": int(ds.steps),
            "dt": float(ds.attrs["dt"]),
        },
        "rolling": math.isinf(spec.kwargs["mu"]),
        "body": {
            "a": body.a,
            "b": body.b,
            "c": body.c,
            "com": body.com.tolist(),
            "full_ellipsoid": body.full_ellipsoid,
        },
        "python": python_code(spec),
        "warnings": messages,
    }
