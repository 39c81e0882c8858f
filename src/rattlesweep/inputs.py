"""Every input of the two models, described once: name, units, long name, default, rule,
whether a sweep can vary it, and one line of documentation.

What is generated from these descriptions: the CF attributes (``units``, ``long_name``)
that results carry for each input (:mod:`rattlesweep.rattleback.metadata`,
:mod:`rattlesweep.planar.metadata`), the parameters a sweep can vary
(:mod:`rattlesweep.sweep._config.params`), the rules the batch layer checks for every model
(:func:`rattlesweep._launches.check_common`), the inputs a batch keeps as coordinates, the
command line's friction options and the documentation's tables of inputs
(``docs/generate.py``). The kernel's parameter rows (:mod:`rattlesweep._core`) pack an
input by the name it has here, in the units it has here.

Values are in SI units (angles in radians); results show an angle in degrees under a
``_deg`` name (``roll`` is ``roll_deg``), and the launch spin as ``launch_spin``, since
``spin`` is the spin's time series.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping

import numpy as np

from ._rules import (
    AT_LEAST_MU,
    BAND,
    FINITE,
    HALF_TURN,
    NONNEG,
    NONNEG_INF,
    POSITIVE,
    UNIT_QUATERNION,
    Rule,
)
from ._validation import fail_where

__all__ = [
    "AT_LEAST_MU",
    "BAND",
    "FINITE",
    "HALF_TURN",
    "INPUTS",
    "NONNEG",
    "NONNEG_INF",
    "PLANAR",
    "POSITIVE",
    "RATTLEBACK",
    "UNIT_QUATERNION",
    "Input",
    "Rule",
    "check_rules",
    "result_attrs",
]


@dataclass(frozen=True)
class Input:
    """One input: an argument of :func:`rattlesweep.run_batch` or
    :func:`rattlesweep.run_planar_batch` (or a parameter of the body).

    ``default`` is the value an omitted input takes (SI), None where it has none of its
    own; ``default_doc`` says it in words where it is not one value (``mu_static``
    defaults to ``mu``); ``required`` inputs have no default. ``rule`` is the rule its
    values obey. A ``launch_state`` input (spin, angles, velocities) is a value the
    trajectory starts from: a batch gives a non-finite one the status ``non_finite``
    instead of refusing it (its finite values obey the rule); a sweep refuses it by its
    rule. ``result`` and ``result_units`` are its name and units in results where they
    are not ``name`` and ``units`` (an angle in degrees); ``in_results`` is False for an
    input that results hold as a global attribute or not at all. A vector input has
    ``width`` components along the dimension ``dim`` of results. An omitted input takes
    the value of the input ``same_as`` names where it has one. ``details`` is more
    documentation for the functions' docstrings; ``kind`` the type they show for an
    input that is not a number (``"bool"``, the choices of a string).
    """

    name: str
    units: str
    long_name: str
    doc: str
    group: str  # "body", "launch", "friction", "numerics", "run"
    default: Any = None
    rule: Rule | None = None
    sweep: bool = False
    launch_state: bool = False
    result: str | None = None
    result_units: str | None = None
    in_results: bool = True
    default_doc: str = ""
    required: bool = False
    width: int = 1  # the length of a vector input's last axis
    dim: str = ""  # the name of that axis in results
    same_as: str = ""
    details: str = ""
    kind: str = ""

    @property
    def result_name(self) -> str:
        """Its name in results."""
        return self.result or self.name

    @property
    def attrs(self) -> dict[str, str]:
        """The CF attributes its values carry in results."""
        return {"units": self.result_units or self.units, "long_name": self.long_name}

    @property
    def default_text(self) -> str:
        """The default in words, for documentation ("" where there is none)."""
        if self.required:
            return "required"
        if self.default_doc:
            return self.default_doc
        if self.default is None:
            return ""
        if isinstance(self.default, float):
            return f"`{self.default:g}`"
        if isinstance(self.default, str):
            return f'`"{self.default}"`'
        return f"`{self.default}`"


# --- inputs both models have ----------------------------------------------------------
MU = Input(
    "mu",
    "1",
    "kinetic friction coefficient",
    "Kinetic Coulomb coefficient: inf rolls without slip, 0 is frictionless.",
    "friction",
    math.inf,
    NONNEG_INF,
    sweep=True,
)
MU_STATIC = Input(
    "mu_static",
    "1",
    "static friction coefficient",
    "Static Coulomb coefficient, at least mu: the bound a sticking contact holds.",
    "friction",
    None,
    AT_LEAST_MU,
    sweep=True,
    default_doc="`mu`",
    same_as="mu",
)
MU_SPIN = Input(
    "mu_spin",
    "m",
    "spin friction coefficient: bound of the couple about the normal per unit normal force",
    "Spin (drilling) friction: a couple of at most mu_spin N about the contact "
    "normal, opposing the spin about it.",
    "friction",
    0.0,
    NONNEG,
    sweep=True,
)
MU_ROLL = Input(
    "mu_roll",
    "m",
    "rolling resistance coefficient: bound of the rolling couple per unit normal force",
    "Rolling resistance: a couple of at most mu_roll N opposing the rolling.",
    "friction",
    0.0,
    NONNEG,
    sweep=True,
    details="The couple sticks (holds the rolling at rest) while the couple needed stays "
    "within the bound. In 3-D, below a rate of order mu_roll g dt / (I/m) the couple is "
    "proportional to the rate, and a roll slower than that whose sticking couple fits "
    "the bound sticks, the rest of the rate removed by a plastic couple impulse; in the "
    "plane it holds the body still (the dry-friction oscillator).",
)
G = Input(
    "g",
    "m s-2",
    "gravitational acceleration",
    "Gravitational acceleration.",
    "numerics",
    9.81,
    POSITIVE,
    sweep=True,
)
DT = Input(
    "dt",
    "s",
    "time step",
    "Fixed time step of the integration.",
    "numerics",
    None,
    POSITIVE,
    sweep=True,
    details="A given dt longer than t_end is refused: a launch takes whole steps. The "
    "default step of a launch shorter than it is its t_end (one step).",
    default_doc="1/64 of the body's shortest small-oscillation period",
)
T_END = Input(
    "t_end",
    "s",
    "requested end time",
    "End time: each launch takes ceil(t_end / dt) steps, at most 2**53.",
    "numerics",
    None,
    POSITIVE,
    sweep=True,
    required=True,
)
METHOD = Input(
    "method",
    "1",
    "integration method",
    'Classic RK4 ("rk4") or first-order semi-implicit Euler ("euler").',
    "run",
    "rk4",
    in_results=False,
    kind='{"rk4", "euler"}',
)
RECORD_EVERY = Input(
    "record_every",
    "1",
    "steps between recorded samples",
    "Record every k-th step into time series (a positive integer).",
    "run",
    None,
    in_results=False,
    default_doc="off for a batch; for a single run, the smallest stride "
    "that keeps at most 10 000 samples",
    details="A batch records into time series over (trajectory, time) and needs one "
    "dt and t_end for the whole batch.",
    kind="int",
)
PARALLEL = Input(
    "parallel",
    "1",
    "spread blocks over numba threads",
    "Run blocks of launches on numba threads; False runs on the calling thread only.",
    "run",
    True,
    in_results=False,
    details="The calling thread releases the GIL, for callers that bring their own "
    "parallelism.",
    kind="bool",
)
THREADS = Input(
    "threads",
    "1",
    "numba threads of a parallel run",
    "Number of numba threads for a parallel run.",
    "run",
    None,
    in_results=False,
    default_doc="all",
    kind="int",
)

# --- the rattleback (3-D model) ---------------------------------------------------------
_TILT = (
    "The orientation is R = R_z(yaw) R_y(pitch) R_x(roll), body to world. A tilt beyond "
    "90 degrees (180 for a full ellipsoid) in radians draws a UnitsWarning: degrees "
    "typed as radians."
)
RATTLEBACK_INPUTS: tuple[Input, ...] = (
    Input(
        "a",
        "m",
        "semi-axis along body x",
        "Semi-axis along body x.",
        "body",
        rule=POSITIVE,
        sweep=True,
    ),
    Input(
        "b",
        "m",
        "semi-axis along body y",
        "Semi-axis along body y.",
        "body",
        rule=POSITIVE,
        sweep=True,
    ),
    Input(
        "c",
        "m",
        "semi-axis along body z",
        "Semi-axis along body z (the depth).",
        "body",
        rule=POSITIVE,
        sweep=True,
    ),
    Input("mass", "kg", "mass", "Mass.", "body", rule=POSITIVE, sweep=True),
    Input(
        "delta",
        "rad",
        "misalignment of the inertia axes about +z",
        "Misalignment of the principal axes of inertia from the geometric axes.",
        "body",
        0.0,
        FINITE,
        sweep=True,
        result="delta_deg",
        result_units="degree",
    ),
    Input(
        "full_ellipsoid",
        "1",
        "1 for a full ellipsoid (no rim), 0 for a semi-ellipsoid",
        "Whether the body is a full ellipsoid (no rim, never capsizes).",
        "body",
    ),
    *(
        Input(
            f"inertia_{ij}",
            "kg m2",
            f"inertia tensor element I_{ij} about G",
            f"Element I_{ij} of the inertia tensor about G, body frame.",
            "body",
        )
        for ij in ("xx", "yy", "zz", "xy", "xz", "yz")
    ),
    Input(
        "com",
        "m",
        "centre of mass from the centre of the flat face, body frame",
        "Centre of mass G from the centre of the flat face.",
        "body",
        width=3,
        dim="body_axis",
    ),
    Input(
        "spin",
        "rad s-1",
        "initial spin about the vertical",
        "Initial rotation about the world vertical, counter-clockwise seen from above.",
        "launch",
        0.0,
        FINITE,
        sweep=True,
        launch_state=True,
        result="launch_spin",
    ),
    Input(
        "omega",
        "rad s-1",
        "initial angular velocity, body components",
        "Initial angular velocity (body frame), instead of spin.",
        "launch",
        launch_state=True,
        result="launch_omega",
        width=3,
        dim="body_axis",
    ),
    Input(
        "roll",
        "rad",
        "initial roll about body x",
        "Initial roll about body x (or roll_deg, in degrees).",
        "launch",
        0.0,
        FINITE,
        sweep=True,
        launch_state=True,
        result="roll_deg",
        result_units="degree",
        details=_TILT,
    ),
    Input(
        "pitch",
        "rad",
        "initial pitch about body y",
        "Initial pitch about body y (or pitch_deg, in degrees).",
        "launch",
        0.0,
        FINITE,
        sweep=True,
        launch_state=True,
        result="pitch_deg",
        result_units="degree",
        details=_TILT,
    ),
    Input(
        "yaw",
        "rad",
        "initial yaw about the vertical",
        "Initial yaw about the vertical (or yaw_deg, in degrees).",
        "launch",
        0.0,
        FINITE,
        sweep=True,
        launch_state=True,
        result="yaw_deg",
        result_units="degree",
    ),
    Input(
        "orientation",
        "1",
        "initial orientation quaternion (w, x, y, z)",
        "Initial orientation, a unit quaternion body to world, instead of the angles.",
        "launch",
        rule=UNIT_QUATERNION,
        launch_state=True,
        width=4,
        dim="quaternion_component",
    ),
    Input(
        "velocity",
        "m s-1",
        "initial horizontal velocity of the centre of mass",
        "Initial horizontal velocity of G: a sliding launch.",
        "launch",
        launch_state=True,
        result="launch_velocity",
        width=2,
        dim="horizontal",
        default_doc="rolling (the contact point at rest)",
    ),
    MU,
    MU_STATIC,
    MU_SPIN,
    MU_ROLL,
    Input(
        "damping",
        "N m s",
        "viscous torque coefficient",
        "Viscous torque coefficient: a torque -damping omega.",
        "friction",
        0.0,
        NONNEG,
        sweep=True,
    ),
    G,
    replace(
        DT,
        default_doc=f"{DT.default_doc}; with `damping`, at most the body's smallest "
        "principal moment of inertia / `damping` where that is shorter",
    ),
    T_END,
    METHOD,
    RECORD_EVERY,
    Input(
        "reversal_band",
        "1",
        "hysteresis of the reversal detector",
        "Hysteresis of the reversal detector, a fraction of the initial spin's magnitude.",
        "run",
        0.05,
        BAND,
        in_results=False,
        kind="float",
    ),
    Input(
        "stop",
        "1",
        "when a launch ends",
        'None runs to t_end; "first_reversal" ends a launch at its first reversal.',
        "run",
        None,
        in_results=False,
        default_doc="`None` (run to t_end)",
        details="A launch stops at the first step at which it has both a first reversal "
        "time and a reversal of its heading, unless it capsizes or lifts off first. Its "
        "first_reversal_time and whether it reversed are those of the full run, bit for "
        "bit, and so is its status up to the stop (a launch that reverses and only later "
        "capsizes ends ok); n_reversals is at most 1; final_spin, energy_final, "
        "energy_lost, slip_fraction and max_tilt are taken at the stop, t_final; "
        "mean_final_spin is the mean over the part of the last 10 % of t_end it ran.",
        kind='{None, "first_reversal"}',
    ),
    Input(
        "lyapunov",
        "1",
        "compute each launch's largest Lyapunov exponent",
        "Add lyapunov (1/s): each launch's largest finite-time Lyapunov exponent over "
        "its run.",
        "run",
        False,
        in_results=False,
        details="Computed in the kernel from a shadow launch displaced by 1e-8 and "
        "renormalised every 0.05 s of the launch's time; it needs rolling contact (mu = "
        "inf, the default, or mu_static = inf; mu_spin = mu_roll = 0) and costs about "
        "twice the plain run. "
        "Near an unstable upright spin it is the largest growth rate of the linear "
        "stability analysis; near a stable one it tends to zero.",
        kind="bool",
    ),
    PARALLEL,
    THREADS,
)

# --- the rocking semi-ellipse (planar model) --------------------------------------------
PLANAR_INPUTS: tuple[Input, ...] = (
    Input(
        "a",
        "m",
        "semi-axis along the flat edge",
        "Semi-axis along the flat edge.",
        "body",
        rule=POSITIVE,
    ),
    Input(
        "b",
        "m",
        "semi-axis normal to the flat edge",
        "Semi-axis normal to the flat edge.",
        "body",
        rule=POSITIVE,
    ),
    Input("mass", "kg", "mass", "Mass.", "body", rule=POSITIVE),
    Input(
        "com_depth",
        "m",
        "depth of the centre of mass below the flat edge",
        "Depth of the centre of mass below the flat edge.",
        "body",
    ),
    Input(
        "inertia",
        "kg m2",
        "moment of inertia about the centre of mass",
        "Moment of inertia about the centre of mass.",
        "body",
    ),
    Input(
        "theta",
        "rad",
        "initial rocking angle",
        "Initial rocking angle, counter-clockwise.",
        "launch",
        rule=HALF_TURN,
        launch_state=True,
        result="launch_angle",
        required=True,
    ),
    Input(
        "rate",
        "rad s-1",
        "initial rocking rate",
        "Initial rocking rate d(theta)/dt.",
        "launch",
        0.0,
        launch_state=True,
        result="launch_rate",
    ),
    Input(
        "velocity",
        "m s-1",
        "initial horizontal velocity of the centre of mass",
        "Initial horizontal velocity of the centre of mass; any but the rolling one "
        "launches the body sliding.",
        "launch",
        launch_state=True,
        result="launch_velocity",
        default_doc="rolling (the contact point at rest)",
    ),
    MU,
    MU_STATIC,
    MU_ROLL,
    G,
    DT,
    T_END,
    METHOD,
    RECORD_EVERY,
    PARALLEL,
    THREADS,
)

RATTLEBACK: dict[str, Input] = {i.name: i for i in RATTLEBACK_INPUTS}
"""The inputs of the rattleback (3-D model) by name."""
PLANAR: dict[str, Input] = {i.name: i for i in PLANAR_INPUTS}
"""The inputs of the planar model by name."""

INPUTS: dict[str, Input] = {**PLANAR, **RATTLEBACK}
"""Every input by name (the 3-D model's description where both models have one)."""


def result_attrs(inputs: Mapping[str, Input]) -> dict[str, dict[str, str]]:
    """CF attributes by result name of the inputs that results hold."""
    return {i.result_name: i.attrs for i in inputs.values() if i.in_results}


def check_rules(arrays: Mapping[str, Any], inputs: Mapping[str, Input]) -> None:
    """Refuse, naming the input, the value and the rule, any value of ``arrays`` (name ->
    array) that breaks the rule of its description in ``inputs``. A non-finite value of
    a launch-state input is left to the kernel, which gives it the status
    ``non_finite``."""
    for spec in inputs.values():
        if spec.name in arrays and spec.rule is not None:
            values = np.asarray(arrays[spec.name], dtype=float)
            bad = spec.rule.bad(values)
            if spec.launch_state:
                bad &= np.isfinite(values)
            fail_where(spec.name, values, bad, spec.rule.message)
