"""The parameters a sweep can vary: names, units, and the rules their values obey.

Every sweepable input is a scalar named here. Values are given in the units the user
chooses (``units = "deg"``, or a ``_deg`` suffix on an angle's name) and converted to SI
before they reach the kernel. Results name each parameter as :func:`rattlesweep.run_batch`
does (:func:`result_name`): angles in degrees as ``roll_deg``, ``delta_deg``..., the
launch spin as ``launch_spin``; other coordinates keep the user's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["BODY_PARAMS", "DEFAULTS", "PARAMS", "Param", "check_values", "resolve",
           "result_name", "result_values"]

_ANGLE = {"rad": (1.0, "rad"), "deg": (math.pi / 180.0, "degree"),
          "degree": (math.pi / 180.0, "degree"), "degrees": (math.pi / 180.0, "degree")}
_SPIN = {"rad/s": (1.0, "rad s-1"), "rad s-1": (1.0, "rad s-1"),
         "rpm": (2.0 * math.pi / 60.0, "rpm"), "rev/s": (2.0 * math.pi, "s-1")}
_LENGTH = {"m": (1.0, "m"), "cm": (0.01, "cm"), "mm": (0.001, "mm")}
_MASS = {"kg": (1.0, "kg"), "g": (0.001, "g")}
_TIME = {"s": (1.0, "s"), "ms": (0.001, "ms")}
_ONE = {"1": (1.0, "1")}
_DAMPING = {"N m s": (1.0, "N m s")}
_ACCEL = {"m/s2": (1.0, "m s-2"), "m s-2": (1.0, "m s-2")}

# rule names: "positive" (finite > 0), "finite", "nonneg_inf" (>= 0, inf allowed),
# "nonneg" (finite >= 0)


@dataclass(frozen=True)
class Param:
    """One sweepable scalar: its SI unit table, default, rule and long name."""

    name: str
    units: dict[str, tuple[float, str]]
    rule: str
    long_name: str
    group: str  # "body", "launch", "friction", "numerics"


PARAMS: dict[str, Param] = {p.name: p for p in (
    Param("a", _LENGTH, "positive", "semi-axis along body x", "body"),
    Param("b", _LENGTH, "positive", "semi-axis along body y", "body"),
    Param("c", _LENGTH, "positive", "semi-axis along body z", "body"),
    Param("mass", _MASS, "positive", "mass", "body"),
    Param("delta", _ANGLE, "finite", "misalignment of the inertia axes about +z", "body"),
    Param("spin", _SPIN, "finite", "initial spin about the vertical", "launch"),
    Param("roll", _ANGLE, "finite", "initial roll about body x", "launch"),
    Param("pitch", _ANGLE, "finite", "initial pitch about body y", "launch"),
    Param("yaw", _ANGLE, "finite", "initial yaw about the vertical", "launch"),
    Param("mu", _ONE, "nonneg_inf", "kinetic friction coefficient", "friction"),
    Param("mu_static", _ONE, "nonneg_inf", "static friction coefficient", "friction"),
    Param("mu_spin", _LENGTH, "nonneg", "spin friction coefficient (couple bound per "
          "unit normal force)", "friction"),
    Param("mu_roll", _LENGTH, "nonneg", "rolling resistance coefficient (couple bound "
          "per unit normal force)", "friction"),
    Param("damping", _DAMPING, "nonneg", "viscous torque coefficient", "friction"),
    Param("g", _ACCEL, "positive", "gravitational acceleration", "numerics"),
    Param("dt", _TIME, "positive", "time step", "numerics"),
    Param("t_end", _TIME, "positive", "requested end time", "numerics"),
)}

BODY_PARAMS = ("a", "b", "c", "mass", "delta")
"""Parameters of a homogeneous semi-ellipsoid (:meth:`rattlesweep.Body.semi_ellipsoid`)."""

DEFAULTS = {"spin": 0.0, "roll": 0.0, "pitch": 0.0, "yaw": 0.0, "mu": math.inf,
            "mu_spin": 0.0, "mu_roll": 0.0, "damping": 0.0, "g": 9.81}
"""Values (SI) of launch, friction and numerics parameters a sweep leaves out."""

_RULES = {
    "positive": (lambda v: np.isfinite(v) & (v > 0), "must be finite and > 0"),
    "finite": (lambda v: np.isfinite(v), "must be finite"),
    "nonneg_inf": (lambda v: v >= 0, "must be >= 0 (inf allowed)"),
    "nonneg": (lambda v: np.isfinite(v) & (v >= 0), "must be finite and >= 0"),
}


def resolve(key: str, units: str | None, where: str) -> tuple[Param, float, str]:
    """Map a user key (``delta_deg``) and optional units to (param, SI factor, CF units).

    ``where`` names the place in the configuration for error messages.
    """
    name, suffix_units = key, None
    if key.endswith("_deg") and key[:-4] in PARAMS and PARAMS[key[:-4]].units is _ANGLE:
        name, suffix_units = key[:-4], "deg"
    if name not in PARAMS:
        import difflib

        allowed = sorted(PARAMS) + ["body"] + [f"{n}_deg" for n in PARAMS
                                                if PARAMS[n].units is _ANGLE]
        close = difflib.get_close_matches(key, allowed, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"{where}: unknown parameter {key!r}{hint}; sweepable parameters "
                         f"are {', '.join(allowed)}")
    param = PARAMS[name]
    if suffix_units and units not in (None, "deg", "degree", "degrees"):
        raise ValueError(f"{where}: {key!r} is in degrees by its name; got units {units!r}")
    u = units or suffix_units or next(iter(param.units))
    if u not in param.units:
        raise ValueError(f"{where}: units {u!r} are not allowed for {name!r}; use one of "
                         f"{', '.join(repr(k) for k in param.units)}")
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


def result_values(key: str, values: np.ndarray, factor: float, units: str
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
    ok, rule = _RULES[param.rule]
    with np.errstate(invalid="ignore"):
        bad = ~ok(np.asarray(values, dtype=float) * factor)
    if np.any(bad):
        raise ValueError(f"{where}: {param.name} {rule}; got {float(values[np.argmax(bad)])!r}")
