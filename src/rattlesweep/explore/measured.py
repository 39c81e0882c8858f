"""A measured rattleback in the page: a loaded file drawn over the run, and a fit of the
controls the user ticks to it (:func:`rattlesweep.fit`), whose values go back into the
controls.

The page sends the file's text (a phyphox gyroscope export or a Tracker data export;
a CSV with other columns needs the command line's column options). What is drawn over
the spin plot is the measured turning rate: a gyroscope's z rate, or a video's heading
differentiated over :data:`RATE_WINDOW`. The bounds of a fitted control come from its
current value (:func:`bounds_for`), so a user first brings the run near the data by
hand, then fits.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..fitting import Measurement, fit, read_measurement
from .caps import Caps
from .runs import numbers
from .settings import RunSpec, SettingError

__all__ = ["FIT_CONTROLS", "RATE_WINDOW", "bounds_for", "fit_controls", "load", "overlay"]

FIT_CONTROLS = ("spin", "roll_deg", "pitch_deg", "mu", "damping", "mu_spin")
"""The controls a fit in the page may free."""

SENSOR_YAW = "sensor_yaw_deg"
"""Also free for gyroscope data: the phone's turn on the flat face (not a control; the
fit reports it)."""

LATE_START = 0.5
"""s: data whose first sample comes later than this do not start at the release."""

RATE_WINDOW = 0.1
"""s: the span over which a video's heading is differentiated for the drawn rate."""

_SIM_NAME = {"roll_deg": "roll", "pitch_deg": "pitch"}

# the search's sizes in the page: a fit of 5 s of data takes about 10 s on one core
_GLOBAL_SIZE, _GLOBAL_ROUNDS, _PROFILE_POINTS = 512, 3, 9


def load(name: str, text: str, caps: Caps) -> Measurement:
    """Read a measurement the page sent: ``name`` (the file's name, for its format)
    and ``text``, within the caps. Raises :class:`SettingError` naming the problem."""
    if not isinstance(text, str) or not text.strip():
        raise SettingError("the measurement file is empty", "measurement")
    suffix = Path(str(name)).suffix.lower()
    if suffix not in (".csv", ".txt", ".tsv", ".dat"):
        suffix = ".csv"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"measurement{suffix}"
        path.write_text(text, encoding="utf-8")
        try:
            m = read_measurement(path)
        except ValueError as exc:
            message = str(exc).replace(str(path), str(name) or "the file")
            raise SettingError(message, "measurement") from None
    if m.time[0] > LATE_START:
        raise SettingError(
            f"the recording starts at t = {m.time[0]:.4g} s: time zero must be the "
            "release. Cut the rows before the release and count time from it (the "
            "command line's rattlesweep fit --trim-start does that)",
            "measurement",
        )
    caps.check("measured duration", m.duration, "max_fit_t_end", "s", control="measurement")
    caps.check("measured samples", len(m.time), "max_fit_samples", control="measurement")
    return Measurement(m.kind, m.time, m.values, str(name) or m.source)


def overlay(m: Measurement) -> dict[str, Any]:
    """What the page draws over the spin plot: times (s) and the measured turning rate
    (rad/s), with what it is."""
    if m.kind == "gyro":
        return {
            "kind": m.kind,
            "t": numbers(m.time),
            "rate": numbers(m.values[:, 2]),
            "what": "gyroscope z rate",
        }
    # the heading's slope over RATE_WINDOW: a frame-to-frame difference of a tracked
    # line is mostly the tracking's noise
    half = RATE_WINDOW / 2
    lo = np.searchsorted(m.time, m.time - half)
    hi = np.minimum(
        np.searchsorted(m.time, m.time + half, side="right") - 1, len(m.time) - 1
    )
    span = m.time[hi] - m.time[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(span > 0, (m.values[hi] - m.values[lo]) / span, np.nan)
    return {
        "kind": m.kind,
        "t": numbers(m.time),
        "rate": numbers(rate),
        "what": "turning rate of the video's line",
    }


def bounds_for(name: str, value: float) -> tuple[float, float]:
    """The bounds a page fit gives control ``name`` whose current value is ``value``."""
    if name == "spin":
        half = max(2.0, 0.5 * abs(value))
        return (value - half, value + half)
    if name in ("roll_deg", "pitch_deg"):
        # a release tilt and its mirror image make runs a fit cannot tell apart: the
        # tilt keeps the side the user chose
        reach = max(5.0, 3.0 * abs(value))
        return (-reach, 0.0) if value < 0 else (0.0, reach)
    if name == "mu":
        return (0.01, 1.5)
    if name == "damping":
        return (1e-6, 1e-2)
    if name == "mu_spin":
        return (0.0, 2e-3)
    if name == SENSOR_YAW:
        return (-90.0, 90.0)
    raise SettingError(
        f"fit: {name!r} cannot be fitted here; tick some of {', '.join(FIT_CONTROLS)}",
        "measurement",
    )


def fit_controls(
    spec: RunSpec, m: Measurement, free: list[str], settings: Mapping[str, Any]
) -> dict[str, Any]:
    """Fit the controls ``free`` of the page's run ``spec`` to ``m`` (serially, on the
    calling thread); the other controls are held. Returns the fitted controls' values
    and intervals, the fit's quality and notes, and the settings to load."""
    if not free:
        raise SettingError("fit: tick at least one control to fit", "measurement")
    allowed = FIT_CONTROLS + ((SENSOR_YAW,) if m.kind == "gyro" else ())
    unknown = [n for n in free if n not in allowed]
    if unknown:
        raise SettingError(
            f"fit: {', '.join(map(repr, unknown))} cannot be fitted here; they are "
            f"{', '.join(allowed)}",
            "measurement",
        )
    current = {n: 0.0 if n == SENSOR_YAW else _current(n, spec) for n in free}
    bounds = {n: bounds_for(n, current[n]) for n in free}
    freed = {_SIM_NAME.get(n, n) for n in free}
    fixed = {
        k: v
        for k, v in spec.kwargs.items()
        if k not in freed and k not in ("t_end", "dt") and v is not None
    }
    if "mu" in free:
        fixed.pop("mu_static", None)
    try:
        result = fit(
            m,
            spec.body,
            bounds,
            fixed,
            threads=1,
            global_size=_GLOBAL_SIZE,
            global_rounds=_GLOBAL_ROUNDS,
            profile_points=_PROFILE_POINTS,
        )
    except ValueError as exc:
        raise SettingError(f"fit: {exc}", "measurement") from None
    values = dict(settings)
    fitted = {}
    for name in free:
        f = result.fitted[name]
        if name != SENSOR_YAW:
            values[name] = f.value
        fitted[name] = {
            "value": f.value,
            "low": f.low,
            "high": f.high,
            "determined": f.determined,
            "units": f.units,
        }
    values["t_end"] = round(m.duration, 3)
    return {
        "fitted": fitted,
        "settings": values,
        "reduced_chi2": result.reduced_chi2,
        "notes": result.notes,
        "runs": result.evaluations,
        "seconds": result.seconds,
        "determined": result.determined,
    }


def _current(name: str, spec: RunSpec) -> float:
    value = spec.kwargs[_SIM_NAME.get(name, name)]
    return math.degrees(value) if name in _SIM_NAME else float(value)
