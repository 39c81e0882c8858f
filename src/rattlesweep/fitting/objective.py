"""What a fit compares: features of the measured series against the same features of
the model's, for a whole batch of candidate parameter sets in one ``run_batch``.

The rocking phase of a long run depends on every input, so residuals of the raw series
over many rocking periods make a landscape with a minimum per rocking period. The slow
information (damping, friction, the launch) is in quantities that do not depend on that
phase, so the fit compares, in consecutive windows of ``window`` seconds (several
rocking periods):

* heading data: the mean heading in each window (rad), less an offset (the video's zero
  is arbitrary), fitted in closed form;
* gyroscope data: the mean spin rate (the sensor's z rate) in each window, and the root
  mean square of the x and y rates about their window means (the rocking's envelope),
  with a constant bias per axis fitted in closed form (``bias_x``, ``bias_y``,
  ``bias_z``; the x and y biases from the whole run's means). The data's noise raises
  their RMS, so the model's gets the measured noise added in quadrature. When the
  sensor's angles are fitted, also the covariance of the x and y rates in each window
  (``rocking_xy``, rad^2/s^2): the RMS of turned axes cannot tell a yaw from its mirror
  image, the covariance's sign can. With the axes known it adds little (the body's own
  x-y covariance is a fraction of a per cent of the x variance), so it is left out.

Each kind of feature is divided by a scale fixed from the data before the search: the
larger of its measurement noise (estimated from the scatter of consecutive samples) and
a floor: for rates 1 % of the feature's range, since a model agrees with a real
rattleback to a few per cent at best; for the heading :data:`HEADING_FLOOR`.
The sum of squares of the scaled residuals is the fit's chi-squared.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .measurement import Measurement

__all__ = [
    "Comparison",
    "Features",
    "HEADING_FLOOR",
    "compare",
    "in_sensor_axes",
    "measured_features",
]

HEADING_FLOOR = 1e-3
"""rad: the smallest scale of a window's mean heading (a line tracked in a video is
good to a fraction of a degree per frame, and a window averages many frames)."""


@dataclass(frozen=True)
class Features:
    """The windows (``edges``, s) of a measurement, its features (``values``, one row
    of ``names`` each) and the scale of each row."""

    edges: np.ndarray
    names: tuple[str, ...]
    values: np.ndarray  # (n_features, n_windows)
    scale: np.ndarray  # (n_features,)
    noise: np.ndarray  # the data's noise per series (rad, or rad/s per sensor axis)

    @property
    def size(self) -> int:
        return int(self.values.size)


def _windows(time: np.ndarray, window: float) -> np.ndarray:
    n = max(4, int(round(time[-1] / window)))
    return np.linspace(0.0, time[-1], n + 1)


def _window_index(time: np.ndarray, edges: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(edges, time, side="right") - 1, 0, len(edges) - 2)


def _means(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Window means of ``values`` (..., samples) for window ``index`` of each sample."""
    counts = np.bincount(index, minlength=n)
    out = np.zeros(values.shape[:-1] + (n,))
    for k in range(n):
        out[..., k] = values[..., index == k].mean(axis=-1) if counts[k] else np.nan
    return out


def _noise(values: np.ndarray) -> float:
    """The noise of a sampled series: the median absolute second difference, scaled
    to a standard deviation (a second difference of white noise has variance 6 σ²)."""
    d2 = np.diff(values, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def measured_features(data: Measurement, window: float, cross: bool = False) -> Features:
    """The features of the measurement, and their scales; with ``cross``, a
    gyroscope's x-y covariance per window too."""
    edges = _windows(data.time, window)
    index = _window_index(data.time, edges)
    n = len(edges) - 1
    counts = np.maximum(np.bincount(index, minlength=n), 1)
    if data.kind == "heading":
        values = _means(index, data.values, n)[None]
        noise = np.array([_noise(data.values)])
        scale = np.array([max(noise[0] / np.sqrt(counts.mean()), HEADING_FLOOR)])
        return Features(edges, ("heading",), values, scale, noise)
    rows = _gyro_rows(index, data.values.T, n, cross=cross)
    noise = np.array([_noise(data.values[:, a]) for a in range(3)])
    scales: list[float] = [
        max(nz / np.sqrt(counts.mean()), 0.01 * np.ptp(row), 1e-6)
        for nz, row in zip(noise[[2, 0, 1]], rows)
    ]
    names: tuple[str, ...] = ("spin", "rocking_x", "rocking_y")
    if cross:
        # the covariance's scatter from the noise: each axis's noise times the other
        # axis's rocking, and the noises' own product, over a window's samples
        vx, vy = np.nanmean(rows[1] ** 2), np.nanmean(rows[2] ** 2)
        nx, ny = noise[0], noise[1]
        scatter = np.sqrt(nx**2 * vy + ny**2 * vx + nx**2 * ny**2) / np.sqrt(counts.mean())
        scales.append(max(scatter, 0.01 * np.sqrt(vx * vy), 1e-12))
        names += ("rocking_xy",)
    return Features(edges, names, rows, np.array(scales), noise)


def _gyro_rows(
    index: np.ndarray,
    rates: np.ndarray,
    n: int,
    noise: np.ndarray | None = None,
    cross: bool = False,
) -> np.ndarray:
    """(3, ..., n): the window means of the z rate and the RMS of x and y about their
    window means, for rates (3, ..., samples); with the ``noise`` of the x and y
    series added in quadrature (a model's series, compared with noisy data, whose RMS
    the noise raises); with ``cross`` (4, ..., n), the x-y covariance too (independent
    noise leaves it unbiased)."""
    mean = _means(index, rates, n)
    square = _means(index, rates**2, n)
    variance = square[:2] - mean[:2] ** 2
    if noise is not None:
        variance = variance + (noise[:2] ** 2).reshape((2,) + (1,) * (variance.ndim - 1))
    rms = np.sqrt(np.maximum(variance, 0.0))
    rows = [mean[2], rms[0], rms[1]]
    if cross:
        rows.append(_means(index, rates[0] * rates[1], n) - mean[0] * mean[1])
    return np.stack(rows)


@dataclass(frozen=True)
class Comparison:
    """The model's features for a batch of candidates against the measured ones:
    ``residuals`` (candidates, n) scaled, ``chi2`` (candidates,), and the offsets fitted
    in closed form (``offsets``: name to (candidates,) values)."""

    residuals: np.ndarray
    chi2: np.ndarray
    offsets: dict[str, np.ndarray]


def compare(
    data: Measurement,
    measured: Features,
    model_time: np.ndarray,
    model_series: np.ndarray,
    *,
    fit_bias: bool = True,
    rotation: np.ndarray | None = None,
    heading_sign: float = 1.0,
) -> Comparison:
    """Compare a batch of model runs with the measurement. ``model_series``: the
    heading (candidates, times) or the body-frame rates (candidates, times, 3) at
    ``model_time``, sampled several times as densely as the data, and interpolated to
    the data's times (a window's mean of a steep heading depends on where its samples
    fall, so both are taken at the same times). A run that ended early (NaN) gets
    infinite chi-squared."""
    n = len(measured.edges) - 1
    index = _window_index(data.time, measured.edges)
    if data.kind == "heading":
        at = _interp(data.time, model_time, heading_sign * model_series[..., None])[..., 0]
        model = _means(index, at, n)[:, None, :]  # (c, 1, n)
        offset = np.nanmean(measured.values[None] - model, axis=(1, 2))
        model = model + offset[:, None, None]
        offsets = {"heading_offset": offset}
    else:
        series = (
            model_series if rotation is None else in_sensor_axes(model_series, rotation)
        )
        rates = np.moveaxis(
            _interp(data.time, model_time, series), -1, 0
        )  # (3, c, samples)
        cross = len(measured.names) == 4
        model = np.moveaxis(
            _gyro_rows(index, rates, n, measured.noise, cross), 0, 1
        )  # (c, 3 or 4, n)
        offsets = {}
        if fit_bias:
            bias = data.values.mean(axis=0)[None] - np.moveaxis(rates.mean(axis=-1), 0, 1)
            bias[:, 2] = np.nanmean(measured.values[0][None] - model[:, 0], axis=1)
            model[:, 0] += bias[:, 2:3]
            offsets = {f"bias_{a}": bias[:, k] for k, a in enumerate("xyz")}
    residuals = ((model - measured.values[None]) / measured.scale[None, :, None]).reshape(
        len(model), -1
    )
    chi2 = np.sum(residuals**2, axis=1)
    chi2[~np.isfinite(chi2)] = np.inf
    residuals[~np.isfinite(residuals)] = 1e6
    return Comparison(residuals, chi2, offsets)


def in_sensor_axes(series: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rates (c, t, 3) in the sensor's axes, for one rotation (3, 3) or one per
    candidate (c, 3, 3): a reading is ``R @ omega``."""
    if rotation.ndim == 2:
        return series @ rotation.T
    return np.einsum("cij,ctj->cti", rotation, series)


def _interp(t: np.ndarray, tm: np.ndarray, series: np.ndarray) -> np.ndarray:
    """Linear interpolation of series (candidates, model times, k) at times t."""
    j = np.clip(np.searchsorted(tm, t, side="right") - 1, 0, len(tm) - 2)
    w = ((t - tm[j]) / (tm[j + 1] - tm[j]))[None, :, None]
    return series[:, j] * (1.0 - w) + series[:, j + 1] * w
