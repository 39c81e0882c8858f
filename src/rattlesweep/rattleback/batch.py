"""Batches of rattleback launches: broadcasting, validation, packing, results.

:func:`run_batch` is the array entry point. Every per-trajectory input (the body, the
launch, the friction, the numerics) may be an array; all are broadcast together and the
batch is flattened onto one ``trajectory`` dimension whose coordinates are the inputs.
The steps go down the shared batch layer: :func:`launch_inputs` (checks and
broadcasting, :mod:`rattlesweep._launches`; no kernel), :func:`prepare` (the launch
state, packed into kernel blocks by :mod:`rattlesweep._pack`) and :func:`run_batch` (the
kernel run by :mod:`rattlesweep._run`, its results labelled by
:mod:`rattlesweep._results`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._launches import as_bodies, launches
from .._model import Model, Prepared
from .._options import (
    check_band,
    check_method,
    check_record_every,
    check_single_step,
    check_stop,
)
from .._pack import blocked, prepared
from .._run import contact_slip_velocity, execute
from .._steps import step_counts, time_steps
from .._validation import as_float_array, fail_where
from .._core.models import RATTLEBACK
from .._core.rattleback import layout
from ..inputs import RATTLEBACK as INPUTS
from .body import Bodies, Body
from .launch import (
    angles_in_radians,
    check_unit_quaternion,
    quaternion_from_angles,
    tilt_limit_error,
    up_vector,
)
from .metadata import attrs_for

__all__ = [
    "MODEL",
    "Inputs",
    "damping_dts",
    "launch_inputs",
    "max_steps",
    "prepare",
    "radian_angles",
    "run_attrs",
    "run_batch",
]

TITLE = "rattlesweep rattleback simulation"

MODEL = Model(
    RATTLEBACK,
    layout,
    observables=(
        "first_reversal_time",
        "n_reversals",
        "initial_spin",
        "final_spin",
        "mean_final_spin",
        "max_tilt",
        "energy_initial",
        "energy_final",
        "energy_lost",
        "slip_fraction",
        "t_final",
        "steps",
        "status",
    ),
    status_attrs=attrs_for("status"),
    derived={
        "energy_lost": (
            lambda v: v["energy_initial"] - v["energy_final"],
            "J",
            "energy_initial - energy_final",
        )
    },
)
"""The rattleback model as the batch layer sees it."""

SETTINGS = tuple(
    s.name for s in INPUTS.values() if s.group in ("friction", "numerics") and s.in_results
)
"""The inputs results hold as they are given: friction and numerics."""


@dataclass(frozen=True)
class Inputs:
    """Checked launch inputs, broadcast and flattened over n trajectories."""

    shape: tuple[int, ...]
    n: int
    bodies: list[Body]  # the distinct bodies
    index: np.ndarray  # (n,) index of each trajectory's body into ``bodies``
    flat: dict[str, np.ndarray]  # scalar inputs, (n,) each, dt included
    vectors: dict[str, np.ndarray]  # omega (n, 3), orientation (n, 4), velocity (n, 2)
    nsteps: np.ndarray  # (n,) int64
    quaternion: np.ndarray  # (n, 4) launch orientation, body to world

    def body_columns(self) -> dict[str, np.ndarray]:
        """Each trajectory's body parameters by name (``com`` is (n, 3))."""
        rows = {
            "a": [b.a for b in self.bodies],
            "b": [b.b for b in self.bodies],
            "c": [b.c for b in self.bodies],
            "mass": [b.mass for b in self.bodies],
            "com": [b.com for b in self.bodies],
            "full_ellipsoid": [float(b.full_ellipsoid) for b in self.bodies],
        }
        for name, (r, c) in (
            ("xx", (0, 0)),
            ("yy", (1, 1)),
            ("zz", (2, 2)),
            ("xy", (0, 1)),
            ("xz", (0, 2)),
            ("yz", (1, 2)),
        ):
            rows[f"inertia_{name}"] = [b.inertia[r, c] for b in self.bodies]
        columns = {k: np.array(v, dtype=float)[self.index] for k, v in rows.items()}
        columns["com"] = columns["com"].reshape(-1, 3)  # (0, 3) for an empty batch
        return columns


def launch_inputs(
    body: Bodies,
    *,
    spin: ArrayLike | None = None,
    omega: ArrayLike | None = None,
    roll: ArrayLike = 0.0,
    pitch: ArrayLike = 0.0,
    yaw: ArrayLike = 0.0,
    orientation: ArrayLike | None = None,
    velocity: ArrayLike | None = None,
    mu: ArrayLike = math.inf,
    mu_static: ArrayLike | None = None,
    mu_spin: ArrayLike = 0.0,
    mu_roll: ArrayLike = 0.0,
    damping: ArrayLike = 0.0,
    g: ArrayLike = 9.81,
    dt: ArrayLike | None = None,
    t_end: ArrayLike,
    announce: bool = True,
) -> Inputs:
    """Check and broadcast launch inputs (see :func:`run_batch` for their meaning and
    units), without the kernel. Raises ValueError naming the parameter, the value and
    the rule for any invalid input. Non-finite launch values (spin, omega, angles,
    orientation, velocity) are not errors: those trajectories get the status
    ``non_finite``. ``announce`` warns (:class:`~rattlesweep.LongRunWarning`) of
    a batch of more than :data:`~rattlesweep._steps.LONG_RUN_STEPS` steps."""
    if spin is not None and omega is not None:
        raise ValueError(
            "give either spin (about the vertical) or omega (body frame), not both"
        )
    angles = {"roll": roll, "pitch": pitch, "yaw": yaw}
    if orientation is not None and any(
        np.any(as_float_array(k, x) != 0) for k, x in angles.items()
    ):
        raise ValueError("give either orientation or roll/pitch/yaw, not both")
    if t_end is None:
        raise ValueError("t_end (s) is required")
    scalars = {
        "roll": roll,
        "pitch": pitch,
        "yaw": yaw,
        "mu": mu,
        "mu_static": mu if mu_static is None else mu_static,
        "mu_spin": mu_spin,
        "mu_roll": mu_roll,
        "damping": damping,
        "g": g,
        "t_end": t_end,
    }
    if omega is None:
        scalars["spin"] = 0.0 if spin is None else spin
    if dt is not None:
        scalars["dt"] = dt
    vectors: dict[str, np.ndarray] = {}
    for name, value in (
        ("omega", omega),
        ("orientation", orientation),
        ("velocity", velocity),
    ):
        width = INPUTS[name].width
        if value is not None:
            arr = as_float_array(name, value)
            if arr.ndim == 0 or arr.shape[-1] != width:
                raise ValueError(
                    f"{name} must have a last axis of length {width}, got shape {arr.shape}"
                )
            vectors[name] = arr
    launch = launches(body, Body, scalars, INPUTS, vectors)
    flat, flat_vec, table, index = launch.flat, launch.vectors, launch.bodies, launch.index
    # warnings at the user's call: run_batch or simulate -> prepare -> launch_inputs
    longest = damping_dts(table, index, flat["damping"])
    flat["dt"], default_from = time_steps(
        table,
        index,
        flat,
        longest=(longest, ("damping",)),
        dt_at_most_t_end=True,
        stacklevel=4,
    )
    if "orientation" in flat_vec:
        q = flat_vec["orientation"].copy()
        check_unit_quaternion(q)
    else:
        q = quaternion_from_angles(flat["roll"], flat["pitch"], flat["yaw"])
    full = np.array([b.full_ellipsoid for b in table], dtype=bool)[index]
    tilt_limit_error(up_vector(q)[:, 2], full)
    steps = step_counts(
        flat["t_end"],
        flat["dt"],
        default_from,
        (table, index),
        announce=announce,
        stacklevel=4,
    )
    return Inputs(launch.shape, launch.n, table, index, flat, flat_vec, steps, q)


def radian_angles(body: Bodies, given: dict[str, Any]) -> dict[str, Any]:
    """roll, pitch, yaw (rad) from the radian or degree keyword arguments of
    :func:`run_batch` or :func:`rattlesweep.simulate` (see
    :func:`rattlesweep.rattleback.launch.angles_in_radians`; warns at the caller's
    caller)."""
    bodies = as_bodies(body, Body)
    full = all(b.full_ellipsoid for b in bodies.flat)
    return angles_in_radians(given, full_ellipsoid=full, stacklevel=4)


def damping_dts(table: list[Body], index: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """The longest step that follows each trajectory's viscous damping (inf without
    damping): the torque -damping * omega makes omega about a principal axis of moment
    I_k relax at the rate damping / I_k, and RK4 follows that decay monotonically at
    steps up to I_k / damping (rate times step at most 1, well inside RK4's stability
    limit of 2.78), so a default step is at most the smallest moment over damping."""
    i_min = np.array([np.linalg.eigvalsh(b.inertia)[0] for b in table])[index]
    with np.errstate(divide="ignore"):
        return np.where(damping > 0, i_min / damping, np.inf)


def max_steps(body: Bodies, **kwargs: Any) -> int:
    """The largest number of steps a trajectory of these launches takes, 0 for an empty
    batch (checks every input as :func:`launch_inputs` does, without the kernel)."""
    return int(launch_inputs(body, announce=False, **kwargs).nsteps.max(initial=0))


def _launch_state(inputs: Inputs) -> dict[str, np.ndarray]:
    """The launch state by row name; G's velocity, zero here, is set in :func:`prepare`
    once the kernel has given the rolling one."""
    q, vec = inputs.quaternion, inputs.vectors
    w = vec["omega"] if "omega" in vec else inputs.flat["spin"][:, None] * up_vector(q)
    return {
        "quaternion": q,
        "omega": w,
        "position": np.zeros((inputs.n, 2)),
        "velocity": np.zeros((inputs.n, 2)),
    }


def _coords(
    inputs: Inputs,
    columns: dict[str, np.ndarray],
    velocity: np.ndarray | None,
    degrees: Mapping[str, ArrayLike],
) -> dict[str, Any]:
    """Every input, per trajectory: name -> (dims, values). Angles are in degrees, named
    ``roll_deg``, ``pitch_deg``, ``yaw_deg``: the values of ``degrees`` (the user's,
    unrounded) where given, else converted from radians."""
    dim, flat, vec = "trajectory", inputs.flat, inputs.vectors
    coords: dict[str, Any] = {}
    if "orientation" in vec:
        coords["orientation"] = ((dim, "quaternion_component"), vec["orientation"])
    else:
        for k in ("roll", "pitch", "yaw"):
            if k in degrees:
                given = np.broadcast_to(
                    as_float_array(f"{k}_deg", degrees[k]), inputs.shape
                )
                coords[f"{k}_deg"] = (dim, given.reshape(-1).copy())
            else:
                coords[f"{k}_deg"] = (dim, np.degrees(flat[k]))
    if "omega" in vec:
        coords["launch_omega"] = ((dim, "body_axis"), vec["omega"])
    else:
        coords["launch_spin"] = (dim, flat["spin"])
    if velocity is not None:
        coords["launch_velocity"] = ((dim, "horizontal"), velocity)
    for k in SETTINGS:
        coords[k] = (dim, flat[k])
    for spec in INPUTS.values():
        if spec.group == "body" and spec.name in columns:
            coords[spec.name] = ((dim, spec.dim) if spec.dim else dim, columns[spec.name])
    coords["body_name"] = (dim, np.array([b.name for b in inputs.bodies])[inputs.index])
    return coords


def prepare(
    body: Bodies,
    *,
    stop: str | None = None,
    degrees: Mapping[str, ArrayLike] | None = None,
    announce: bool = True,
    **kwargs: Any,
) -> Prepared:
    """Check, broadcast and pack launches for the kernel; arguments as for
    :func:`run_batch`, angles in radians; ``degrees`` maps ``roll``, ``pitch``, ``yaw``
    to the values the user gave in degrees, which the coordinates keep as given
    (``announce`` as for :func:`launch_inputs`)."""
    rule = check_stop(stop)
    inputs = launch_inputs(body, announce=announce, **kwargs)
    n = inputs.n
    columns = {**inputs.body_columns(), **inputs.flat, "stop_rule": np.full(n, rule)}
    prep = prepared(
        MODEL, columns, _launch_state(inputs), inputs.nsteps, n, inputs.shape, {}
    )
    # G's velocity: rolling (material contact point at rest) unless given
    rolling = -contact_slip_velocity(MODEL, prep.P, prep.Y)[:, :n]
    given = inputs.vectors.get("velocity")
    if given is not None:
        v = given.T
        sliding = np.isfinite(v).all(axis=0) & np.any(v != rolling, axis=0)
        fail_where(
            "velocity",
            given,
            sliding & np.isinf(inputs.flat["mu_static"]),
            "makes a sliding launch, which needs a finite mu_static",
        )
    else:
        v = rolling
    prep.Y[:, layout.STATE.slice("velocity"), :] = blocked(v, n)
    return dataclasses.replace(prep, coords=_coords(inputs, columns, given, degrees or {}))


def run_batch(
    body: Bodies,
    *,
    spin: ArrayLike | None = None,
    omega: ArrayLike | None = None,
    roll: ArrayLike | None = None,
    pitch: ArrayLike | None = None,
    yaw: ArrayLike | None = None,
    roll_deg: ArrayLike | None = None,
    pitch_deg: ArrayLike | None = None,
    yaw_deg: ArrayLike | None = None,
    orientation: ArrayLike | None = None,
    velocity: ArrayLike | None = None,
    mu: ArrayLike = math.inf,
    mu_static: ArrayLike | None = None,
    mu_spin: ArrayLike = 0.0,
    mu_roll: ArrayLike = 0.0,
    damping: ArrayLike = 0.0,
    g: ArrayLike = 9.81,
    dt: ArrayLike | None = None,
    t_end: ArrayLike,
    method: str = "rk4",
    record_every: int | None = None,
    reversal_band: float = 0.05,
    stop: str | None = None,
    parallel: bool = True,
    threads: int | None = None,
) -> xr.Dataset:
    """Integrate many launches at once; return per-trajectory observables.

    Every argument except ``method``, ``record_every``, ``reversal_band``, ``stop``,
    ``parallel`` and ``threads`` may be an array; all are broadcast together (vector
    inputs ``omega``, ``orientation`` and ``velocity`` broadcast on their leading axes)
    and flattened onto a ``trajectory`` dimension.

    Parameters
    ----------
    body : Body or array_like of Body
        The body of each launch.
    spin : array_like, optional
        Rotation about the world vertical (rad/s, positive counter-clockwise seen from
        above). Default 0.
    omega : array_like, shape (..., 3), optional
        Body-frame angular velocity (rad/s) instead of ``spin``.
    roll, pitch, yaw : array_like, optional
        Initial orientation (rad), R = R_z(yaw) R_y(pitch) R_x(roll). Default 0. A roll
        or pitch beyond 90 degrees (180 for a full ellipsoid) in radians draws a
        :class:`~rattlesweep.UnitsWarning`: degrees typed as radians.
    roll_deg, pitch_deg, yaw_deg : array_like, optional
        The same angles in degrees; give one form of each angle, not both.
    orientation : array_like, shape (..., 4), optional
        Unit quaternion (w, x, y, z), body to world, instead of the angles.
    velocity : array_like, shape (..., 2), optional
        Horizontal velocity of G (m/s): a sliding launch. Default: rolling.
    mu, mu_static : array_like, optional
        Kinetic and static Coulomb coefficients; ``inf`` (the default) rolls without
        slip, ``0`` is frictionless. ``mu_static`` defaults to ``mu`` and must be
        >= ``mu``.
    mu_spin : array_like, optional
        Spin (drilling) friction (m): a couple about the contact normal of at most
        mu_spin·N opposing the spin about it, which stops that spin while the couple
        needed stays within the bound. Default 0.
    mu_roll : array_like, optional
        Rolling resistance (m): a couple of at most mu_roll·N opposing the horizontal
        part of ω, which sticks (holds that part at zero) while the couple needed stays
        within the bound. In 3-D, below a rate of order mu_roll·g·dt/(I/m) the couple
        is proportional to the rate, and a roll slower than that whose sticking couple
        fits the bound sticks, the rest of the rate removed by a plastic couple
        impulse. Default 0.
    damping : array_like, optional
        Viscous torque coefficient (N m s): a torque −damping·ω. Default 0.
    g : array_like, optional
        Gravitational acceleration (m/s²). Default 9.81.
    dt : array_like, optional
        Time step (s). Default: 1/64 of the body's shortest small-oscillation period,
        or the body's smallest principal moment of inertia / ``damping`` when that is
        shorter (:func:`damping_dts`).
    t_end : array_like
        End time (s); each trajectory takes ceil(t_end/dt) steps, at most 2**53.
    method : {"rk4", "euler"}, optional
        Classic RK4 (default) or semi-implicit Euler (first order).
    record_every : int, optional
        Record every k-th step into time-series variables over (trajectory, time);
        needs one ``dt`` and ``t_end`` for the whole batch. Off by default.
    reversal_band : float, optional
        Hysteresis of the reversal detector, a fraction of the initial spin's magnitude,
        in [0, 1). Default 0.05.
    stop : {None, "first_reversal"}, optional
        None runs every launch to ``t_end``; ``"first_reversal"`` ends a launch at its
        first reversal, unless it capsizes or lifts off first: at the first step at
        which it has both a first reversal time (the spin beyond the band on the other
        side) and a reversal of its heading (see ``n_reversals``). Its
        ``first_reversal_time`` and whether it reversed are then those of the full run,
        bit for bit, and so is its ``status`` up to the stop: a launch that reverses and
        only later capsizes or lifts off ends ``ok`` where the full run says
        ``capsized`` or ``lifted_off``; ``n_reversals`` is at most 1, and
        ``final_spin``, ``energy_final``, ``energy_lost``, ``slip_fraction`` and
        ``max_tilt`` are taken at the stop, ``t_final``; ``mean_final_spin`` is the
        mean over the part of the last 10 % of ``t_end`` it ran (NaN for none).
    parallel : bool, optional
        Spread blocks of trajectories over numba threads (default); ``False`` runs on
        the calling thread only, releasing the GIL, for callers that bring their own
        parallelism.
    threads : int, optional
        Number of numba threads for a parallel run (default: all).

    Returns
    -------
    xarray.Dataset
        Over ``trajectory``: ``first_reversal_time`` (s, NaN when none; the spin's
        first crossing beyond the band), ``n_reversals`` (reversals of the heading, the
        long axis seen from above: each time it turns back by more than 0.1 rad from
        the furthest it had turned), ``initial_spin``, ``final_spin``, ``mean_final_spin``
        (rad/s), ``max_tilt`` (rad), ``energy_initial``, ``energy_final``, ``energy_lost``
        (J), ``slip_fraction``, ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok,
        capsized, lifted_off, non_finite), with every input as a coordinate.

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule, before any
        computation. Non-finite launch values are not errors: those trajectories get
        the status ``non_finite``.

    Warns
    -----
    CoarseStepWarning
        When a given ``dt`` is more than 4 times the default step.
    LongRunWarning
        Before a batch of more than 10**9 steps in all (a quarter of an hour of a
        core or more), with the step count and where it comes from.
    """
    m = check_method(method)
    rec_every = check_record_every(record_every)
    band = check_band(reversal_band)
    degrees = {
        k: v
        for k, v in (("roll", roll_deg), ("pitch", pitch_deg), ("yaw", yaw_deg))
        if v is not None
    }
    angles = radian_angles(
        body,
        dict(
            roll=roll,
            pitch=pitch,
            yaw=yaw,
            roll_deg=roll_deg,
            pitch_deg=pitch_deg,
            yaw_deg=yaw_deg,
        ),
    )
    prep = prepare(
        body,
        spin=spin,
        omega=omega,
        **angles,
        degrees=degrees,
        orientation=orientation,
        velocity=velocity,
        mu=mu,
        mu_static=mu_static,
        mu_spin=mu_spin,
        mu_roll=mu_roll,
        damping=damping,
        g=g,
        dt=dt,
        t_end=t_end,
        stop=stop,
    )
    if rec_every is not None:
        check_single_step(prep)
    raw = execute(
        prep,
        method=m,
        record_every=rec_every,
        band=band,
        parallel=parallel,
        threads=threads,
    )
    return results.batch_dataset(
        prep, raw, rec_every, attrs_for, run_attrs(method, rec_every, band, stop)
    )


def run_attrs(
    method: str, record_every: int | None, band: float, stop: str | None = None
) -> dict[str, Any]:
    """Global attributes of a rattleback result."""
    attrs = results.run_attrs(method, record_every, band, stop)
    attrs["title"] = TITLE
    return attrs
