"""``rattlesweep.fit``: a measured rattleback's inputs, with intervals, from a batch
search (the search: :mod:`.search`; what is compared: :mod:`.objective`)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, cast

import numpy as np
import xarray as xr

from ..rattleback.body import Body
from .measurement import Measurement, from_dataset, read_measurement
from .objective import Comparison, Features, compare, in_sensor_axes, measured_features
from .parameters import Bound, bodies_for, bounds_from, check_fixed, defaults_left
from .parameters import units_of
from .search import Profile, global_search, polish, profiles
from .sensor import ANGLES, check as check_sensor, rotations, sensor_body, split

__all__ = ["FitResult", "Fitted", "fit"]

CHUNK = 256
"""Candidates per batch run: bounds the memory of the recorded series."""

RESTARTS = 2
"""Times the polish starts again from a lower point a profile met."""

POOR_FIT = 25.0
"""A reduced chi-squared above this says the model cannot reproduce the data (noise
misjudged by a factor of 5): the result says so, and is not determined."""


@dataclass(frozen=True)
class Fitted:
    """One fitted input: its best ``value``, the 95 % interval ``low``..``high`` (its
    bounds where the data do not pin it down), ``units``, and whether each end of the
    interval was ``determined``."""

    name: str
    value: float
    low: float
    high: float
    units: str
    low_determined: bool
    high_determined: bool

    @property
    def determined(self) -> bool:
        return self.low_determined and self.high_determined


@dataclass
class FitResult:
    """What :func:`fit` found: the ``fitted`` inputs, the ``fixed`` ones, those held at
    their ``defaults`` (neither free nor fixed), the offsets
    fitted in closed form (``offsets``: gyroscope biases, rad/s, or the heading's
    offset, rad), the fit's quality (``chi2``, ``reduced_chi2``, ``residual_rms`` of the
    scaled features), the ``correlation`` matrix of the fitted inputs (from the
    Jacobian at the best fit), the data and best model series (``dataset``), and
    ``notes`` (plain statements of what the data cannot pin down)."""

    fitted: dict[str, Fitted]
    fixed: dict[str, Any]
    defaults: dict[str, float]
    offsets: dict[str, float]
    chi2: float
    reduced_chi2: float
    residual_rms: float
    correlation: np.ndarray
    body: Body
    dataset: xr.Dataset
    evaluations: int
    seconds: float
    notes: list[str] = field(default_factory=list)

    @property
    def determined(self) -> bool:
        """Whether every fitted input has both ends of its interval, and the model
        fits the data (reduced chi-squared at most :data:`POOR_FIT`)."""
        return self.reduced_chi2 <= POOR_FIT and all(
            f.determined for f in self.fitted.values()
        )

    def summary(self) -> str:
        from .files import _interval, _units

        lines = []
        for f in self.fitted.values():
            lines.append(
                f"  {f.name} = {f.value:.4g}{_units(f.units)}  95 %: {_interval(f)}"
            )
        if self.offsets:
            lines.append(
                "  fitted in closed form: "
                + ", ".join(f"{k} = {v:.4g}" for k, v in self.offsets.items())
            )
        lines.append(
            f"  reduced chi2 {self.reduced_chi2:.3g}, residual RMS {self.residual_rms:.3g} "
            f"(in units of each feature's scale); {self.evaluations} model runs in "
            f"{self.seconds:.1f} s"
        )
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])


def fit(
    data: Measurement | str | Path | xr.Dataset,
    body: Body | str,
    free: Mapping[str, tuple[float, float]],
    fixed: Mapping[str, Any] | None = None,
    *,
    window: float = 0.5,
    fit_bias: bool = True,
    sensor_rotation: Any = None,
    heading_sign: float = 1.0,
    global_size: int = 1024,
    global_rounds: int = 4,
    profile_points: int = 15,
    seed: int = 0,
    threads: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> FitResult:
    """Fit the inputs named in ``free`` to a measured rattleback.

    Parameters
    ----------
    data : Measurement, path or xarray.Dataset
        The measurement (:func:`read_measurement` reads files; a path is read with it).
    body : Body or str
        The body, or a preset's name.
    free : mapping
        Each input to fit and its bounds, ``{"mu": (0.1, 1.0), "roll_deg": (0, 5)}``: any
        scalar input of :func:`rattlesweep.simulate` by any of its names (angles in
        degrees by their ``_deg`` name), and ``delta``/``delta_deg``, the body's
        misalignment.
    fixed : mapping, optional
        Other inputs, as :func:`rattlesweep.simulate` takes them; ``t_end`` comes from
        the data. Also the gyroscope's angles ``sensor_yaw_deg``, ``sensor_pitch_deg``,
        ``sensor_roll_deg`` (which ``free`` may name instead), its mass
        ``sensor_mass`` (kg) and ``sensor_position`` (m, body frame from the centre of
        the flat face), added to the body (:mod:`.sensor`).
    window : float
        Seconds per window of the compared features (:mod:`.objective`).
    fit_bias : bool
        Fit a constant bias per gyroscope axis (gyroscope data).
    sensor_rotation : array_like (3, 3), optional
        ``R`` with a gyroscope reading ``R @ omega_body`` (rows: the sensor's axes in
        the body's); or give the sensor's angles in ``fixed`` or ``free``.
    heading_sign : float
        -1 for a mirrored video (clockwise seen from above counted positive).
    global_size, global_rounds, profile_points, seed : int
        The search's sizes (:mod:`.search`) and its random seed.
    threads : int, optional
        Threads each batch of candidates runs on (default: the cores; 1 runs on the
        calling thread, as a server's worker does).
    progress : callable, optional
        Called with a line at each stage.

    Returns
    -------
    FitResult
    """
    began = time.perf_counter()
    say = progress or (lambda line: None)
    measurement = _measurement(data)
    the_body = Body.preset(body) if isinstance(body, str) else body
    if not isinstance(the_body, Body):
        raise ValueError(f"body must be a Body or a preset name, got {body!r}")
    bounds = bounds_from(free)
    fixed = check_fixed(fixed or {}, bounds)
    fixed, sensor = split(fixed)
    check_sensor(
        {**sensor, **{b.name: 0.0 for b in bounds if b.name in ANGLES}},
        measurement.kind,
        sensor_rotation,
    )
    the_body = sensor_body(the_body, sensor)
    defaults = defaults_left(bounds, fixed)
    if defaults:
        say(
            "held at their defaults (fix them with fixed, or free them): "
            + ", ".join(f"{k} = {v:g}" for k, v in defaults.items())
        )
    if not (math.isfinite(window) and 0 < window <= measurement.duration / 4):
        raise ValueError(
            f"window must be a positive number of seconds, at most a quarter of the "
            f"measurement's {measurement.duration:g} s ({measurement.duration / 4:g} s), "
            f"got {window!r}"
        )
    if measurement.time[0] >= window:
        raise ValueError(
            f"the data start at t = {measurement.time[0]:.4g} s: time zero must be the "
            "release. Read the file with trim_start= the time of the release (the "
            "command line's --trim-start) to count time from it"
        )
    _check_inputs(the_body, fixed, bounds, measurement.duration)
    rotation = None if sensor_rotation is None else np.asarray(sensor_rotation, float)
    if rotation is not None and (
        rotation.shape != (3, 3)
        or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6)
    ):
        raise ValueError("sensor_rotation must be a 3 x 3 rotation matrix")
    measured = measured_features(
        measurement, window, cross=any(b.name in ANGLES for b in bounds)
    )
    run = _Runner(
        measurement,
        measured,
        the_body,
        bounds,
        fixed,
        fit_bias,
        rotation,
        heading_sign,
        {k: float(v) for k, v in sensor.items() if k in ANGLES},
        threads,
    )
    rng = np.random.default_rng(seed)
    p = len(bounds)
    start, _, n_global = global_search(
        run.evaluate, p, rng, global_size, global_rounds, say
    )
    say("polishing the best candidate (Levenberg-Marquardt)...")
    runs = n_global
    for attempt in range(RESTARTS + 1):
        x, chi2, J, n = polish(run.evaluate, start[None], np.ones((1, p), dtype=bool))
        best, best_chi2, jac = x[0], float(chi2[0]), J[0]
        dof = max(1, measured.size - p - len(run.last_offsets))
        reduced = best_chi2 / dof
        threshold = 3.84 * max(1.0, reduced)
        say(f"profiles of {p} inputs ({profile_points}+ points each)...")
        found, n_prof, lowest, lowest_chi2 = profiles(
            run.evaluate, best, best_chi2, threshold, profile_points, jac
        )
        runs += n + n_prof
        if lowest_chi2 >= best_chi2 - max(1e-3, 1e-4 * best_chi2) or attempt == RESTARTS:
            break
        # a profile went below the best fit: polish from there and profile again
        say(
            f"a profile met chi2 {lowest_chi2:.6g}, below the best fit's "
            f"{best_chi2:.6g}: polishing from there and profiling again"
        )
        start = lowest
    comparison, series = run.series(best)
    fitted, notes = _fitted(bounds, best, found)
    correlation = _correlation(jac)
    notes += _trade_offs(bounds, correlation)
    if reduced > POOR_FIT:
        notes.insert(
            0,
            f"the model does not fit these data (reduced chi2 {reduced:.3g}): the "
            "intervals mean little; check the body, the fixed inputs, the defaults and "
            "the bounds"
            + (
                ", and the sensor's axes (a phone turned on the face: fit sensor_yaw_deg)"
                if measurement.kind == "gyro" and not any(b.name in ANGLES for b in bounds)
                else ""
            ),
        )
    values = {b.name: float(b.value(np.array(best[k]))) for k, b in enumerate(bounds)}
    fitted_body = _body_of(the_body, {**fixed, **values})
    fixed = {**fixed, **sensor}
    offsets = {k: float(v[0]) for k, v in comparison.offsets.items()}
    if "heading_offset" in offsets:  # the video's zero, as an angle in (-pi, pi]
        offsets["heading_offset"] = math.pi - (math.pi - offsets["heading_offset"]) % (
            2 * math.pi
        )
    result = FitResult(
        fitted=fitted,
        fixed=dict(fixed),
        defaults=defaults,
        offsets=offsets,
        chi2=best_chi2,
        reduced_chi2=reduced,
        residual_rms=float(np.sqrt(best_chi2 / measured.size)),
        correlation=correlation,
        body=fitted_body,
        dataset=_dataset(measurement, measured, comparison, series, run),
        evaluations=runs,
        seconds=time.perf_counter() - began,
        notes=notes,
    )
    return result


def _check_inputs(
    body: Body, fixed: Mapping[str, Any], bounds: list[Any], t_end: float
) -> None:
    """The fixed inputs, with each free one in the middle of its bounds, checked by
    the batch's own rules as one launch: an error names the input and its value
    before any search starts."""
    from ..rattleback.batch import launch_inputs, split_angles

    given: dict[str, Any] = {**fixed, "t_end": t_end}
    for b in bounds:
        if b.name not in ANGLES and b.name not in ("delta", "delta_deg"):
            given[b.name] = float(b.value(np.array(0.5)))
    given.pop("delta", None)
    given.pop("delta_deg", None)
    plain, radians, _ = split_angles(body, given)
    launch_inputs(body, announce=False, **plain, **radians)


def _measurement(data: Any) -> Measurement:
    if isinstance(data, Measurement):
        return data
    if isinstance(data, xr.Dataset):
        return from_dataset(data)
    if isinstance(data, (str, Path)):
        return read_measurement(data)
    raise ValueError(
        "data must be a Measurement, a file path or an xarray Dataset, got "
        f"{type(data).__name__}"
    )


def _body_of(body: Body, values: Mapping[str, Any]) -> Body:
    delta = values.get("delta", None)
    if "delta_deg" in values:
        delta = math.radians(float(values["delta_deg"]))
    if delta is None:
        return body
    turned = bodies_for(body, np.array([delta]))
    return cast(Body, turned[0])


class _Runner:
    """Runs batches of candidates and compares them with the measurement."""

    def __init__(
        self,
        data: Measurement,
        measured: Features,
        body: Body,
        bounds: list[Bound],
        fixed: Mapping[str, Any],
        fit_bias: bool,
        rotation: np.ndarray | None,
        heading_sign: float,
        angles: Mapping[str, float] | None = None,
        threads: int | None = None,
    ) -> None:
        self.data, self.measured, self.body = data, measured, body
        self.bounds, self.fixed = bounds, dict(fixed)
        self.fit_bias, self.rotation, self.heading_sign = fit_bias, rotation, heading_sign
        self.angles = dict(angles or {})
        self.threads = threads
        dt = float(fixed.get("dt", body.default_dt(float(fixed.get("g", 9.81)))))
        # model samples at least 3 per data sample: a window's mean and RMS of the
        # rocking taken from them are then as accurate as the data's own
        spacing = float(np.median(np.diff(data.time)))
        self.record_every = max(1, int(spacing / (3 * dt)))
        self.dt = dt
        self.t_end = data.duration + 2 * dt * self.record_every
        self.last_offsets: dict[str, np.ndarray] = {}

    def inputs(self, cube: np.ndarray) -> tuple[Any, dict[str, Any]]:
        given: dict[str, Any] = {**self.fixed}
        for k, b in enumerate(self.bounds):
            if b.name not in ANGLES:
                given[b.name] = b.value(cube[:, k])
        body: Any = self.body
        delta = given.pop("delta", None)
        if "delta_deg" in given:
            delta = np.radians(given.pop("delta_deg"))
        if delta is not None:
            body = bodies_for(self.body, np.broadcast_to(delta, (len(cube),)))
        given.setdefault("dt", self.dt)
        return body, given

    def run(self, cube: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(sample times, the compared series of each candidate): run_batch's own
        checks and kernel call, without building its dataset (most of a short
        run's cost)."""
        from .._core.rattleback.layout import R_HEADING, R_OMEGA
        from .._core.workspace import RK4
        from .._options import check_single_step
        from .._run import execute
        from ..rattleback.batch import prepare, split_angles

        body, given = self.inputs(cube)
        given = {
            k: (np.broadcast_to(v, (len(cube),)) if np.ndim(v) == 0 else v)
            for k, v in given.items()
        }
        plain, radians, degrees = split_angles(body, {**given, "t_end": self.t_end})
        prep = prepare(body, **plain, **radians, degrees=degrees)
        check_single_step(prep)
        heading = self.data.kind == "heading"
        raw = execute(
            prep,
            method=RK4,
            record_every=self.record_every,
            parallel=self.threads != 1,
            threads=self.threads,
            columns=slice(R_HEADING, R_HEADING + 1)
            if heading
            else slice(R_OMEGA, R_OMEGA + 3),
        )
        assert raw.records is not None
        t = np.arange(raw.records.shape[1]) * self.dt * self.record_every
        return t, raw.records[:, :, 0] if heading else raw.records

    def rotation_of(self, cube: np.ndarray) -> np.ndarray | None:
        """The sensor's rotation: one matrix (3, 3), one per candidate (c, 3, 3) when
        its angles are free, or None."""
        angles: dict[str, Any] = dict(self.angles)
        for k, b in enumerate(self.bounds):
            if b.name in ANGLES:
                angles[b.name] = b.value(cube[:, k])
        if not angles:
            return self.rotation
        return rotations(*(angles.get(n, 0.0) for n in ANGLES))

    def compare_chunk(self, cube: np.ndarray) -> tuple[Comparison, np.ndarray, np.ndarray]:
        t, series = self.run(cube)
        comparison = compare(
            self.data,
            self.measured,
            t,
            series,
            fit_bias=self.fit_bias,
            rotation=self.rotation_of(cube),
            heading_sign=self.heading_sign,
        )
        return comparison, t, series

    def evaluate(self, cube: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        chi2, residuals = [], []
        for a in range(0, len(cube), CHUNK):
            comparison, _, _ = self.compare_chunk(cube[a : a + CHUNK])
            chi2.append(comparison.chi2)
            residuals.append(comparison.residuals)
            self.last_offsets = comparison.offsets
        return np.concatenate(chi2), np.vstack(residuals)

    def series(self, best: np.ndarray) -> tuple[Comparison, tuple[np.ndarray, np.ndarray]]:
        """The best candidate's comparison and (times, series), a gyroscope's series
        turned into the sensor's axes."""
        comparison, t, series = self.compare_chunk(best[None])
        rotation = self.rotation_of(best[None])
        if rotation is not None and self.data.kind == "gyro":
            series = in_sensor_axes(series, rotation)
        return comparison, (t, series[0])


def _fitted(
    bounds: list[Bound], best: np.ndarray, found: list[Profile]
) -> tuple[dict, list]:
    out, notes = {}, []
    for k, (b, prof) in enumerate(zip(bounds, found)):
        value = float(b.value(np.array(best[k])))
        low, high = (float(b.value(np.array(v))) for v in (prof.low, prof.high))
        out[b.name] = Fitted(
            b.name, value, low, high, units_of(b.name), prof.low_found, prof.high_found
        )
        if not (prof.low_found or prof.high_found):
            notes.append(
                f"{b.name} is not determined: any value within its bounds "
                f"{b.low:g}..{b.high:g} fits as well"
            )
        elif not prof.low_found:
            notes.append(
                f"{b.name} is bounded from above only (<= {high:.4g}): the data fit "
                f"as well down to its lower bound {b.low:g}"
            )
        elif not prof.high_found:
            notes.append(
                f"{b.name} is bounded from below only (>= {low:.4g}): the data fit "
                f"as well up to its upper bound {b.high:g}"
                + (
                    " (a run that never slips bounds mu from below only)"
                    if b.name == "mu"
                    else ""
                )
            )
    return out, notes


def _correlation(jac: np.ndarray) -> np.ndarray:
    a = jac.T @ jac
    cov = np.linalg.pinv(a)
    d = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    return np.clip(cov / np.outer(d, d), -1.0, 1.0)


def _trade_offs(bounds: list[Bound], corr: np.ndarray) -> list[str]:
    notes = []
    for i in range(len(bounds)):
        for j in range(i + 1, len(bounds)):
            if abs(corr[i, j]) > 0.95:
                notes.append(
                    f"{bounds[i].name} and {bounds[j].name} trade off (correlation "
                    f"{corr[i, j]:+.2f}): the data pin down a combination of them"
                )
    return notes


def _dataset(
    data: Measurement,
    measured: Features,
    comparison: Comparison,
    series: tuple[np.ndarray, np.ndarray],
    run: _Runner,
) -> xr.Dataset:
    t_model, model = series
    mid = 0.5 * (measured.edges[1:] + measured.edges[:-1])
    model_features = (
        measured.values
        + comparison.residuals[0].reshape(measured.values.shape) * measured.scale[:, None]
    )
    ds = xr.Dataset(coords={"time": ("time", data.time), "window": ("window", mid)})
    ds["time"].attrs.update(units="s", long_name="time from the release")
    ds["window"].attrs.update(units="s", long_name="middle of the feature window")
    if data.kind == "heading":
        offset = comparison.offsets["heading_offset"][0]
        at = np.interp(data.time, t_model, run.heading_sign * model) + offset
        ds["measured_heading"] = (
            "time",
            data.values,
            {"units": "rad", "long_name": "measured heading"},
        )
        ds["model_heading"] = (
            "time",
            at,
            {"units": "rad", "long_name": "best model's heading, offset added"},
        )
        ds["residual_heading"] = (
            "time",
            data.values - at,
            {"units": "rad", "long_name": "measured minus model heading"},
        )
    else:
        rotated = model
        bias = np.array(
            [comparison.offsets.get(f"bias_{a}", np.zeros(1))[0] for a in "xyz"]
        )
        at = (
            np.stack(
                [np.interp(data.time, t_model, rotated[:, k]) for k in range(3)], axis=1
            )
            + bias
        )
        ds = ds.assign_coords(sensor_axis=("sensor_axis", ["x", "y", "z"]))
        ds["measured_rate"] = (
            ("time", "sensor_axis"),
            data.values,
            {"units": "rad s-1", "long_name": "measured gyroscope rates"},
        )
        ds["model_rate"] = (
            ("time", "sensor_axis"),
            at,
            {
                "units": "rad s-1",
                "long_name": "best model's rates in the sensor's axes, bias added",
            },
        )
        ds["residual_rate"] = (
            ("time", "sensor_axis"),
            data.values - at,
            {"units": "rad s-1", "long_name": "measured minus model rates"},
        )
    ds = ds.assign_coords(feature=("feature", list(measured.names)))
    ds["measured_feature"] = (
        ("feature", "window"),
        measured.values,
        {"long_name": "measured feature per window (rad or rad s-1)"},
    )
    ds["model_feature"] = (
        ("feature", "window"),
        model_features,
        {"long_name": "best model's feature per window (rad or rad s-1)"},
    )
    ds["feature_scale"] = (
        "feature",
        measured.scale,
        {"long_name": "scale each feature's residuals are divided by"},
    )
    return ds
