"""Sweep specifications: :class:`Sweep`, its TOML form, and the checks made before any
compute.

A sweep names axes (value lists or ``linspace``-style ranges, in chosen units), fixed
values for the other parameters, and optional parameters drawn at random for each of
``repeats`` repeats of every grid cell. The TOML file maps one-to-one onto the class::

    name = "toy spin x misalignment"
    tile_size = 2048          # points per dask task (optional: automatic by default)
    method = "rk4"
    reversal_band = 0.05

    [axes]
    spin = { start = -30, stop = 30, num = 41 }          # rad/s by default
    delta_deg = { start = -8, stop = 8, num = 33 }       # degrees by its name
    mu = [0.3, inf]

    [fixed]
    t_end = 5.0
    roll = { value = 0.5, units = "deg" }

    [random]                   # optional; needs repeats >= 1 and gives a `repeat` axis
    pitch_deg = { uniform = [-0.2, 0.2] }

The body is a preset (``body = "toy"``, the default), a preset axis
(``body = ["toy", "kane_levinson"]``), an explicit body table
(``body = { a = ..., b = ..., c = ..., mass = ..., com = [...], inertia = [[...]] }``), or,
when any of ``a, b, c, mass, delta`` is given, a homogeneous semi-ellipsoid
(:meth:`rattlesweep.Body.semi_ellipsoid`) whose unspecified parameters are the ``toy``
preset's.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..batch import METHODS, check_band, prepare
from ..body import PRESETS, Body
from .grid import Axis, RandomParam, batch_inputs
from .params import BODY_PARAMS, DEFAULTS, PARAMS, check_values, resolve

_TOP_KEYS = ("name", "axes", "fixed", "random", "repeats", "seed", "method",
             "reversal_band", "tile_size")
TILE_STEPS = 2e7
"""Trajectory-steps per tile aimed at by the automatic tile size."""
_RANGE_KEYS = {"start", "stop", "num", "units", "scale"}
_VALUES_KEYS = {"values", "units"}


def _is_number(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _default_units(key: str) -> str:
    param = PARAMS[key[:-4]] if key.endswith("_deg") and key[:-4] in PARAMS else PARAMS[key]
    return "deg" if key.endswith("_deg") else next(iter(param.units))


def _units_entry(key: str, units) -> dict:
    if units is None or units == _default_units(key):
        return {}
    if not isinstance(units, str):
        raise ValueError(f"units of {key!r} must be a string, got {units!r}")
    return {"units": units}


def _body_entry(value, where: str):
    """Normalise a body value: a preset name or a plain-number description."""
    if isinstance(value, str):
        if value not in PRESETS:
            raise ValueError(f"{where}: preset name {value!r} is unknown; choose one of "
                             f"{sorted(PRESETS)}")
        return value
    if isinstance(value, Body):
        return value.describe()
    if isinstance(value, Mapping):
        return _body_from_dict(value, where).describe()
    raise ValueError(f"{where}: a body is a preset name, a Body, or a table with a, b, c, "
                     f"mass, com, inertia; got {value!r}")


def _body_from_dict(d: Mapping, where: str) -> Body:
    allowed = {"a", "b", "c", "mass", "com", "inertia", "full_ellipsoid", "body_name", "name"}
    extra = set(d) - allowed
    if extra:
        raise ValueError(f"{where}: unknown body keys {sorted(extra)}; a body table has "
                         f"{sorted(allowed - {'body_name'})}")
    missing = {"a", "b", "c", "mass", "com", "inertia"} - set(d)
    if missing:
        raise ValueError(f"{where}: body table lacks {sorted(missing)}")
    try:
        return Body(d["a"], d["b"], d["c"], d["mass"], d["com"], d["inertia"],
                    bool(d.get("full_ellipsoid", False)),
                    name=str(d.get("name", d.get("body_name", "custom"))))
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _normalise_axis(key: str, spec) -> dict:
    where = f"axes.{key}"
    if key == "body":
        names = list(spec.get("values", [])) if isinstance(spec, Mapping) else list(spec)
        if not names:
            raise ValueError(f"{where}: axis is empty")
        for name in names:
            if not isinstance(name, str):
                raise ValueError(f"{where}: a body axis lists preset names, got {name!r}")
            _body_entry(name, where)
        if len(set(names)) != len(names):
            raise ValueError(f"{where}: axis has duplicate values {names}")
        return {"values": names}
    if isinstance(spec, (list, tuple, np.ndarray)):
        spec = {"values": list(np.asarray(spec).tolist())}
    if not isinstance(spec, Mapping):
        raise ValueError(f"{where}: an axis is a list of values or a table "
                         f"{{start, stop, num[, units, scale]}}; got {spec!r}")
    keys = set(spec)
    param, factor, _ = resolve(key, spec.get("units"), where)
    if "values" in keys:
        if keys - _VALUES_KEYS:
            raise ValueError(f"{where}: unknown keys {sorted(keys - _VALUES_KEYS)} next to "
                             f"'values' (allowed: values, units)")
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
        check_values(param, np.array(values), factor, where)
        return {"values": values, **_units_entry(key, spec.get("units"))}
    if keys - _RANGE_KEYS or not {"start", "stop", "num"} <= keys:
        raise ValueError(f"{where}: a range needs start, stop, num (and optionally units, "
                         f"scale); got keys {sorted(keys)}")
    start, stop, num = spec["start"], spec["stop"], spec["num"]
    if not (_is_number(start) and _is_number(stop) and math.isfinite(start)
            and math.isfinite(stop)):
        raise ValueError(f"{where}: start and stop must be finite numbers, "
                         f"got {start!r}, {stop!r}")
    if not (isinstance(num, (int, np.integer)) and not isinstance(num, bool) and num >= 1):
        raise ValueError(f"{where}: num must be an integer >= 1, got {num!r}")
    if num > 1 and not start < stop:
        raise ValueError(f"{where}: range is inverted or empty: need start < stop, got "
                         f"start={start!r}, stop={stop!r}")
    scale = spec.get("scale", "linear")
    if scale not in ("linear", "log"):
        raise ValueError(f"{where}: scale must be 'linear' or 'log', got {scale!r}")
    if scale == "log" and not start > 0:
        raise ValueError(f"{where}: a log range needs start > 0, got {start!r}")
    out = {"start": float(start), "stop": float(stop), "num": int(num)}
    if scale != "linear":
        out["scale"] = scale
    check_values(param, _range_values(out), factor, where)
    return {**out, **_units_entry(key, spec.get("units"))}


def _range_values(spec: Mapping) -> np.ndarray:
    if "values" in spec:
        return np.asarray(spec["values"], dtype=float)
    fn = np.geomspace if spec.get("scale") == "log" else np.linspace
    return fn(spec["start"], spec["stop"], spec["num"])


def _normalise_fixed(key: str, value):
    where = f"fixed.{key}"
    if key == "body":
        return _body_entry(value, where)
    units = None
    if isinstance(value, Mapping):
        if set(value) - {"value", "units"} or "value" not in value:
            raise ValueError(f"{where}: a fixed value is a number or {{value, units}}, "
                             f"got {dict(value)!r}")
        value, units = value["value"], value.get("units")
    param, factor, _ = resolve(key, units, where)
    if not _is_number(value):
        raise ValueError(f"{where}: must be a number, got {value!r}")
    check_values(param, np.array([float(value)]), factor, where)
    entry = _units_entry(key, units)
    return {"value": float(value), **entry} if entry else float(value)


def _normalise_random(key: str, spec) -> dict:
    where = f"random.{key}"
    if key == "body" or not isinstance(spec, Mapping):
        raise ValueError(f"{where}: a random parameter is a table {{uniform = [low, high]}} "
                         f"or {{normal = [mean, std]}} (optionally with units); got {spec!r}")
    kinds = [k for k in ("uniform", "normal") if k in spec]
    if len(kinds) != 1 or set(spec) - {"uniform", "normal", "units"}:
        raise ValueError(f"{where}: give exactly one of uniform = [low, high] or "
                         f"normal = [mean, std], optionally with units; got {dict(spec)!r}")
    kind = kinds[0]
    pair = spec[kind]
    if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and all(map(_is_number, pair))
            and all(math.isfinite(v) for v in pair)):
        raise ValueError(f"{where}: {kind} needs two finite numbers, got {pair!r}")
    a, b = float(pair[0]), float(pair[1])
    if kind == "uniform" and not a < b:
        raise ValueError(f"{where}: uniform range is inverted or empty: need low < high, "
                         f"got {[a, b]}")
    if kind == "normal" and not b > 0:
        raise ValueError(f"{where}: normal std must be > 0, got {b!r}")
    param, factor, _ = resolve(key, spec.get("units"), where)
    rp = RandomParam(key, param.name, kind, a, b, factor, "", "")
    check_values(param, np.array(rp.bounds()), factor, where)
    return {kind: [a, b], **_units_entry(key, spec.get("units"))}


@dataclass(frozen=True, eq=False)
class Sweep:
    """A parameter sweep: named axes, fixed values, optional random repeats.

    Parameters
    ----------
    axes : mapping of parameter name to a list of values, ``{"values": [...], "units": u}``
        or a range ``{"start", "stop", "num"[, "units"][, "scale": "log"]}`` (inclusive,
        like :func:`numpy.linspace`). Names: see :data:`rattlesweep.sweep.params.PARAMS`;
        angles take a ``_deg`` suffix for degrees. Axis order is dimension order.
    fixed : mapping of parameter name to a number or ``{"value", "units"}``; ``body`` to
        a preset name, a :class:`~rattlesweep.Body` or a body table. Launch, friction and
        numerics parameters left out take the :func:`rattlesweep.run_batch` defaults;
        ``t_end`` (s) is required to simulate (here or as an axis); without it the
        sweep serves :func:`rattlesweep.stability.stability_dataset` only.
    random : mapping of parameter name to ``{"uniform": [low, high]}`` or
        ``{"normal": [mean, std]}`` (truncated at 4 std), optionally with ``units``: drawn
        independently for every repeat of every grid cell, reproducibly from ``seed``.
    repeats : int, repeats per grid cell (a ``repeat`` dimension when ``random`` is given).
    seed : int >= 0, seed of the random draws.
    method : "rk4" or "euler".
    reversal_band : hysteresis of the reversal detector, a fraction of |initial spin|.
    tile_size : points per tile (one dask task, one file). Default: chosen from the
        configuration so that a tile is about ``TILE_STEPS`` trajectory-steps (about 2 s on
        one core) and the grid has at least 16 tiles, in multiples of 32 from 256 to
        65536; the chosen number is part of the stored configuration.
    name : a label stored with the results.

    Every value is checked when the sweep is made, including every combination of the
    extremes of the axes and random ranges (the rules are monotone in each parameter, so
    the extremes bound the grid): a bad configuration is a ValueError naming the key.
    """

    axes: Mapping[str, Any]
    fixed: Mapping[str, Any] = field(default_factory=dict)
    random: Mapping[str, Any] = field(default_factory=dict)
    repeats: int = 1
    seed: int = 0
    method: str = "rk4"
    reversal_band: float = 0.05
    tile_size: int | None = None
    name: str = "sweep"

    def __post_init__(self) -> None:
        for label, m in (("axes", self.axes), ("fixed", self.fixed), ("random", self.random)):
            if not isinstance(m, Mapping):
                raise ValueError(f"{label} must be a mapping of parameter names, got {m!r}")
        if not self.axes:
            raise ValueError("axes: a sweep needs at least one axis")
        axes = {str(k): _normalise_axis(str(k), v) for k, v in self.axes.items()}
        fixed = {str(k): _normalise_fixed(str(k), v) for k, v in self.fixed.items()}
        random = {str(k): _normalise_random(str(k), v) for k, v in self.random.items()}

        seen: dict[str, str] = {}
        for section, d in (("axes", axes), ("fixed", fixed), ("random", random)):
            for key in d:
                canon = key[:-4] if key.endswith("_deg") else key
                if canon in seen:
                    raise ValueError(f"{section}.{key}: {canon!r} is already given in "
                                     f"{seen[canon]}; give each parameter once")
                seen[canon] = f"{section}.{key}"
        shape_keys = [k for k in seen if k in BODY_PARAMS]
        if shape_keys and "body" in seen:
            raise ValueError(f"{seen['body']}: give either a body or the semi-ellipsoid "
                             f"parameters {shape_keys}, not both")
        if not shape_keys and "body" not in seen:
            fixed["body"] = "toy"
        for k, v in DEFAULTS.items():
            if k not in seen:
                fixed[k] = v

        for label, v, ok, rule in (
            ("repeats", self.repeats, isinstance(self.repeats, (int, np.integer))
             and not isinstance(self.repeats, bool) and self.repeats >= 1, "an integer >= 1"),
            ("seed", self.seed, isinstance(self.seed, (int, np.integer))
             and not isinstance(self.seed, bool) and 0 <= self.seed < 2**63,
             "an integer >= 0"),
            ("tile_size", self.tile_size, self.tile_size is None or (
                isinstance(self.tile_size, (int, np.integer))
                and not isinstance(self.tile_size, bool) and self.tile_size >= 1),
             "an integer >= 1 (or None: automatic)"),
            ("method", self.method, self.method in METHODS, f"one of {sorted(METHODS)}"),
            ("name", self.name, isinstance(self.name, str), "a string"),
        ):
            if not ok:
                raise ValueError(f"{label} must be {rule}, got {v!r}")
        try:
            band = check_band(self.reversal_band)
        except (TypeError, ValueError):
            raise ValueError(f"reversal_band must be in [0, 1) (a fraction of |initial "
                             f"spin|), got {self.reversal_band!r}") from None
        if self.repeats > 1 and not random:
            raise ValueError(f"repeats = {self.repeats} needs at least one [random] "
                             f"parameter; repeats of identical launches give identical "
                             f"results")
        for name, value in (("axes", axes), ("fixed", fixed), ("random", random),
                            ("repeats", int(self.repeats)), ("seed", int(self.seed)),
                            ("reversal_band", band)):
            object.__setattr__(self, name, value)
        max_steps = self._check_combinations()
        if self.tile_size is None:
            tile = min(TILE_STEPS / max_steps, self.size / 16)
            tile = int(min(max(32 * math.ceil(tile / 32), 256), 65536))
        else:
            tile = int(self.tile_size)
        object.__setattr__(self, "tile_size", tile)

    # --- structure --------------------------------------------------------------------
    # cached: size, shape and tile_range are asked for per tile and would rebuild the
    # axis arrays each time (cached_property writes the instance dict, frozen or not)
    @functools.cached_property
    def grid_axes(self) -> tuple[Axis, ...]:
        """The axes as :class:`~rattlesweep.sweep.grid.Axis` objects, in order."""
        out = []
        for key, spec in self.axes.items():
            if key == "body":
                out.append(Axis(key, "body", np.array(spec["values"]), 1.0, "",
                                "body preset"))
                continue
            param, factor, cf = resolve(key, spec.get("units"), f"axes.{key}")
            out.append(Axis(key, param.name, _range_values(spec), factor, cf,
                            param.long_name))
        return tuple(out)

    @functools.cached_property
    def random_params(self) -> tuple[RandomParam, ...]:
        out = []
        for key, spec in self.random.items():
            kind = "uniform" if "uniform" in spec else "normal"
            param, factor, cf = resolve(key, spec.get("units"), f"random.{key}")
            out.append(RandomParam(key, param.name, kind, *spec[kind], factor, cf,
                                   param.long_name))
        return tuple(out)

    def fixed_si(self) -> dict[str, float]:
        """Fixed numeric parameters in SI, by canonical name (``body`` excluded)."""
        out = {}
        for key, v in self.fixed.items():
            if key == "body":
                continue
            value, units = (v["value"], v.get("units")) if isinstance(v, Mapping) else (v, None)
            param, factor, _ = resolve(key, units, f"fixed.{key}")
            out[param.name] = value * factor
        return out

    def fixed_body(self):
        """The fixed body: a preset name, a Body, or None when the body varies."""
        v = self.fixed.get("body")
        return _body_from_dict(v, "fixed.body") if isinstance(v, Mapping) else v

    @property
    def simulates(self) -> bool:
        """True when the configuration has the end time a simulation needs (a
        configuration without ``t_end`` serves linear stability maps only)."""
        return any(k == "t_end" for k in (*self.axes, *self.fixed, *self.random))

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(self.axes) + (("repeat",) if self.random else ())

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.grid_axes) + (
            (self.repeats,) if self.random else ())

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    @property
    def n_tiles(self) -> int:
        return -(-self.size // self.tile_size)

    def tile_range(self, tile: int) -> tuple[int, int]:
        """Flat point indices [start, stop) of a tile."""
        start = tile * self.tile_size
        return start, min(start + self.tile_size, self.size)

    def points(self, start: int, stop: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Bodies and :func:`rattlesweep.batch.prepare` keyword arguments (SI) for the
        flat point indices [start, stop)."""
        index = np.arange(start, stop, dtype=np.int64)
        where = np.unravel_index(index, self.shape)
        columns: dict[str, np.ndarray] = {}
        body_column = None
        for ax, pos in zip(self.grid_axes, where):
            if ax.param == "body":
                body_column = ax.values[pos]
            else:
                columns[ax.param] = ax.si[pos]
        for rp in self.random_params:
            columns[rp.param] = rp.draw(self.seed, index) * rp.factor
        n = len(index)
        for k, v in self.fixed_si().items():
            columns[k] = np.full(n, v)
        return batch_inputs(columns, body_column, self.fixed_body())

    # --- checks -------------------------------------------------------------------------
    def _check_combinations(self) -> int:
        """Check every combination of the extremes of the varying parameters; return the
        largest number of steps any point takes (the extremes bound it too)."""
        varying: list[tuple[str, str, list]] = []
        for ax in self.grid_axes:
            if ax.param == "body":
                varying.append((ax.key, "body", list(ax.values)))
            else:
                si = ax.si
                varying.append((ax.key, ax.param, sorted({float(si.min()), float(si.max())})))
        for rp in self.random_params:
            lo, hi = rp.bounds()
            varying.append((rp.key, rp.param, [lo * rp.factor, hi * rp.factor]))
        combos = list(itertools.product(*[v[2] for v in varying]))
        fixed = self.fixed_si()
        if not self.simulates:
            fixed["t_end"] = 1.0  # a stability-only configuration: size tiles for 1 s
        columns = {k: np.full(len(combos), v) for k, v in fixed.items()}
        body_column = None
        for j, (_, param, _) in enumerate(varying):
            values = [c[j] for c in combos]
            if param == "body":
                body_column = np.array(values)
            else:
                columns[param] = np.array(values, dtype=float)

        def describe(i: int) -> str:
            return ", ".join(f"{key}={_show(combos[i][j], param, key)}"
                             for j, (key, param, _) in enumerate(varying))

        def check(sel: slice) -> int:
            bodies, kwargs = batch_inputs({k: v[sel] for k, v in columns.items()},
                                          None if body_column is None else body_column[sel],
                                          self.fixed_body())
            return int(prepare(bodies, **kwargs).nsteps.max())

        try:
            return check(slice(None))
        except ValueError:
            # find the first offending corner to name it
            for i in range(len(combos)):
                try:
                    check(slice(i, i + 1))
                except ValueError as exc:
                    raise ValueError(f"{exc} (at the sweep corner {describe(i)})") from None
            raise

    # --- serialisation ------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The normalised configuration as plain data (the TOML file's content)."""
        return json.loads(json.dumps({
            "name": self.name, "method": self.method, "reversal_band": self.reversal_band,
            "tile_size": self.tile_size, "repeats": self.repeats, "seed": self.seed,
            "axes": self.axes, "fixed": self.fixed, "random": self.random,
        }))

    @classmethod
    def from_dict(cls, d: Mapping) -> "Sweep":
        if not isinstance(d, Mapping):
            raise ValueError(f"a sweep configuration is a table, got {d!r}")
        unknown = set(d) - set(_TOP_KEYS)
        if unknown:
            raise ValueError(f"unknown configuration keys {sorted(unknown)}; allowed: "
                             f"{', '.join(_TOP_KEYS)}")
        if "axes" not in d:
            raise ValueError("axes: a sweep needs an [axes] table with at least one axis")
        return cls(**d)

    @classmethod
    def from_toml(cls, path_or_text: str | Path) -> "Sweep":
        """Read a sweep from a TOML file (a path) or TOML text."""
        text, label = str(path_or_text), "configuration"
        if isinstance(path_or_text, Path) or "\n" not in text and text.endswith(".toml"):
            label = str(path_or_text)
            try:
                text = Path(path_or_text).read_text()
            except OSError as exc:
                raise ValueError(f"cannot read {label}: {exc.strerror}") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"cannot parse {label} as TOML: {exc}") from None
        return cls.from_dict(data)

    def to_toml(self) -> str:
        """The configuration as TOML text; ``Sweep.from_toml(s.to_toml()) == s``."""
        d = self.to_dict()
        lines = ["# rattlesweep sweep configuration"]
        for key in ("name", "method", "reversal_band", "tile_size", "repeats", "seed"):
            lines.append(f"{key} = {_toml_value(d[key])}")
        for section in ("axes", "fixed", "random"):
            if not d[section]:
                continue
            lines += ["", f"[{section}]"]
            lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in d[section].items()]
        return "\n".join(lines) + "\n"

    def config_hash(self) -> str:
        """SHA-256 of the normalised configuration."""
        text = json.dumps(self.to_dict(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()

    def differences(self, other: "Sweep") -> list[str]:
        """Human-readable list of what differs between two configurations."""
        return _diff(self.to_dict(), other.to_dict(), "")

    def __eq__(self, other) -> bool:
        return isinstance(other, Sweep) and self.to_dict() == other.to_dict()

    __hash__ = None  # mutable-looking mappings inside; compare with ==


def _show(value, param: str, key: str) -> str:
    if param == "body":
        return repr(value)
    try:
        _, factor, cf = resolve(key, None, key)
    except ValueError:
        factor, cf = 1.0, ""
    return f"{value / factor:g}" + (f" {cf}" if cf not in ("", "1") else "")


def _diff(a, b, path: str) -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in list(a) + [k for k in b if k not in a]:
            sub = f"{path}.{k}" if path else k
            if k not in a:
                out.append(f"{sub}: added ({b[k]!r})")
            elif k not in b:
                out.append(f"{sub}: removed (was {a[k]!r})")
            else:
                out += _diff(a[k], b[k], sub)
        return out
    return [] if a == b else [f"{path}: {a!r} -> {b!r}"]


def _toml_key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() else json.dumps(key)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")
