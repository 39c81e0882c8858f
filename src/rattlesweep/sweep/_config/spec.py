"""Sweep specifications: the :class:`Sweep` value object.

A sweep names axes (value lists or ``linspace``-style ranges, in chosen units), fixed
values for the other parameters, and optional parameters drawn at random for each of
``repeats`` repeats of every grid cell. The TOML file maps one-to-one onto the class::

    name = "toy spin x misalignment"
    tile_size = 2048          # points per dask task (optional: automatic by default)
    output = "netcdf"         # or "zarr"
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

The work is split by job: :mod:`.schema` checks and normalises the settings,
:mod:`.corners` checks the combinations of their extremes and sizes the tiles,
:mod:`.toml_io` reads and writes the file; this module holds the resulting value and the
grid structure derived from it.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from types import MappingProxyType
from typing import Any, Iterator, Mapping

import numpy as np

from ...rattleback.body import Body
from ..._core.workspace import friction_level
from .corners import check_corners, choose_tile_size, tile_block
from .grid import Axis, RandomParam, batch_inputs
from .params import resolve
from .schema import axis_values, body_from_table, check_config_table, normalise_config
from .toml_io import format_toml, read_toml

__all__ = ["Sweep"]

_NONE: Mapping[str, Any] = MappingProxyType({})
_ARGUMENTS = (
    "axes",
    "fixed",
    "random",
    "repeats",
    "seed",
    "method",
    "reversal_band",
    "tile_size",
    "output",
    "name",
    "stop",
    "refine",
    "lyapunov",
)


class Sweep:
    """A parameter sweep: named axes, fixed values, optional random repeats.

    Parameters
    ----------
    axes : mapping of parameter name to a list of values, ``{"values": [...], "units": u}``
        or a range ``{"start", "stop", "num"[, "units"][, "scale": "log"]}`` (inclusive,
        like :func:`numpy.linspace`). Names: see
        :data:`rattlesweep.sweep._config.params.PARAMS`; angles take a ``_deg`` suffix for
        degrees. Axis order is dimension order.
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
    reversal_band : hysteresis of the reversal detector, a fraction of the initial spin's
        magnitude.
    tile_size : the most points in a tile (one dask task; one tile file, or one chunk of
        a zarr store). Default: chosen from the configuration so that a tile is about
        :data:`~rattlesweep.sweep._config.corners.TILE_STEPS` trajectory-steps (about 2 s on
        one core) and the grid has at least 16 tiles (a refined sweep: the grid one level
        finer than declared), in multiples of 32 from 256 to 65536; the chosen number is
        part of the stored configuration. A tile is a block of the grid
        (:func:`~rattlesweep.sweep._config.corners.tile_block`), so tiles can hold fewer
        points than this; a refined sweep cuts each level's points into tiles of this size.
    output : "netcdf" (a directory of tile files merged into ``sweep.nc``) or "zarr" (a
        zarr store written tile by tile); see :func:`rattlesweep.sweep.run_sweep`.
    name : a label stored with the results.
    stop : None (every launch runs to ``t_end``) or ``"first_reversal"``: a launch ends at
        its first reversal, or when it capsizes or lifts off (see
        :func:`rattlesweep.run_batch`).
    lyapunov : True adds each point's largest Lyapunov exponent, ``lyapunov`` (1/s; see
        :func:`rattlesweep.run_batch`); it needs rolling contact at every point.
    refine : adaptive refinement (:mod:`rattlesweep.sweep._refinement.plan`): a number of
        levels or a table ``{"levels": L, "axes": [...], "reversal_time_jump": s}``. Each
        level halves the spacing of the refined axes (default: every range axis), and only
        the cells where neighbouring outcomes differ (or, with ``reversal_time_jump``, first
        reversal times jump by more than that many seconds), with a margin of one cell,
        are simulated; the rest is filled from the cells' corners. The result lies on the
        finest grid (:meth:`finest`). Needs ``output = "netcdf"``.

    Every value is checked when the sweep is made, including every combination of the
    extremes of the axes and random ranges (the rules are monotone in each parameter, so
    the extremes bound the grid): a bad configuration is a ValueError naming the key.

    The attributes are the normalised configuration (:meth:`to_dict`), not the arguments
    as given: ``Sweep(**s.to_dict()) == s``. A sweep is immutable: the constructor
    normalises and checks the arguments first (:func:`.schema.normalise_config`,
    :func:`.corners.check_corners`) and then stores the result and the grid structure
    derived from it once, in slots behind read-only properties, so nothing is rewritten
    after it is stored and the per-tile questions (``shape``, ``size``, ``tile_range``)
    are answered without rebuilding the axes. The stored tables are plain dicts (they
    are what the result files record); treat them as read-only. Sweeps compare by
    configuration (``==``) and are not hashable; :meth:`config_hash` is the stable digest.
    """

    __slots__ = (
        "_config",
        "_grid_axes",
        "_random_params",
        "_shape",
        "_tile_shape",
        "_finest",
        "_max_steps",
    )
    _config: dict[str, Any]
    _grid_axes: tuple[Axis, ...]
    _random_params: tuple[RandomParam, ...]
    _shape: tuple[int, ...]
    _tile_shape: tuple[int, ...]
    _finest: Sweep | None
    _max_steps: int

    def __init__(
        self,
        axes: Mapping[str, Any],
        fixed: Mapping[str, Any] = _NONE,
        random: Mapping[str, Any] = _NONE,
        repeats: int = 1,
        seed: int = 0,
        method: str = "rk4",
        reversal_band: float = 0.05,
        tile_size: int | None = None,
        name: str = "sweep",
        output: str = "netcdf",
        stop: str | None = None,
        refine: Mapping[str, Any] | int | None = None,
        lyapunov: bool = False,
    ) -> None:
        config = normalise_config(
            axes=axes,
            fixed=fixed,
            random=random,
            repeats=repeats,
            seed=seed,
            method=method,
            reversal_band=reversal_band,
            tile_size=tile_size,
            name=name,
            output=output,
            stop=stop,
            refine=refine,
            lyapunov=lyapunov,
        )
        grid_axes = _grid_axes(config["axes"])
        random_params = _random_params(config["random"])
        shape = tuple(len(a.values) for a in grid_axes) + (
            (config["repeats"],) if random_params else ()
        )
        _warn_radians_as_degrees(config["fixed"], grid_axes, random_params)
        max_steps = check_corners(
            grid_axes,
            random_params,
            _fixed_si(config["fixed"]),
            _fixed_body(config["fixed"]),
            _fixed_shown({k: v for k, v in config["fixed"].items() if k in fixed}),
            lyapunov=config.get("lyapunov", False),
        )
        if config["tile_size"] is None:
            config = {
                **config,
                "tile_size": choose_tile_size(
                    max_steps,
                    _tiled_size(shape, list(config["axes"]), config.get("refine")),
                ),
            }
        self._config = config
        self._grid_axes = grid_axes
        self._random_params = random_params
        self._shape = shape
        self._tile_shape = tile_block(shape, config["tile_size"])
        self._finest = None
        self._max_steps = max_steps

    # --- the normalised configuration ---------------------------------------------------
    @property
    def axes(self) -> dict[str, dict[str, Any]]:
        """Normalised axes, in dimension order."""
        return self._config["axes"]

    @property
    def fixed(self) -> dict[str, Any]:
        """Normalised fixed values, defaults included."""
        return self._config["fixed"]

    @property
    def random(self) -> dict[str, dict[str, Any]]:
        """Normalised random parameters."""
        return self._config["random"]

    @property
    def repeats(self) -> int:
        return self._config["repeats"]

    @property
    def seed(self) -> int:
        return self._config["seed"]

    @property
    def method(self) -> str:
        return self._config["method"]

    @property
    def reversal_band(self) -> float:
        return self._config["reversal_band"]

    @property
    def tile_size(self) -> int:
        """Points per tile (the given number, or the automatic choice)."""
        return self._config["tile_size"]

    @property
    def name(self) -> str:
        return self._config["name"]

    @property
    def output(self) -> str:
        """Output format: "netcdf" or "zarr"."""
        return self._config["output"]

    @property
    def stop(self) -> str | None:
        """The stop rule: None (run to t_end) or "first_reversal"."""
        return self._config.get("stop")

    @property
    def lyapunov(self) -> bool:
        """True when each point's largest Lyapunov exponent is computed."""
        return self._config.get("lyapunov", False)

    @property
    def refine(self) -> dict[str, Any] | None:
        """The normalised refinement table (levels, axes[, reversal_time_jump]), or
        None."""
        return self._config.get("refine")

    def finest(self) -> "Sweep":
        """The sweep on the grid a refined sweep's result lies on: each refined axis with
        2**levels times finer spacing (``num`` becomes ``(num - 1) * 2**levels + 1``, so
        every declared value stays on it) and no refinement; the sweep itself when it
        is not refined."""
        refine = self.refine
        if refine is None:
            return self
        if self._finest is None:  # made once: its corner check costs milliseconds
            scale = 2 ** refine["levels"]
            axes = {
                k: ({**a, "num": (a["num"] - 1) * scale + 1} if k in refine["axes"] else a)
                for k, a in self.axes.items()
            }
            config = {k: v for k, v in self.to_dict().items() if k != "refine"}
            self._finest = Sweep(**{**config, "axes": axes})
        return self._finest

    @property
    def max_steps(self) -> int:
        """The most steps a launch of the sweep takes (found at the corners of its
        ranges), 0 without ``t_end``."""
        return self._max_steps

    # --- structure ----------------------------------------------------------------------
    @property
    def grid_axes(self) -> tuple[Axis, ...]:
        """The axes as :class:`~rattlesweep.sweep._config.grid.Axis` objects, in order."""
        return self._grid_axes

    @property
    def random_params(self) -> tuple[RandomParam, ...]:
        """The random parameters as :class:`~rattlesweep.sweep._config.grid.RandomParam`
        objects."""
        return self._random_params

    @property
    def friction_level(self) -> int:
        """The kernel's friction level (:func:`rattlesweep._core.workspace.friction_level`)
        that the sweep's launches can need, from every value its friction coefficients
        take (a random one: any value)."""
        values: dict[str, list[float]] = {
            k: [] for k in ("mu", "mu_static", "mu_spin", "mu_roll")
        }
        for axis in self.grid_axes:
            if axis.param in values:
                values[axis.param].extend(np.asarray(axis.si, dtype=float).ravel())
        for param in self.random_params:
            if param.param in values:
                values[param.param].extend([1.0, math.nan])  # any value: the highest level
        for key, value in self.fixed_si().items():
            if key in values:
                values[key].append(float(value))
        static = values["mu_static"] or values["mu"] or [math.inf]
        return friction_level(
            np.array(static),
            np.array(values["mu_spin"] or [0.0]),
            np.array(values["mu_roll"] or [0.0]),
        )

    def fixed_si(self) -> dict[str, float]:
        """Fixed numeric parameters in SI, by canonical name (``body`` excluded)."""
        return _fixed_si(self.fixed)

    def fixed_body(self) -> str | Body | None:
        """The fixed body: a preset name, a Body, or None when the body varies."""
        return _fixed_body(self.fixed)

    @property
    def simulates(self) -> bool:
        """True when the configuration has the end time a simulation needs (a
        configuration without ``t_end`` serves linear stability maps only)."""
        return any(k == "t_end" for k in (*self.axes, *self.fixed, *self.random))

    @property
    def dims(self) -> tuple[str, ...]:
        """The result's dimensions: the axes as results name them (``launch_spin``,
        ``roll_deg``: :func:`~rattlesweep.sweep._config.params.result_name`), then
        ``repeat`` when there are random draws."""
        return tuple(ax.name for ax in self.grid_axes) + (
            ("repeat",) if self.random else ()
        )

    @property
    def shape(self) -> tuple[int, ...]:
        return self._shape

    @property
    def size(self) -> int:
        return _size(self._shape)

    @property
    def tile_shape(self) -> tuple[int, ...]:
        """The shape of a full tile, a block of the grid of at most ``tile_size`` points
        (tiles at the ends of a dimension can be smaller)."""
        return self._tile_shape

    @property
    def _tile_grid(self) -> tuple[int, ...]:
        return tuple(-(-n // b) for n, b in zip(self._shape, self._tile_shape))

    @property
    def n_tiles(self) -> int:
        return _size(self._tile_grid)

    def tile_region(self, tile: int) -> tuple[slice, ...]:
        """The block of the grid a tile covers, one slice per dimension."""
        corner = np.unravel_index(tile, self._tile_grid)
        return tuple(
            slice(int(i) * b, min((int(i) + 1) * b, n))
            for i, b, n in zip(corner, self._tile_shape, self._shape)
        )

    def tile_range(self, tile: int) -> tuple[int, int]:
        """Flat point indices [start, stop) of a tile (its points are consecutive)."""
        region = self.tile_region(tile)
        start = int(np.ravel_multi_index([r.start for r in region], self._shape))
        return start, start + _size(tuple(r.stop - r.start for r in region))

    def points(self, start: int, stop: int) -> tuple[np.ndarray, dict[str, Any]]:
        """Bodies and :func:`rattlesweep.rattleback.batch.prepare` keyword arguments (SI)
        for the flat point indices [start, stop)."""
        return self.points_at(np.arange(start, stop, dtype=np.int64))

    def points_at(self, index: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """As :meth:`points`, for any flat point indices ``index`` (int64)."""
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

    # --- serialisation ------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The normalised configuration as plain data (the TOML file's content)."""
        return json.loads(json.dumps(self._config))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Sweep":
        check_config_table(d)
        return cls(**d)

    @classmethod
    def from_toml(cls, path_or_text: str | Path) -> "Sweep":
        """Read a sweep from a TOML file (a path) or TOML text."""
        return cls.from_dict(read_toml(path_or_text))

    def to_toml(self) -> str:
        """The configuration as TOML text; ``Sweep.from_toml(s.to_toml()) == s``."""
        document = {k: v for k, v in self.to_dict().items() if v != {}}
        return format_toml(document, comment="rattlesweep sweep configuration")

    def config_hash(self) -> str:
        """SHA-256 of the normalised configuration, the order of the axes (the order of
        the result's dimensions) included."""
        text = json.dumps(
            {"config": self.to_dict(), "axis_order": list(self.axes)}, sort_keys=True
        )
        return hashlib.sha256(text.encode()).hexdigest()

    def differences(self, other: "Sweep") -> list[str]:
        """Human-readable list of what differs between two configurations."""
        out = _diff(self.to_dict(), other.to_dict(), "")
        if list(self.axes) != list(other.axes) and set(self.axes) == set(other.axes):
            out.append(f"axes: order {', '.join(self.axes)} -> {', '.join(other.axes)}")
        return out

    def __eq__(self, other: object) -> bool:
        # dicts compare without order, but the order of the axes is that of the dimensions
        return (
            isinstance(other, Sweep)
            and self.to_dict() == other.to_dict()
            and list(self.axes) == list(other.axes)
        )

    # the stored tables are mutable dicts; compare with ==. The ignore: mypy refuses the
    # None with which the data model marks a class unhashable.
    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        args = ", ".join(
            f"{k}={self._config[k]!r}" for k in _ARGUMENTS if k in self._config
        )
        return f"Sweep({args})"


def _grid_axes(axes: Mapping[str, dict[str, Any]]) -> tuple[Axis, ...]:
    out = []
    for key, spec in axes.items():
        if key == "body":
            out.append(Axis(key, "body", np.array(spec["values"]), 1.0, "", "body preset"))
            continue
        param, factor, cf = resolve(key, spec.get("units"), f"axes.{key}")
        out.append(Axis(key, param.name, axis_values(spec), factor, cf, param.long_name))
    return tuple(out)


def _random_params(random: Mapping[str, dict[str, Any]]) -> tuple[RandomParam, ...]:
    out = []
    for key, spec in random.items():
        kind = "uniform" if "uniform" in spec else "normal"
        param, factor, cf = resolve(key, spec.get("units"), f"random.{key}")
        a, b = spec[kind]
        out.append(RandomParam(key, param.name, kind, a, b, factor, cf, param.long_name))
    return tuple(out)


def fixed_value(entry: Any) -> tuple[Any, str | None]:
    """(value, units) of a numeric entry of a ``[fixed]`` table: a number, or a
    ``{value, units}`` table (units None where not given)."""
    if isinstance(entry, Mapping):
        return entry["value"], entry.get("units")
    return entry, None


def _fixed_numbers(fixed: Mapping[str, Any]) -> Iterator[tuple[str, Any, str | None]]:
    """(key, value, units) of each fixed numeric parameter, in the table's order."""
    for key, entry in fixed.items():
        if key != "body":
            yield (key, *fixed_value(entry))


def _fixed_si(fixed: Mapping[str, Any]) -> dict[str, float]:
    out = {}
    for key, value, units in _fixed_numbers(fixed):
        param, factor, _ = resolve(key, units, f"fixed.{key}")
        out[param.name] = value * factor
    return out


def _warn_radians_as_degrees(
    fixed: Mapping[str, Any],
    grid_axes: tuple[Axis, ...],
    random_params: tuple[RandomParam, ...],
) -> None:
    """Warn (:class:`~rattlesweep.UnitsWarning`) of a roll or pitch given in radians that
    can only be degrees typed as radians (``roll = 30``), by the rule and with the
    message of :func:`rattlesweep.run_batch`; a sweep passes its angles on in radians,
    past the check that keyword makes."""
    from ...rattleback.launch import angles_in_radians

    given: dict[str, list[float]] = {}
    for key, value, units in _fixed_numbers(fixed):
        param, factor, _ = resolve(key, units, f"fixed.{key}")
        if factor == 1.0:
            given.setdefault(param.name, []).append(value)
    for axis in grid_axes:
        if axis.param != "body" and axis.factor == 1.0:
            given.setdefault(axis.param, []).extend(float(v) for v in axis.values)
    for random in random_params:
        if random.factor == 1.0:
            given.setdefault(random.param, []).extend(random.bounds())
    body = _fixed_body(fixed)
    full = isinstance(body, Body) and body.full_ellipsoid
    # only the tilts are checked; yaw and the others are passed through untouched
    tilts = {k: np.array(v) for k, v in given.items() if k in ("roll", "pitch")}
    if tilts:
        angles_in_radians(tilts, full_ellipsoid=full, stacklevel=4)


def _fixed_shown(fixed: Mapping[str, Any]) -> str:
    """The fixed numeric values as the configuration spells them, for error messages:
    ``fixed.roll_deg = 1e+300, fixed.t_end = 3`` (the user's, not the defaults)."""
    return ", ".join(
        f"fixed.{key} = {value!r}" + (f" {units}" if units else "")
        for key, value, units in _fixed_numbers(fixed)
    )


def _fixed_body(fixed: Mapping[str, Any]) -> str | Body | None:
    v = fixed.get("body")
    return body_from_table(v, "fixed.body") if isinstance(v, Mapping) else v


def _tiled_size(
    shape: tuple[int, ...], keys: list[str], refine: Mapping[str, Any] | None
) -> int:
    """The number of points the automatic tile size is chosen for: the grid's, or for a
    refined sweep that of its grid one level finer, about as many points as its levels
    simulate each (tiles sized for the declared grid alone would be so small that their
    overhead shows)."""
    if refine is None:
        return _size(shape)
    return _size(
        tuple(
            2 * n - 1 if k in refine["axes"] else n
            for k, n in zip(keys + ["repeat"], shape)
        )
    )


def _size(shape: tuple[int, ...]) -> int:
    return int(np.prod(shape))


def _diff(a: Any, b: Any, path: str) -> list[str]:
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
