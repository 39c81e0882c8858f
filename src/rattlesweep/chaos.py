"""Poincaré sections of single runs: the state each time it crosses a plane you name.

A section samples a run once per passage through the plane, so that regular motion
(a torus) shows as points on closed curves and chaotic motion as a scattered cloud: the
picture behind what the largest Lyapunov exponent (``lyapunov=True``) reports.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import xarray as xr

from .rattleback.launch import up_vector

__all__ = ["SECTION_VARIABLES", "poincare_section"]

SECTION_VARIABLES = (
    "spin",
    "tilt",
    "tilt_rate",
    "heading",
    "energy",
    "normal_force",
    "omega_x",
    "omega_y",
    "omega_z",
    "gamma_x",
    "gamma_y",
    "gamma_z",
)
"""The variables a section holds and a plane may be named by."""


def _series(run: xr.Dataset) -> dict[str, tuple[np.ndarray, dict[str, Any]]]:
    """Every section variable of a run over its samples, with its CF attributes."""
    t = run["time"].values
    out = {}
    for name in ("spin", "tilt", "heading", "energy", "normal_force"):
        da = run[name]
        out[name] = (da.values, {k: da.attrs[k] for k in ("units", "long_name")})
    tilt = run["tilt"].values
    out["tilt_rate"] = (
        np.gradient(tilt, t) if t.size > 1 else np.full(t.size, np.nan),
        {"units": "rad s-1", "long_name": "rate of change of the tilt"},
    )
    gamma = up_vector(run["quaternion"].values).T
    for k, axis in enumerate("xyz"):
        out[f"omega_{axis}"] = (
            run["omega"].values[:, k],
            {"units": "rad s-1", "long_name": f"body angular velocity, {axis} component"},
        )
        out[f"gamma_{axis}"] = (
            gamma[k],
            {"units": "1", "long_name": f"world up-vector in body components, {axis}"},
        )
    return out


def _ordinal(n: int) -> str:
    """2 -> "2nd", 11 -> "11th", 23 -> "23rd"."""
    tail = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{tail}"


def poincare_section(
    run: xr.Dataset, plane: str = "omega_x", level: float = 0.0, direction: str = "up"
) -> xr.Dataset:
    """The state of a run (:func:`rattlesweep.simulate`) each time the variable ``plane``
    crosses ``level`` in ``direction`` (``"up"``, ``"down"`` or ``"both"``). By default
    the roll rate ``omega_x`` crossing zero upward: once per rocking about the long axis,
    at the roll's most negative.

    ``plane`` and the section's variables are those of :data:`SECTION_VARIABLES`:
    the recorded ``spin``, ``tilt`` (rad), ``heading``, ``energy`` and
    ``normal_force``; ``tilt_rate`` (rad/s, the tilt's time derivative by central
    differences); the body components of the angular velocity ``omega_x`` ...
    (rad/s) and of the world up-vector ``gamma_x`` ... Each is interpolated linearly
    between the two samples around a crossing, so the section is as fine as the run's
    record: record every step (``record_every=1``) for a sharp one (a coarser record
    warns). The tilt is a magnitude, with a cusp at upright: a tilt-rate plane is
    crossed on both sides of upright, twice per rocking.

    Returns a Dataset over ``crossing`` with ``crossing_time`` (s) and every section
    variable at each crossing; its attribute ``section`` names the plane. A plane the
    run never crosses gives an empty section, with a warning saying the range it
    spanned.
    """
    if not isinstance(run, xr.Dataset) or "quaternion" not in run or "time" not in run.dims:
        raise ValueError(
            "run must be the result of rattlesweep.simulate (one run's series)"
        )
    series = _series(run)
    if plane not in series:
        raise ValueError(f"plane must be one of {list(SECTION_VARIABLES)}, got {plane!r}")
    if direction not in ("up", "down", "both"):
        raise ValueError(f"direction must be 'up', 'down' or 'both', got {direction!r}")
    try:
        level = float(level)
    except (TypeError, ValueError):
        level = math.nan
    if not math.isfinite(level):
        raise ValueError(f"level must be a finite number, got {level!r}")
    t = run["time"].values
    s = series[plane][0] - level
    before, after = s[:-1], s[1:]
    with np.errstate(invalid="ignore"):
        up = (before < 0.0) & (after >= 0.0)
        down = (before > 0.0) & (after <= 0.0)
    hit = {"up": up, "down": down, "both": up | down}[direction]
    i = np.nonzero(hit)[0]
    frac = before[i] / (before[i] - after[i])
    data: dict[str, Any] = {
        "crossing_time": (
            "crossing",
            t[i] + frac * (t[i + 1] - t[i]),
            {"units": "s", "long_name": "time of the crossing"},
        )
    }
    for name in SECTION_VARIABLES:
        values, attrs = series[name]
        data[name] = ("crossing", values[i] + frac * (values[i + 1] - values[i]), attrs)
    ds = xr.Dataset(data, coords={"crossing": np.arange(i.size)})
    unit = series[plane][1]["units"]
    crossed = "either way" if direction == "both" else f"{direction}ward"
    where = f"{plane} = {level:g}{'' if unit == '1' else ' ' + unit}"
    ds.attrs["section"] = f"{where}, crossed {crossed}"
    ds.attrs["Conventions"] = "CF-1.8"
    every = int(run.attrs.get("record_every", 1))
    if i.size == 0:
        finite = s[np.isfinite(s)] + level
        spanned = f"{finite.min():.4g} to {finite.max():.4g}" if finite.size else "nothing"
        warnings.warn(
            f"the run never crosses {where} {crossed}: {plane} spans {spanned} "
            f"{'' if unit == '1' else unit}".rstrip(),
            RuntimeWarning,
            stacklevel=2,
        )
    elif every > 1:
        warnings.warn(
            f"the run records every {_ordinal(every)} step: each crossing is "
            f"interpolated over "
            f"{every} steps; simulate with record_every=1 for a sharp section",
            RuntimeWarning,
            stacklevel=2,
        )
    return ds
