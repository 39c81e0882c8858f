"""The inputs a fit may free or fix, their bounds, and the batch runs of candidates.

A fit frees inputs of :func:`rattlesweep.simulate` by any of the names it takes them by
(``spin``, ``roll`` or ``roll_deg``, ``mu``, ``damping``, ``mu_spin``, ...), and the
body's misalignment ``delta`` (rad) or ``delta_deg``: the body's inertia tensor turned
about the vertical axis so that its principal axes make that angle with the geometric
ones. The search works in the unit cube of the bounds, on a log scale for a bound range
of a positive input spanning a factor of 100 or more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..inputs import RATTLEBACK as INPUTS
from ..rattleback.batch import ACCEPTED
from ..rattleback.body import Body
from .sensor import ANGLES, SENSOR_NAMES, UNITS

__all__ = ["Bound", "FITTABLE", "bounds_from", "check_fixed", "defaults_left", "units_of"]

_NOT_FREE = {"t_end", "dt", "omega", "orientation", "velocity", "mu_static"}
FITTABLE = (
    tuple(n for n in ACCEPTED if n not in _NOT_FREE) + ("delta", "delta_deg") + ANGLES
)
"""Names a fit can free: the scalar launch, friction and gravity inputs of
:func:`rattlesweep.simulate` in each form it takes them, the body's misalignment, and
the angles of a gyroscope's axes (:mod:`.sensor`)."""


def units_of(name: str) -> str:
    """The units of an input as a fit reports it."""
    if name.endswith("_deg"):
        return "degree"
    if name in UNITS:
        return UNITS[name]
    return INPUTS[name].units


@dataclass(frozen=True)
class Bound:
    """A free input ``name`` between ``low`` and ``high``, searched on a log scale when
    ``log``."""

    name: str
    low: float
    high: float
    log: bool

    def value(self, u: np.ndarray) -> np.ndarray:
        """The input's values at unit-cube coordinates ``u``."""
        u = np.clip(u, 0.0, 1.0)
        if self.log:
            return self.low * (self.high / self.low) ** u
        return self.low + (self.high - self.low) * u

    def unit(self, value: float) -> float:
        """The unit-cube coordinate of ``value``."""
        if self.log:
            return math.log(value / self.low) / math.log(self.high / self.low)
        return (value - self.low) / (self.high - self.low)


def bounds_from(free: Mapping[str, tuple[float, float]]) -> list[Bound]:
    """The bounds of the free inputs, checked: a known name, two finite numbers, low
    below high; ValueError naming the input and the rule."""
    if not free:
        raise ValueError("free must name at least one input to fit, with its bounds")
    out = []
    for name, pair in free.items():
        if name not in FITTABLE:
            raise ValueError(
                f"free: {name!r} is not an input a fit can free; they are "
                f"{', '.join(FITTABLE)}"
            )
        try:
            low, high = (float(x) for x in pair)
        except (TypeError, ValueError):
            raise ValueError(
                f"free: {name} must have two bounds (low, high), got {pair!r}"
            ) from None
        if not (math.isfinite(low) and math.isfinite(high)):
            raise ValueError(
                f"free: {name} bounds must be finite numbers, got {low}:{high}"
            )
        if not low < high:
            raise ValueError(
                f"free: {name} bounds must have low < high, got {low:g}:{high:g}"
                + (" (inverted)" if low > high else "")
            )
        _check_range(name, low, high)
        out.append(Bound(name, low, high, low > 0 and high / low >= 100.0))
    names = [b.name.removesuffix("_deg") for b in out]
    twice = {n for n in names if names.count(n) > 1}
    if twice:
        raise ValueError(f"free: {', '.join(sorted(twice))} given twice (in two forms)")
    return out


def _check_range(name: str, low: float, high: float) -> None:
    base = name.removesuffix("_deg")
    if base in ("mu", "mu_spin", "mu_roll", "damping", "g") and low < 0:
        raise ValueError(f"free: {name} must be >= 0; its bounds are {low:g}:{high:g}")
    if base == "mu" and low == 0:
        raise ValueError(
            f"free: mu must be > 0 for a fit (mu = 0 is frictionless: no rolling); its "
            f"bounds are {low:g}:{high:g}"
        )


def check_fixed(fixed: Mapping[str, Any], bounds: list[Bound]) -> dict[str, Any]:
    """The fixed inputs, checked against the free ones."""
    free = {b.name.removesuffix("_deg") for b in bounds}
    both = sorted(n for n in fixed if n.removesuffix("_deg") in free)
    if both:
        raise ValueError(f"{', '.join(both)} both free and fixed: give each input one role")
    allowed = set(ACCEPTED) | {"delta", "delta_deg"} | set(SENSOR_NAMES)
    unknown = sorted(set(fixed) - allowed)
    if unknown:
        raise ValueError(
            f"fixed: {', '.join(unknown)} not inputs of simulate (they are "
            f"{', '.join(sorted(allowed))})"
        )
    if "t_end" in fixed:
        raise ValueError("fixed: t_end is set by the measurement's duration")
    return dict(fixed)


_DEFAULTED = ("spin", "roll", "pitch", "mu", "mu_spin", "mu_roll", "damping")


def defaults_left(bounds: list[Bound], fixed: Mapping[str, Any]) -> dict[str, float]:
    """The launch and friction inputs neither free nor fixed, with the defaults
    :func:`rattlesweep.simulate` gives them (a fit says so: a forgotten input is a
    common reason for a fit that cannot match)."""
    given = {b.name.removesuffix("_deg") for b in bounds}
    given |= {n.removesuffix("_deg") for n in fixed}
    if "mu_static" in fixed:
        given.add("mu")
    return {n: float(INPUTS[n].default) for n in _DEFAULTED if n not in given}


def bodies_for(body: Body, delta: np.ndarray) -> np.ndarray:
    """The body with its inertia turned about the vertical so that its misalignment is
    each of ``delta`` (rad)."""
    turn = np.asarray(delta, dtype=float) - body.misalignment
    out = np.empty(turn.shape, dtype=object)
    for k, angle in np.ndenumerate(turn):
        c, s = math.cos(angle), math.sin(angle)
        r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        out[k] = Body(
            body.a,
            body.b,
            body.c,
            body.mass,
            body.com,
            r @ body.inertia @ r.T,
            body.full_ellipsoid,
            name=body.name,
        )
    return out
