"""The page's settings, as the library's calls: the body, the keyword arguments of
:func:`rattlesweep.simulate`, the runnable Python of a run, and the :class:`Sweep` of a map.

Settings arrive as a flat mapping of control name to the text typed (or a number): the
body (``preset``: a preset name or ``"custom"``; ``a``, ``b``, ``c`` (m), ``mass`` (kg),
``delta_deg``; ``masses``: a list of ``[mass_kg, x_m, y_m, z_m]``), the launch (``spin``
rad/s, ``roll_deg``, ``pitch_deg``), friction (``mu``, ``mu_static`` (empty: same as
``mu``), ``mu_spin`` (m), ``mu_roll`` (m), ``damping`` (N m s)) and ``t_end`` (s).
Every value is checked by the library itself; its ``ValueError`` is what the page shows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from .._keywords import angles, per_launch
from ..inputs import RATTLEBACK as INPUTS
from ..inputs import Input
from ..rattleback.batch import launch_inputs
from ..rattleback.body import PRESETS, Body
from .caps import Caps

__all__ = [
    "CONTROLS",
    "LABELS",
    "MAP_AXES",
    "MAX_SPIN",
    "RunSpec",
    "SettingError",
    "UNITS",
    "defaults",
    "map_axes",
    "map_sweep",
    "preset_bodies",
    "run_spec",
]

ANGLES = angles(INPUTS)

CONTROLS = (
    "preset",
    "a",
    "b",
    "c",
    "mass",
    "delta_deg",
    "masses",
    "spin",
    "roll_deg",
    "pitch_deg",
    "mu",
    "mu_static",
    "mu_spin",
    "mu_roll",
    "damping",
    "t_end",
)
"""The page's controls, in the order their messages are matched."""

_PAGE_UNITS = {"rad s-1": "rad/s", "degree": "deg"}
"""The page's way of writing units that differ from the description's CF units."""


def _input(control: str) -> Input | None:
    """The described input a control sets (``roll_deg``: ``roll``), or None."""
    degrees = control.endswith("_deg") and control[:-4] in INPUTS
    return INPUTS.get(control[:-4] if degrees else control)


def _units(control: str) -> str:
    spec = _input(control)
    assert spec is not None, control
    units = "degree" if control != spec.name else spec.units
    return _PAGE_UNITS.get(units, units)


UNITS = {c: _units(c) for c in CONTROLS if c not in ("preset", "masses")}
"""Units of each numeric control, as the page writes them (from the descriptions)."""

LAUNCH = tuple(
    c for c in CONTROLS if (i := _input(c)) is not None and i.name in per_launch(INPUTS)
)
"""The controls of per-launch inputs (the launch, the friction, the run length)."""

LABELS = {
    "a": "a (semi-axis x)",
    "b": "b (semi-axis y)",
    "c": "c (semi-axis z)",
    "mass": "mass",
    "delta_deg": "misalignment δ",
    "spin": "spin",
    "roll_deg": "roll",
    "pitch_deg": "pitch",
    "mu": "μ kinetic",
    "mu_static": "μ static",
    "mu_spin": "μ spin",
    "mu_roll": "μ roll",
    "damping": "damping",
    "t_end": "run length",
}
"""The page's label of each numeric control (the map's axes use the same)."""

MAP_AXES = (
    "spin",
    "delta_deg",
    "mu",
    "roll_deg",
    "pitch_deg",
    "mu_spin",
    "mu_roll",
    "damping",
    "a",
    "b",
    "c",
    "mass",
)
"""Inputs a map may vary (sweep parameter names); each is also a control."""

MAX_SPIN = 1e8
"""Largest launch spin (rad/s, in size) the page accepts: far beyond any rattleback (such a
launch lifts off at once), yet below where its energy overflows what the page can draw."""

# a map axis's default range, for inputs without a natural one relative to the body
_RANGES = {
    "spin": (-30.0, 30.0),
    "delta_deg": (-8.0, 8.0),
    "mu": (0.05, 1.0),
    "roll_deg": (0.5, 10.0),
    "pitch_deg": (0.5, 10.0),
    "mu_spin": (0.0, 0.002),
    "mu_roll": (0.0, 0.002),
    "damping": (0.0, 2e-7),
}

_PRESET_NAMES = {
    "kane_levinson": "Kane & Levinson (1982)",
    "golden": "golden (Kuypers)",
    "toy": "toy (plastic, 95 mm)",
}


def map_axes() -> dict[str, dict[str, Any]]:
    """Each map axis: its label and units (the control's), the library's description
    (:data:`rattlesweep.sweep._config.params.PARAMS`) and a default range (``start``,
    ``stop``; ``relative``: a factor range about the control's current value, for body
    sizes)."""
    from ..sweep._config.params import PARAMS

    out: dict[str, dict[str, Any]] = {}
    for k in MAP_AXES:
        param = PARAMS[k[:-4] if k.endswith("_deg") else k]
        entry: dict[str, Any] = {
            "label": LABELS[k],
            "units": UNITS[k],
            "description": param.long_name,
        }
        if k in _RANGES:
            entry["start"], entry["stop"] = _RANGES[k]
        else:  # a, b, c, mass: half to one and a half times the current body's
            entry["relative"] = [0.5, 1.5]
        out[k] = entry
    return out


def preset_bodies() -> dict[str, dict[str, Any]]:
    """Each preset: a readable name and its size and mass (m, kg) for the page's boxes."""
    out = {}
    for name in sorted(PRESETS):
        b = Body.preset(name)
        out[name] = {
            "label": _PRESET_NAMES.get(name, name.replace("_", " ")),
            "a": b.a,
            "b": b.b,
            "c": b.c,
            "mass": b.mass,
        }
    return out


_BODY_KEYS = ("a", "b", "c", "mass", "delta_deg")


class SettingError(ValueError):
    """A refused setting: the library's message and the control it belongs to (None when
    it concerns several)."""

    def __init__(self, message: str, control: str | None) -> None:
        super().__init__(message)
        self.control = control


_START = {"delta_deg": 5.0, "spin": -5.0, "roll_deg": 0.5, "mu": 0.3, "t_end": 5.0}
"""The page's starting values where they are not the library's defaults: the toy
rattleback spun against its preferred sense, with friction, for five seconds."""


def defaults() -> dict[str, Any]:
    """The page's starting settings: the toy rattleback spun against its preferred sense;
    each launch input not in :data:`_START` at its library default (empty for none)."""
    toy = Body.preset("toy")
    launch = {}
    for c in LAUNCH:
        spec = _input(c)
        assert spec is not None
        launch[c] = _START.get(c, "" if spec.default is None else spec.default)
    return {
        "preset": "custom",
        "a": toy.a,
        "b": toy.b,
        "c": toy.c,
        "mass": toy.mass,
        "delta_deg": _START["delta_deg"],
        "masses": [],
        **launch,
    }


def control_of(message: str) -> str | None:
    """The control a library message is about: the parameter it starts with."""
    head = message.split(" ", 1)[0].rstrip(":,")
    aliases = {
        "roll": "roll_deg",
        "pitch": "pitch_deg",
        "roll/pitch/orientation": "roll_deg",
        "delta": "delta_deg",
        "com": "masses",
    }
    if head.startswith("masses["):
        return "masses"
    if head in CONTROLS:
        return head
    return aliases.get(head)


def _number(
    name: str, value: Any, control: str | None = None, finite: bool = False
) -> float:
    """A control's value as a float; text that is no number is refused as the library
    refuses it, and so is a non-finite value where ``finite`` (the library gives such a
    launch a status, not an error, so the page refuses it here)."""
    control = control or name
    if isinstance(value, bool):
        raise SettingError(f"{name} must be a number, got {value!r}", control)
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise SettingError(f"{name} must be a number, got {value!r}", control) from None
    if finite and not math.isfinite(v):
        unit = UNITS.get(name, "")
        shown = f" ({unit})" if unit and unit != "1" else ""
        raise SettingError(f"{name} must be a finite number{shown}, got {v!r}", control)
    return v


@dataclass(frozen=True)
class RunSpec:
    """A checked run: the body, how it was described, and :func:`simulate`'s keywords."""

    body: Body
    body_args: dict[str, Any]  # preset name, or semi-ellipsoid arguments and masses
    kwargs: dict[str, Any]  # simulate() keywords, SI
    steps: int


def _body(s: Mapping[str, Any], caps: Caps) -> tuple[Body, dict[str, Any]]:
    preset = str(s.get("preset", "custom"))
    masses = s.get("masses") or []
    if not isinstance(masses, list):
        raise SettingError(
            f"masses must be a list of [mass, x, y, z], got {masses!r}", "masses"
        )
    caps.check("number of point masses", len(masses), "max_point_masses", control="masses")
    try:
        if preset != "custom":
            body = Body.preset(preset)
            args: dict[str, Any] = {"preset": preset}
        else:
            values = {k: _number(k, s.get(k), finite=True) for k in _BODY_KEYS}
            args = {k: values[k] for k in _BODY_KEYS}
            body = Body.semi_ellipsoid(
                values["a"],
                values["b"],
                values["c"],
                values["mass"],
                math.radians(values["delta_deg"]),
            )
        items = []
        for i, row in enumerate(masses):
            if not isinstance(row, (list, tuple)) or len(row) != 4:
                raise SettingError(
                    f"masses[{i}] must be [mass (kg), x, y, z (m)], got {row!r}", "masses"
                )
            m = _number(f"masses[{i}] mass", row[0], "masses", finite=True)
            pos = [
                _number(f"masses[{i}] position", v, "masses", finite=True) for v in row[1:]
            ]
            items.append((m, pos))
        if items:
            body = body.with_point_masses(items)
        args["masses"] = [[m, *p] for m, p in items]
    except SettingError:
        raise
    except ValueError as exc:
        raise SettingError(str(exc), control_of(str(exc)) or "preset") from None
    return body, args


def _launch(s: Mapping[str, Any]) -> dict[str, Any]:
    """The keyword arguments of :func:`rattlesweep.simulate` (SI, angles in radians) from
    the launch controls. A control left empty gives None where the input has no value of
    its own (``mu_static``: that of ``mu``); a non-finite value is refused where the
    input's rule refuses infinity."""
    kw: dict[str, Any] = {}
    for c in LAUNCH:
        spec = _input(c)
        assert spec is not None
        value = s.get(c, spec.default)
        if value in (None, "") and spec.default is None and not spec.required:
            kw[spec.name] = None
            continue
        finite = spec.rule is None or bool(spec.rule.bad(math.inf))
        v = _number(c, value, finite=finite)
        kw[spec.name] = math.radians(v) if c != spec.name else v
    if abs(kw["spin"]) > MAX_SPIN:
        raise SettingError(
            f"spin must be at most {MAX_SPIN:g} rad/s in size, got {kw['spin']!r}", "spin"
        )
    return kw


def run_spec(settings: Mapping[str, Any], caps: Caps) -> RunSpec:
    """Check the settings of a run, by the library's own rules and the caps, without
    running it. Raises :class:`SettingError` (the library's message, or the cap's)."""
    body, args = _body(settings, caps)
    kw = _launch(settings)
    try:
        inputs = launch_inputs(body, **kw)
    except ValueError as exc:
        raise SettingError(str(exc), control_of(str(exc))) from None
    caps.check("t_end", kw["t_end"], "max_t_end", "s", control="t_end")
    steps = int(inputs.nsteps.max())
    caps.check("time steps of this run", steps, "max_steps", control="t_end")
    return RunSpec(body, args, kw, steps)


def _fmt(x: float) -> str:
    if math.isinf(x):
        return "math.inf" if x > 0 else "-math.inf"
    return repr(float(x))


def _degrees(rad: float) -> float:
    """Degrees of an angle the page gave in degrees: the typed number back (0.5, not
    0.49999999999999994)."""
    deg = math.degrees(rad)
    short = float(f"{deg:.12g}")
    return short if math.radians(short) == rad else deg


def python_code(spec: RunSpec) -> str:
    """A runnable script that makes the same run with :func:`rattlesweep.simulate`."""
    args = spec.body_args
    lines = ["import math", "", "import rattlesweep as rs", ""]
    if "preset" in args:
        lines.append(f"body = rs.Body.preset({args['preset']!r})")
    else:
        lines.append(
            f"body = rs.Body.semi_ellipsoid(a={_fmt(args['a'])}, b={_fmt(args['b'])}, "
            f"c={_fmt(args['c'])}, mass={_fmt(args['mass'])}, "
            f"delta=math.radians({_fmt(args['delta_deg'])}))"
        )
    if args.get("masses"):
        items = ", ".join(
            f"({_fmt(m)}, ({_fmt(x)}, {_fmt(y)}, {_fmt(z)}))"
            for m, x, y, z in args["masses"]
        )
        lines.append(f"body = body.with_point_masses([{items}])  # (kg, (x, y, z) m)")
    parts = []
    for name, value in spec.kwargs.items():  # those not at the library's default
        if value is None or value == INPUTS[name].default:
            continue
        if name in ANGLES:
            parts.append(f"{name}_deg={_fmt(_degrees(value))}")
        else:
            parts.append(f"{name}={_fmt(value)}")
    lines.append("run = rs.simulate(body, " + ", ".join(parts) + ")")
    lines.append("print(run.first_reversal_time.item(), run.n_reversals.item())")
    return "\n".join(lines) + "\n"


def _whole(name: str, value: Any, control: str) -> int:
    """A count the page sent: a whole number, not one truncated from 2.5."""
    number = _number(name, value, control, finite=True)
    if not float(number).is_integer():
        raise SettingError(f"{name} must be a whole number, got {number:g}", control)
    return int(number)


def map_sweep(settings: Mapping[str, Any], axes: Mapping[str, Any], caps: Caps) -> Any:
    """The :class:`rattlesweep.Sweep` of a map: two axes (``x`` and ``y``: ``param``,
    ``start``, ``stop``, ``num``) over the current other settings, refined ``levels``
    times, each launch stopped at its first reversal. Raises :class:`SettingError`."""
    from ..sweep import Sweep

    spec = run_spec(settings, caps)  # the settings themselves must make a valid run
    caps.check("map t_end", spec.kwargs["t_end"], "max_map_t_end", "s", control="t_end")
    levels = _whole("map levels", axes.get("levels", 0), "map_levels")
    caps.check("map levels", levels, "max_map_levels", control="map_levels")
    grid: dict[str, Any] = {}
    for key in ("x", "y"):
        ax = axes.get(key) or {}
        param = str(ax.get("param"))
        if param not in MAP_AXES:
            raise SettingError(
                f"map {key} axis must be one of {sorted(MAP_AXES)}, got {param!r}",
                f"map_{key}",
            )
        num = _whole(f"map {key} num", ax.get("num"), f"map_{key}")
        caps.check(f"map {key} num", num, "max_map_num", control=f"map_{key}")
        grid[param] = {
            "start": _number(f"map {key} start", ax.get("start"), f"map_{key}"),
            "stop": _number(f"map {key} stop", ax.get("stop"), f"map_{key}"),
            "num": num,
        }
    if len(grid) != 2:
        raise SettingError("the map's two axes must be different inputs", "map_y")
    fixed: dict[str, Any] = {}
    args = spec.body_args
    body_on_axis = any(k in grid for k in _BODY_KEYS)
    if "preset" in args and not args.get("masses"):
        if body_on_axis:
            raise SettingError(
                f"a map over {'/'.join(k for k in grid if k in _BODY_KEYS)} "
                "needs the custom (semi-ellipsoid) body, not a preset",
                "preset",
            )
        fixed["body"] = args["preset"]
    elif args.get("masses"):
        if body_on_axis:
            raise SettingError(
                "a map over a body parameter needs a body without point masses", "masses"
            )
        fixed["body"] = spec.body
    else:
        fixed.update({k: args[k] for k in _BODY_KEYS if k not in grid})
    for name, value in spec.kwargs.items():
        key = f"{name}_deg" if name in ANGLES else name
        follows = INPUTS[name].same_as  # left out to follow its input along an axis
        if key in grid or value is None or (follows and follows in grid):
            continue
        fixed[key] = math.degrees(value) if name in ANGLES else value
    try:
        sweep = Sweep(
            axes=grid,
            fixed=fixed,
            name="rattlesweep explore map",
            stop="first_reversal",
            refine={"levels": levels} if levels else None,
        )
    except ValueError as exc:
        raise SettingError(str(exc), None) from None
    # every point, not only the settings' own run: a step size follows the inputs
    # (damping, the body), and the most steps of any point are reached at a corner
    caps.check("time steps of a map point", sweep.max_steps, "max_steps")
    return sweep


def presets() -> list[str]:
    return sorted(PRESETS)
