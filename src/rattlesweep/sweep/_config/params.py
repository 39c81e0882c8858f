"""The parameters a sweep can vary: names, units, and the rules their values obey.

Every sweepable input is a scalar described in :mod:`rattlesweep.inputs` (name, SI
units, long name, default, rule); this module adds the units a configuration may give it
in. Values are given in the units the user chooses (``units = "deg"``, or a ``_deg``
suffix on an angle's name) and converted to SI before they reach the kernel. Results
name each parameter as :func:`rattlesweep.run_batch` does (:func:`result_name`): angles
in degrees as ``roll_deg``, ``delta_deg``..., the launch spin as ``launch_spin``; other
coordinates keep the user's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...inputs import RATTLEBACK, Input, Rule

__all__ = [
    "BODY_PARAMS",
    "DEFAULTS",
    "PARAMS",
    "Param",
    "check_values",
    "resolve",
    "result_name",
    "result_values",
]

_ANGLE = {
    "rad": (1.0, "rad"),
    "deg": (math.pi / 180.0, "degree"),
    "degree": (math.pi / 180.0, "degree"),
    "degrees": (math.pi / 180.0, "degree"),
}
_SPIN = {
    "rad/s": (1.0, "rad s-1"),
    "rad s-1": (1.0, "rad s-1"),
    "rpm": (2.0 * math.pi / 60.0, "rpm"),
    "rev/s": (2.0 * math.pi, "s-1"),
}
_LENGTH = {"m": (1.0, "m"), "cm": (0.01, "cm"), "mm": (0.001, "mm")}
_MASS = {"kg": (1.0, "kg"), "g": (0.001, "g")}
_TIME = {"s": (1.0, "s"), "ms": (0.001, "ms")}
_ONE = {"1": (1.0, "1")}
_DAMPING = {"N m s": (1.0, "N m s")}
_ACCEL = {"m/s2": (1.0, "m s-2"), "m s-2": (1.0, "m s-2")}

_UNITS = {
    "rad": _ANGLE,
    "rad s-1": _SPIN,
    "m": _LENGTH,
    "kg": _MASS,
    "s": _TIME,
    "1": _ONE,
    "N m s": _DAMPING,
    "m s-2": _ACCEL,
}
"""The units a configuration may give a parameter in, by the SI units of its
description (the first is the default)."""


@dataclass(frozen=True)
class Param:
    """One sweepable scalar: its description, the units a configuration may give it in
    (name -> (SI factor, CF units)) and its rule."""

    spec: Input
    units: dict[str, tuple[float, str]]

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def long_name(self) -> str:
        return self.spec.long_name

    @property
    def group(self) -> str:
        return self.spec.group

    @property
    def rule(self) -> Rule:
        assert self.spec.rule is not None  # every sweepable input has a rule
        return self.spec.rule


PARAMS: dict[str, Param] = {
    i.name: Param(i, _UNITS.get(i.units, {i.units: (1.0, i.units)}))
    for i in RATTLEBACK.values()
    if i.sweep
}
"""The inputs a sweep can vary (:mod:`rattlesweep.inputs`: those marked ``sweep``), each
in the units of :data:`_UNITS` for its SI units, or in those alone."""

BODY_PARAMS = tuple(k for k, p in PARAMS.items() if p.group == "body")
"""Parameters of a homogeneous semi-ellipsoid (:meth:`rattlesweep.Body.semi_ellipsoid`)."""

DEFAULTS = {
    k: float(p.spec.default)
    for k, p in PARAMS.items()
    if p.group != "body" and isinstance(p.spec.default, float)
}
"""Values (SI) of launch, friction and numerics parameters a sweep leaves out."""


def resolve(key: str, units: str | None, where: str) -> tuple[Param, float, str]:
    """Map a user key (``delta_deg``) and optional units to (param, SI factor, CF units).

    ``where`` names the place in the configuration for error messages.
    """
    name, suffix_units = key, None
    if key.endswith("_deg") and key[:-4] in PARAMS and PARAMS[key[:-4]].units is _ANGLE:
        name, suffix_units = key[:-4], "deg"
    if name not in PARAMS:
        import difflib

        allowed = (
            sorted(PARAMS)
            + ["body"]
            + [f"{n}_deg" for n in PARAMS if PARAMS[n].units is _ANGLE]
        )
        close = difflib.get_close_matches(key, allowed, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(
            f"{where}: unknown parameter {key!r}{hint}; sweepable parameters "
            f"are {', '.join(allowed)}"
        )
    param = PARAMS[name]
    if suffix_units and units not in (None, "deg", "degree", "degrees"):
        raise ValueError(f"{where}: {key!r} is in degrees by its name; got units {units!r}")
    u = units or suffix_units or next(iter(param.units))
    if u not in param.units:
        raise ValueError(
            f"{where}: units {u!r} are not allowed for {name!r}; use one of "
            f"{', '.join(repr(k) for k in param.units)}"
        )
    factor, cf = param.units[u]
    return param, factor, cf


def _canonical(key: str) -> str:
    return key[:-4] if key.endswith("_deg") and key[:-4] in PARAMS else key


def result_name(key: str) -> str:
    """The name a parameter given as ``key`` (``roll``, ``roll_deg``, ``spin``) has in
    results, the same as in :func:`rattlesweep.run_batch` results: ``<angle>_deg`` for an
    angle (its values in degrees, whatever units the configuration used),
    ``launch_spin`` for ``spin`` (``spin`` is the spin's time series), else the
    parameter's name."""
    name = _canonical(key)
    if name in PARAMS and PARAMS[name].units is _ANGLE:
        return f"{name}_deg"
    return "launch_spin" if name == "spin" else name


def result_values(
    key: str, values: np.ndarray, factor: float, units: str
) -> tuple[np.ndarray, str]:
    """Values (user units: SI = values * factor, CF ``units``) as the result holds them
    under :func:`result_name`: angles in degrees (the user's numbers when given in
    degrees), anything else as given."""
    name = _canonical(key)
    if name in PARAMS and PARAMS[name].units is _ANGLE and units != "degree":
        return np.degrees(np.asarray(values, dtype=float) * factor), "degree"
    return values, units


def check_values(param: Param, values: np.ndarray, factor: float, where: str) -> None:
    """Raise ValueError if any value (in the user's units, SI = values * factor) breaks
    the parameter's rule; the message quotes the value as the user wrote it."""
    bad = param.rule.bad(np.asarray(values, dtype=float) * factor)
    if np.any(bad):
        raise ValueError(
            f"{where}: {param.name} {param.rule.message}; got "
            f"{float(values[np.argmax(bad)])!r}"
        )
