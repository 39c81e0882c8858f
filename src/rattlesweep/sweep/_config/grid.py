"""The points of a sweep: parameter values at flat grid indices, seeded random draws, and
the bodies they describe, packed as keyword arguments for
:func:`rattlesweep.rattleback.batch.prepare`.

Random draws are a counter-based hash of (seed, parameter name, flat point index), so a
point's draw does not depend on how the grid is cut into tiles, on the order tiles run, or
on which other parameters are random.
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ...rattleback.body import Body
from .params import BODY_PARAMS, DEFAULTS, PARAMS, result_name, result_values

__all__ = [
    "NORMAL_CLIP",
    "Axis",
    "RandomParam",
    "batch_inputs",
    "body_for",
    "semi_ellipsoid_defaults",
    "uniform01",
]

NORMAL_CLIP = 4.0
"""Normal draws are truncated at mean ± NORMAL_CLIP standard deviations (so validation of
the configuration can bound them)."""


@dataclass(frozen=True)
class Axis:
    """One sweep axis: ``key`` names the dimension; ``values`` are in the user's units
    (strings for a ``body`` axis of preset names); SI = values * factor."""

    key: str
    param: str
    values: np.ndarray
    factor: float
    units: str
    long_name: str

    @property
    def si(self) -> np.ndarray:
        return self.values * self.factor if self.param != "body" else self.values

    @property
    def name(self) -> str:
        """The dimension's name in results
        (:func:`~rattlesweep.sweep._config.params.result_name`)."""
        return result_name(self.key)

    def coordinate(self) -> tuple[np.ndarray, str]:
        """The coordinate's values and CF units in results (angles in degrees)."""
        if self.param == "body":
            return self.values, ""
        return result_values(self.key, self.values, self.factor, self.units)


@dataclass(frozen=True)
class RandomParam:
    """A parameter drawn afresh for every repeat of every grid cell."""

    key: str
    param: str
    kind: str  # "uniform" (a, b = low, high) or "normal" (a, b = mean, std)
    a: float
    b: float
    factor: float
    units: str
    long_name: str

    @property
    def name(self) -> str:
        """The draws' variable name in results."""
        return result_name(self.key)

    @property
    def result_units(self) -> str:
        """CF units of the draws in results (angles in degrees)."""
        return result_values(self.key, np.zeros(0), self.factor, self.units)[1]

    def result_draw(self, seed: int, index: np.ndarray) -> np.ndarray:
        """:meth:`draw` in the units of results (angles in degrees)."""
        return result_values(self.key, self.draw(seed, index), self.factor, self.units)[0]

    def bounds(self) -> tuple[float, float]:
        """Smallest and largest possible draw (user units)."""
        if self.kind == "uniform":
            return self.a, self.b
        return self.a - NORMAL_CLIP * self.b, self.a + NORMAL_CLIP * self.b

    def draw(self, seed: int, index: np.ndarray) -> np.ndarray:
        """Draws (user units) for the flat point indices ``index``."""
        u = uniform01(seed, self.key, index)
        if self.kind == "uniform":
            return self.a + (self.b - self.a) * u
        u2 = uniform01(seed, self.key + "#2", index)
        z = np.sqrt(-2.0 * np.log1p(-u)) * np.cos(2.0 * math.pi * u2)  # Box-Muller
        return self.a + self.b * np.clip(z, -NORMAL_CLIP, NORMAL_CLIP)


_M1 = np.uint64(0x9E3779B97F4A7C15)
_M2 = np.uint64(0xBF58476D1CE4E5B9)
_M3 = np.uint64(0x94D049BB133111EB)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    x = x + _M1
    x = (x ^ (x >> np.uint64(30))) * _M2
    x = (x ^ (x >> np.uint64(27))) * _M3
    return x ^ (x >> np.uint64(31))


def uniform01(seed: int, key: str, index: np.ndarray) -> np.ndarray:
    """Uniform draws in [0, 1) that depend only on (seed, key, index)."""
    stream = np.array([seed, zlib.crc32(key.encode())], dtype=np.uint64)
    base = _splitmix64(_splitmix64(stream[:1]) ^ stream[1:])
    with np.errstate(over="ignore"):
        x = _splitmix64(np.asarray(index, dtype=np.uint64) * _M1 ^ base)
    return (x >> np.uint64(11)).astype(np.float64) * 2.0**-53


def body_for(body: str | Body | None, params: Mapping[str, float]) -> Body | None:
    """The body of one point: ``body`` (a preset name, or a Body) unless semi-ellipsoid
    parameters are given, which build :meth:`Body.semi_ellipsoid`. None for neither."""
    if params:
        return _semi_ellipsoid(*(float(params[k]) for k in BODY_PARAMS))
    return _preset(body) if isinstance(body, str) else body


# Tiles of a sweep share bodies; building one (validation, inertia, default dt) costs
# about 0.5 ms, as much as its packing, so each distinct body is built once per process.
@functools.lru_cache(maxsize=4096)
def _semi_ellipsoid(a: float, b: float, c: float, mass: float, delta: float) -> Body:
    return Body.semi_ellipsoid(a, b, c, mass, delta)


@functools.lru_cache(maxsize=64)
def _preset(name: str) -> Body:
    return Body.preset(name)


def semi_ellipsoid_defaults() -> dict[str, float]:
    """SI values of a, b, c, mass, delta a sweep leaves out: those of the ``toy`` preset."""
    toy = _preset("toy")
    return {"a": toy.a, "b": toy.b, "c": toy.c, "mass": toy.mass, "delta": toy.misalignment}


def _object_array(items: list[Any]) -> np.ndarray:
    out = np.empty(len(items), dtype=object)
    out[:] = items
    return out


def batch_inputs(
    columns: dict[str, np.ndarray],
    body_column: np.ndarray | None,
    fixed_body: str | Body | None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Bodies and :func:`prepare` keyword arguments for a set of points.

    ``columns`` maps parameter names to SI arrays over the points (every swept, random and
    fixed parameter, broadcast); ``body_column`` holds preset names per point when the body
    is an axis; ``fixed_body`` is the fixed body (preset name or Body) otherwise. Bodies
    are built once per distinct parameter combination. The keyword arguments are SI
    arrays, or a default's number, or None for a ``t_end`` that is not given.
    """
    n = len(next(iter(columns.values())))
    shape_params = [k for k in BODY_PARAMS if k in columns]
    if shape_params:
        full: dict[str, float | np.ndarray] = {
            **semi_ellipsoid_defaults(),
            **{k: columns[k] for k in shape_params},
        }
        table = np.stack([np.broadcast_to(full[k], (n,)) for k in BODY_PARAMS], axis=1)
        uniq, inverse = np.unique(table, axis=0, return_inverse=True)
        made = _object_array([body_for(None, dict(zip(BODY_PARAMS, row))) for row in uniq])
        bodies = made[inverse.reshape(-1)]
    elif body_column is not None:
        names, inverse = np.unique(body_column, return_inverse=True)
        bodies = _object_array([_preset(name) for name in names])[inverse.reshape(-1)]
    else:
        bodies = _object_array([body_for(fixed_body, {})])[np.zeros(n, dtype=np.intp)]
    # an input neither given nor with a number for its default (mu_static, dt) is left
    # to the batch's own default; t_end, required, is None
    kwargs = {
        k: columns.get(k, DEFAULTS.get(k))
        for k, p in PARAMS.items()
        if p.group != "body" and (k in columns or k in DEFAULTS or p.spec.required)
    }
    return bodies, kwargs
