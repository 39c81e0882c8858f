"""The configuration schema: checking a sweep's settings and bringing them to one normal
form.

The normal form is plain data (numbers, strings, lists, tables) in which equal sweeps
look equal: axis values are floats, units equal to a parameter's default are left out, a
body is a preset name or a :meth:`rattlesweep.Body.describe` table, and the defaults
(the ``toy`` body, :data:`~rattlesweep.sweep._config.params.DEFAULTS`) are filled in. Every
error is a ValueError naming the key (``axes.spin``, ``fixed.body``, ``repeats``).

These checks look at one value at a time; the combinations of values a grid reaches are
checked by :mod:`rattlesweep.sweep._config.corners`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, TypeGuard

import numpy as np

from ..._core.workspace import METHODS
from ..._options import check_band
from ...rattleback.body import PRESETS, Body
from ..._validation import check_memory, is_real
from .grid import RandomParam
from .params import BODY_PARAMS, DEFAULTS, PARAMS, check_values, resolve
from .sizes import check_declared_size

__all__ = [
    "CONFIG_KEYS",
    "MAX_REFINE_LEVELS",
    "OUTPUTS",
    "STOPS",
    "axis_values",
    "body_from_table",
    "check_config_table",
    "normalise_axis",
    "normalise_body",
    "normalise_config",
    "normalise_fixed",
    "normalise_random",
    "normalise_refine",
]

CONFIG_KEYS = (
    "name",
    "axes",
    "fixed",
    "random",
    "repeats",
    "seed",
    "method",
    "reversal_band",
    "tile_size",
    "output",
    "stop",
    "lyapunov",
    "refine",
)
"""The keys a configuration table may have."""

OUTPUTS = ("netcdf", "zarr")
"""Output formats of a sweep: a directory of netCDF tiles merged into one file, or a
zarr store written tile by tile (:mod:`rattlesweep.sweep._outputs.zarr_store`)."""

STOPS = ("first_reversal",)
"""Stop rules a sweep may name (:func:`rattlesweep.run_batch`'s ``stop``); without one,
every launch runs to ``t_end``."""

_REFINE_KEYS = ("levels", "axes", "reversal_time_jump")
MAX_REFINE_LEVELS = 12

_RANGE_KEYS = {"start", "stop", "num", "units", "scale"}
_VALUES_KEYS = {"values", "units"}
_BODY_KEYS = {
    "a",
    "b",
    "c",
    "mass",
    "com",
    "inertia",
    "full_ellipsoid",
    "body_name",
    "name",
}
_BODY_REQUIRED = {"a", "b", "c", "mass", "com", "inertia"}


def _is_number(x: object) -> TypeGuard[int | float | np.integer | np.floating]:
    # the rule of the whole API (validation.is_real): 0-d real arrays are numbers too
    return is_real(x)


def _is_int(x: object) -> TypeGuard[int | np.integer]:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _default_units(key: str) -> str:
    param = PARAMS[key[:-4]] if key.endswith("_deg") and key[:-4] in PARAMS else PARAMS[key]
    return "deg" if key.endswith("_deg") else next(iter(param.units))


def _units_entry(key: str, units: object) -> dict[str, str]:
    if units is None or units == _default_units(key):
        return {}
    if not isinstance(units, str):
        raise ValueError(f"units of {key!r} must be a string, got {units!r}")
    return {"units": units}


def normalise_body(value: object, where: str) -> str | dict[str, Any]:
    """A body value as a preset name or a plain-number description table; ``value`` is
    a preset name, a :class:`~rattlesweep.Body` or a body table."""
    if isinstance(value, str):
        if value not in PRESETS:
            raise ValueError(
                f"{where}: preset name {value!r} is unknown; choose one of "
                f"{sorted(PRESETS)}"
            )
        return value
    if isinstance(value, Body):
        return body_table(value)
    if isinstance(value, Mapping):
        return body_table(body_from_table(value, where))
    raise ValueError(
        f"{where}: a body is a preset name, a Body, or a table with a, b, c, "
        f"mass, com, inertia; got {value!r}"
    )


def body_table(body: Body) -> dict[str, Any]:
    """The body as a body table: ``name`` first (the key ``rattlesweep design``'s
    ``[body]`` uses too; ``body_name`` is read as well), then the plain numbers of
    :meth:`~rattlesweep.Body.describe`."""
    d = body.describe()
    return {"name": d.pop("body_name"), **d}


def body_from_table(d: Mapping[str, Any], where: str) -> Body:
    """The :class:`~rattlesweep.Body` a body table describes (checked by ``Body``)."""
    extra = set(d) - _BODY_KEYS
    if extra:
        raise ValueError(
            f"{where}: unknown body keys {sorted(extra)}; a body table has "
            f"{sorted(_BODY_KEYS - {'body_name'})}"
        )
    missing = _BODY_REQUIRED - set(d)
    if missing:
        raise ValueError(f"{where}: body table lacks {sorted(missing)}")
    try:
        return Body(
            d["a"],
            d["b"],
            d["c"],
            d["mass"],
            d["com"],
            d["inertia"],
            d.get("full_ellipsoid", False),
            name=str(d.get("name", d.get("body_name", "custom"))),
        )
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def normalise_axis(key: str, spec: Any, *, check: bool = True) -> dict[str, Any]:
    """An axis as ``{"values": [...]}`` or ``{"start", "stop", "num"[, "scale"]}``, with
    ``units`` when they are not the parameter's default; every value is checked."""
    where = f"axes.{key}"
    if key == "body":
        return _normalise_body_axis(spec, where)
    if isinstance(spec, (list, tuple, np.ndarray)):
        # as given: _normalise_values refuses what is not a flat list of numbers
        spec = {"values": spec.tolist() if isinstance(spec, np.ndarray) else list(spec)}
    if not isinstance(spec, Mapping):
        raise ValueError(
            f"{where}: an axis is a list of values or a table "
            f"{{start, stop, num[, units, scale]}}; got {spec!r}"
        )
    param, factor, _ = resolve(key, spec.get("units"), where)
    if "values" in spec:
        out = _normalise_values(spec, where)
    else:
        out = _normalise_range(spec, where)
    if check or "values" in out:  # a range's values are made only to be checked
        check_values(param, axis_values(out), factor, where)
    return {**out, **_units_entry(key, spec.get("units"))}


def _normalise_body_axis(spec: Any, where: str) -> dict[str, Any]:
    names = list(spec.get("values", [])) if isinstance(spec, Mapping) else list(spec)
    if not names:
        raise ValueError(f"{where}: axis is empty")
    for name in names:
        if not isinstance(name, str):
            raise ValueError(f"{where}: a body axis lists preset names, got {name!r}")
        normalise_body(name, where)
    if len(set(names)) != len(names):
        raise ValueError(f"{where}: axis has duplicate values {names}")
    return {"values": names}


def _normalise_values(spec: Mapping[str, Any], where: str) -> dict[str, Any]:
    keys = set(spec)
    if keys - _VALUES_KEYS:
        raise ValueError(
            f"{where}: unknown keys {sorted(keys - _VALUES_KEYS)} next to "
            f"'values' (allowed: values, units)"
        )
    values = spec["values"]
    if isinstance(values, np.ndarray):
        values = values.tolist()
    if not isinstance(values, (list, tuple)) or not values:
        raise ValueError(f"{where}: axis is empty")
    if not all(_is_number(v) for v in values):
        raise ValueError(f"{where}: values must be numbers, got {list(values)!r}")
    values = [float(v) for v in values]
    if any(math.isnan(v) for v in values):
        raise ValueError(f"{where}: values must not be NaN")
    if len(set(values)) != len(values):
        raise ValueError(f"{where}: axis has duplicate values {values}")
    return {"values": values}


AXIS_VALUE_BYTES = 24
"""Bytes held per value of a range axis while a sweep's grid is built: about two copies
of 8 bytes at the peak (1e8 values: 1.65 GB), and one more as a margin."""


def _normalise_range(spec: Mapping[str, Any], where: str) -> dict[str, Any]:
    keys = set(spec)
    if keys - _RANGE_KEYS or not {"start", "stop", "num"} <= keys:
        raise ValueError(
            f"{where}: a range needs start, stop, num (and optionally units, "
            f"scale); got keys {sorted(keys)}"
        )
    start, stop, num = spec["start"], spec["stop"], spec["num"]
    if not (
        _is_number(start)
        and _is_number(stop)
        and math.isfinite(start)
        and math.isfinite(stop)
    ):
        raise ValueError(
            f"{where}: start and stop must be finite numbers, got {start!r}, {stop!r}"
        )
    if not (_is_int(num) and num >= 1):
        raise ValueError(f"{where}: num must be an integer >= 1, got {num!r}")
    if num > 1 and not start < stop:
        raise ValueError(
            f"{where}: range is inverted or empty: need start < stop, got "
            f"start={start!r}, stop={stop!r}"
        )
    scale = spec.get("scale", "linear")
    if scale not in ("linear", "log"):
        raise ValueError(f"{where}: scale must be 'linear' or 'log', got {scale!r}")
    if scale == "log" and not (start > 0 and stop > 0):
        raise ValueError(
            f"{where}: a log range needs start > 0 and stop > 0, got "
            f"start={start!r}, stop={stop!r}"
        )
    check_memory(f"{where}.num", num, AXIS_VALUE_BYTES * num, f"{num:,} axis values")
    out = {"start": float(start), "stop": float(stop), "num": int(num)}
    if scale != "linear":
        out["scale"] = scale
    return out


def axis_values(spec: Mapping[str, Any]) -> np.ndarray:
    """The values of a normalised numeric axis (user units)."""
    if "values" in spec:
        return np.asarray(spec["values"], dtype=float)
    if spec.get("scale") == "log":
        return np.geomspace(spec["start"], spec["stop"], spec["num"])
    return np.linspace(spec["start"], spec["stop"], spec["num"])


def normalise_fixed(key: str, value: Any) -> float | str | dict[str, Any]:
    """A fixed value as a float, or ``{"value", "units"}`` when the units are not the
    parameter's default; ``body`` as :func:`normalise_body`."""
    where = f"fixed.{key}"
    if key == "body":
        return normalise_body(value, where)
    units = None
    if isinstance(value, Mapping):
        if set(value) - {"value", "units"} or "value" not in value:
            raise ValueError(
                f"{where}: a fixed value is a number or {{value, units}}, "
                f"got {dict(value)!r}"
            )
        value, units = value["value"], value.get("units")
    param, factor, _ = resolve(key, units, where)
    if not _is_number(value):
        raise ValueError(f"{where}: must be a number, got {value!r}")
    check_values(param, np.array([float(value)]), factor, where)
    entry = _units_entry(key, units)
    return {"value": float(value), **entry} if entry else float(value)


def normalise_random(key: str, spec: Any) -> dict[str, Any]:
    """A random parameter as ``{"uniform": [low, high]}`` or ``{"normal": [mean, std]}``
    (with ``units`` when not the default); every value it can draw is checked."""
    where = f"random.{key}"
    if key == "body":
        raise ValueError(
            f"{where}: the body cannot be random; give it in [fixed], or as an axis "
            "of preset names"
        )
    if not isinstance(spec, Mapping):
        raise ValueError(
            f"{where}: a random parameter is a table {{uniform = [low, high]}} "
            f"or {{normal = [mean, std]}} (optionally with units); got {spec!r}"
        )
    kinds = [k for k in ("uniform", "normal") if k in spec]
    if len(kinds) != 1 or set(spec) - {"uniform", "normal", "units"}:
        raise ValueError(
            f"{where}: give exactly one of uniform = [low, high] or "
            f"normal = [mean, std], optionally with units; got {dict(spec)!r}"
        )
    kind = kinds[0]
    pair = spec[kind]
    if not (
        isinstance(pair, (list, tuple))
        and len(pair) == 2
        and all(map(_is_number, pair))
        and all(math.isfinite(v) for v in pair)
    ):
        raise ValueError(f"{where}: {kind} needs two finite numbers, got {pair!r}")
    a, b = float(pair[0]), float(pair[1])
    if kind == "uniform" and not a < b:
        raise ValueError(
            f"{where}: uniform range is inverted or empty: need low < high, got {[a, b]}"
        )
    if kind == "normal" and not b > 0:
        raise ValueError(f"{where}: normal std must be > 0, got {b!r}")
    param, factor, _ = resolve(key, spec.get("units"), where)
    rp = RandomParam(key, param.name, kind, a, b, factor, "", "")
    check_values(param, np.array(rp.bounds()), factor, where)
    return {kind: [a, b], **_units_entry(key, spec.get("units"))}


def _check_each_parameter_once(
    axes: Mapping[str, Any], fixed: Mapping[str, Any], random: Mapping[str, Any]
) -> set[str]:
    """Raise if a parameter is given twice (``delta`` and ``delta_deg`` are the same);
    return the canonical names given."""
    seen: dict[str, str] = {}
    for section, d in (("axes", axes), ("fixed", fixed), ("random", random)):
        for key in d:
            canon = key[:-4] if key.endswith("_deg") else key
            if canon in seen:
                raise ValueError(
                    f"{section}.{key}: {canon!r} is already given in "
                    f"{seen[canon]}; give each parameter once"
                )
            seen[canon] = f"{section}.{key}"
    shape_keys = [k for k in seen if k in BODY_PARAMS]
    if shape_keys and "body" in seen:
        raise ValueError(
            f"{seen['body']}: give either a body or the semi-ellipsoid "
            f"parameters {shape_keys}, not both"
        )
    return set(seen)


def normalise_refine(
    refine: Any, axes: Mapping[str, dict[str, Any]], output: str
) -> dict[str, Any]:
    """The ``refine`` table in normal form: ``levels`` (int >= 1), ``axes`` (the refined
    range axes, in dimension order; default every range axis of more than one value) and,
    when given, ``reversal_time_jump`` (s, > 0)."""
    if isinstance(refine, bool) or not isinstance(refine, (Mapping, int, np.integer)):
        raise ValueError(
            f"refine must be a table {{levels, axes, reversal_time_jump}} or "
            f"a number of levels, got {refine!r}"
        )
    spec = dict(refine) if isinstance(refine, Mapping) else {"levels": refine}
    unknown = set(spec) - set(_REFINE_KEYS)
    if unknown:
        raise ValueError(
            f"refine: unknown keys {sorted(unknown)}; allowed: {', '.join(_REFINE_KEYS)}"
        )
    if "levels" not in spec:
        raise ValueError(
            f"refine.levels is missing: a refined sweep needs its number of levels, an "
            f"integer from 1 to {MAX_REFINE_LEVELS} (each level halves the spacing of "
            "the refined axes), as `levels = 2` in [refine]"
        )
    levels = spec.get("levels")
    if not (_is_int(levels) and 1 <= levels <= MAX_REFINE_LEVELS):
        raise ValueError(
            f"refine.levels must be an integer from 1 to {MAX_REFINE_LEVELS} "
            f"(each level halves the spacing of the refined axes), got "
            f"{levels!r}"
        )
    ranges = [k for k, a in axes.items() if "num" in a and a["num"] > 1]
    chosen = spec.get("axes", ranges)
    if (
        isinstance(chosen, str)
        or not isinstance(chosen, (list, tuple))
        or not all(isinstance(k, str) for k in chosen)
    ):
        raise ValueError(f"refine.axes must be a list of axis names, got {chosen!r}")
    for key in chosen:
        if key not in axes:
            raise ValueError(
                f"refine.axes: {key!r} is not an axis of the sweep ({', '.join(axes)})"
            )
        if key not in ranges:
            raise ValueError(
                f"refine.axes: {key!r} is not a range of more than one value "
                "({start, stop, num}); only ranges can be refined"
            )
    if not ranges and "axes" not in spec:
        raise ValueError(
            "refine: a refined sweep needs a range axis ({start, stop, num} with num > "
            f"1) to refine; this sweep's axes are lists ({', '.join(axes)})"
        )
    if not chosen or len(set(chosen)) != len(chosen):
        raise ValueError(
            f"refine.axes must name at least one range axis, each once; got "
            f"{list(chosen)!r} (the sweep's ranges: {ranges})"
        )
    if output != "netcdf":
        raise ValueError(
            f"refine: a refined sweep is written as netCDF (output = "
            f'"netcdf"), got output = {output!r}'
        )
    out: dict[str, Any] = {"levels": int(levels), "axes": [k for k in axes if k in chosen]}
    if "reversal_time_jump" in spec:
        jump = spec["reversal_time_jump"]
        if not (_is_number(jump) and math.isfinite(jump) and jump > 0):
            raise ValueError(
                f"refine.reversal_time_jump must be a finite number > 0 (s), got {jump!r}"
            )
        out["reversal_time_jump"] = float(jump)
    return out


def normalise_config(
    *,
    axes: Mapping[Any, Any],
    fixed: Mapping[Any, Any],
    random: Mapping[Any, Any],
    repeats: Any,
    seed: Any,
    method: Any,
    reversal_band: Any,
    tile_size: Any,
    name: Any,
    output: Any = "netcdf",
    stop: Any = None,
    refine: Any = None,
    lyapunov: Any = False,
) -> dict[str, Any]:
    """The normal form of a configuration: a dict with the keys of :data:`CONFIG_KEYS`,
    scalars first (the order of the TOML file). ``tile_size`` stays None when not given
    (:func:`rattlesweep.sweep._config.corners.choose_tile_size` chooses it); ``stop``,
    ``lyapunov`` and ``refine`` are there only when given (``lyapunov`` when true), so
    that the configurations (and hashes) of sweeps without them do not change.

    ``fixed`` gains the parameters left out: the ``toy`` body when neither a body nor a
    semi-ellipsoid parameter is given, and
    :data:`~rattlesweep.sweep._config.params.DEFAULTS`.
    """
    for label, m in (("axes", axes), ("fixed", fixed), ("random", random)):
        if not isinstance(m, Mapping):
            raise ValueError(f"{label} must be a mapping of parameter names, got {m!r}")
    if not axes:
        raise ValueError("axes: a sweep needs at least one axis")
    axes_n = {str(k): normalise_axis(str(k), v, check=False) for k, v in axes.items()}
    fixed_n = {str(k): normalise_fixed(str(k), v) for k, v in fixed.items()}
    random_n = {str(k): normalise_random(str(k), v) for k, v in random.items()}

    given = _check_each_parameter_once(axes_n, fixed_n, random_n)
    if "body" not in given and not given & set(BODY_PARAMS):
        fixed_n["body"] = "toy"
    for k, v in DEFAULTS.items():
        if k not in given:
            fixed_n[k] = v

    for label, v, ok, rule in (
        ("repeats", repeats, _is_int(repeats) and repeats >= 1, "an integer >= 1"),
        ("seed", seed, _is_int(seed) and 0 <= seed < 2**63, "an integer >= 0"),
        (
            "tile_size",
            tile_size,
            tile_size is None or (_is_int(tile_size) and tile_size >= 1),
            "an integer >= 1 (or None: automatic)",
        ),
        ("method", method, method in METHODS, f"one of {sorted(METHODS)}"),
        ("output", output, output in OUTPUTS, f"one of {', '.join(map(repr, OUTPUTS))}"),
        ("name", name, isinstance(name, str), "a string"),
        (
            "stop",
            stop,
            stop is None or stop in STOPS,
            f"one of {', '.join(map(repr, STOPS))} (or left out: run to t_end)",
        ),
        ("lyapunov", lyapunov, isinstance(lyapunov, bool), "true or false"),
    ):
        if not ok:
            raise ValueError(f"{label} must be {rule}, got {v!r}")
    band = check_band(reversal_band)
    if repeats > 1 and not random_n:
        raise ValueError(
            f"repeats = {repeats} needs at least one [random] parameter; "
            f"repeats of identical launches give identical results"
        )
    config = {
        "name": name,
        "method": method,
        "reversal_band": band,
        "tile_size": None if tile_size is None else int(tile_size),
        "output": output,
        "repeats": int(repeats),
        "seed": int(seed),
    }
    if stop is not None:
        config["stop"] = stop
    if lyapunov:
        config["lyapunov"] = True
    config.update({"axes": axes_n, "fixed": fixed_n, "random": random_n})
    if refine is not None:
        config["refine"] = normalise_refine(refine, axes_n, output)
    check_declared_size(config)  # from the declared nums, before any range is made
    for k, v in axes.items():
        if "num" in axes_n[str(k)]:
            normalise_axis(str(k), v)  # the range's values checked
    return config


def check_config_table(d: object) -> None:
    """Raise ValueError unless ``d`` is a configuration table: a mapping with only
    :data:`CONFIG_KEYS` and an ``axes`` entry."""
    if not isinstance(d, Mapping):
        raise ValueError(f"a sweep configuration is a table, got {d!r}")
    unknown = set(d) - set(CONFIG_KEYS)
    if unknown:
        raise ValueError(
            f"unknown configuration keys {sorted(unknown)}; allowed: "
            f"{', '.join(CONFIG_KEYS)}"
        )
    if "axes" not in d:
        raise ValueError("axes: a sweep needs an [axes] table with at least one axis")
