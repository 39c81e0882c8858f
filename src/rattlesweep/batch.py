"""Batches of rattleback launches: broadcasting, validation, packing, results.

:func:`run_batch` is the array entry point. Every per-trajectory input (the body, the
launch, the friction, the numerics) may be an array; all are broadcast together and the
batch is flattened onto one ``trajectory`` dimension whose coordinates are the inputs.
The steps are :func:`launch_inputs` (checks and broadcasting, no kernel),
:func:`prepare` (the launch state and kernel blocks) and the shared batch layer
(:mod:`rattlesweep.engine`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import engine, results
from .body import Body, distinct_bodies
from .core.models import RATTLEBACK
from .core.rattleback import layout
from .engine import (
    Model, Prepared, as_bodies, check_band, check_method, check_record_every,
    check_single_step,
)
from .launch import check_unit_quaternion, quaternion_from_angles, tilt_limit_error, up_vector
from .metadata import attrs_for
from .validation import as_float_array, fail_where

__all__ = ["MODEL", "Inputs", "launch_inputs", "max_steps", "prepare",
           "run_batch"]

MODEL = Model(
    RATTLEBACK, layout,
    observables=("first_reversal_time", "n_reversals", "initial_spin", "final_spin",
                 "mean_final_spin", "max_tilt", "energy_initial", "energy_final",
                 "energy_lost", "slip_fraction", "t_final", "steps", "status"),
    status_attrs=attrs_for("status"),
    derived={"energy_lost": (lambda v: v["energy_initial"] - v["energy_final"], "J",
                             "energy_initial - energy_final")},
)
"""The rattleback model as the batch layer sees it."""

BODY_COLUMNS = ("a", "b", "c", "mass", "full_ellipsoid", "inertia_xx", "inertia_yy",
                "inertia_zz", "inertia_xy", "inertia_xz", "inertia_yz")

@dataclass(frozen=True)
class Inputs:
    """Checked launch inputs, broadcast and flattened over n trajectories."""

    shape: tuple[int, ...]
    n: int
    bodies: list  # the distinct bodies
    index: np.ndarray  # (n,) index of each trajectory's body into ``bodies``
    flat: dict[str, np.ndarray]  # scalar inputs, (n,) each, dt included
    vectors: dict[str, np.ndarray]  # omega (n, 3), orientation (n, 4), velocity (n, 2)
    nsteps: np.ndarray  # (n,) int64
    quaternion: np.ndarray  # (n, 4) launch orientation, body to world

    def body_columns(self) -> dict[str, np.ndarray]:
        """Each trajectory's body parameters by name (``com`` is (n, 3))."""
        rows = {
            "a": [b.a for b in self.bodies], "b": [b.b for b in self.bodies],
            "c": [b.c for b in self.bodies], "mass": [b.mass for b in self.bodies],
            "com": [b.com for b in self.bodies],
            "full_ellipsoid": [float(b.full_ellipsoid) for b in self.bodies],
        }
        for name, (r, c) in (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("xy", (0, 1)),
                             ("xz", (0, 2)), ("yz", (1, 2))):
            rows[f"inertia_{name}"] = [b.inertia[r, c] for b in self.bodies]
        columns = {k: np.array(v, dtype=float)[self.index] for k, v in rows.items()}
        columns["com"] = columns["com"].reshape(-1, 3)  # (0, 3) for an empty batch
        return columns


def launch_inputs(
    body, *, spin=None, omega=None, roll=0.0, pitch=0.0, yaw=0.0, orientation=None,
    velocity=None, mu=math.inf, mu_static=None, damping=0.0, g=9.81, dt=None, t_end,
) -> Inputs:
    """Check and broadcast launch inputs (see :func:`run_batch` for their meaning and
    units), without the kernel. Raises ValueError naming the parameter, the value and
    the rule for any invalid input. Non-finite launch values (spin, omega, angles,
    orientation, velocity) are not errors: those trajectories get the status
    ``non_finite``."""
    if spin is not None and omega is not None:
        raise ValueError("give either spin (about the vertical) or omega (body frame), not both")
    if orientation is not None and any(np.any(np.asarray(x) != 0) for x in (roll, pitch, yaw)):
        raise ValueError("give either orientation or roll/pitch/yaw, not both")
    if t_end is None:
        raise ValueError("t_end (s) is required")
    scalars = {"roll": roll, "pitch": pitch, "yaw": yaw, "mu": mu,
               "mu_static": mu if mu_static is None else mu_static,
               "damping": damping, "g": g, "t_end": t_end}
    if omega is None:
        scalars["spin"] = 0.0 if spin is None else spin
    if dt is not None:
        scalars["dt"] = dt
    vectors = {}
    for name, value, width in (("omega", omega, 3), ("orientation", orientation, 4),
                               ("velocity", velocity, 2)):
        if value is not None:
            arr = as_float_array(name, value)
            if arr.ndim == 0 or arr.shape[-1] != width:
                raise ValueError(f"{name} must have a last axis of length {width}, "
                                 f"got shape {arr.shape}")
            vectors[name] = arr
    arrays = {k: as_float_array(k, v) for k, v in scalars.items()}
    engine.check_common(arrays)
    d = arrays["damping"]
    fail_where("damping", d, ~(np.isfinite(d) & (d >= 0)), "must be finite and >= 0 (N m s)")
    shape, n, flat_bodies, flat, flat_vec = engine.broadcast_inputs(as_bodies(body, Body), arrays,
                                                                    vectors)
    table, index = distinct_bodies(flat_bodies)
    if "dt" not in flat:
        flat["dt"] = engine.default_dts(table, index, flat["g"])
    else:
        # warn at the user's call: run_batch or simulate -> prepare -> launch_inputs
        engine.warn_coarse_dt(table, index, flat["g"], flat["dt"], stacklevel=4)
    if "orientation" in flat_vec:
        q = flat_vec["orientation"].copy()
        check_unit_quaternion(q)
    else:
        q = quaternion_from_angles(flat["roll"], flat["pitch"], flat["yaw"])
    full = np.array([b.full_ellipsoid for b in table], dtype=bool)[index]
    tilt_limit_error(up_vector(q)[:, 2], full)
    return Inputs(shape, n, table, index, flat, flat_vec,
                  engine.steps_for(flat["t_end"], flat["dt"]), q)


def max_steps(body, **kwargs) -> int:
    """The largest number of steps a trajectory of these launches takes (checks every
    input as :func:`launch_inputs` does, without the kernel)."""
    return int(launch_inputs(body, **kwargs).nsteps.max())


def _launch_state(inputs: Inputs) -> dict[str, np.ndarray]:
    """The launch state by row name; G's velocity, zero here, is set in :func:`prepare`
    once the kernel has given the rolling one."""
    q, vec = inputs.quaternion, inputs.vectors
    w = vec["omega"] if "omega" in vec else inputs.flat["spin"][:, None] * up_vector(q)
    return {"quaternion": q, "omega": w, "position": np.zeros((inputs.n, 2)),
            "velocity": np.zeros((inputs.n, 2))}


def _coords(inputs: Inputs, columns: dict[str, np.ndarray], velocity) -> dict[str, Any]:
    """Every input, per trajectory: name -> (dims, values)."""
    dim, flat, vec = "trajectory", inputs.flat, inputs.vectors
    coords: dict[str, Any] = {}
    if "orientation" in vec:
        coords["orientation"] = ((dim, "quaternion_component"), vec["orientation"])
    else:
        for k in ("roll", "pitch", "yaw"):
            coords[k] = (dim, flat[k])
    if "omega" in vec:
        coords["launch_omega"] = ((dim, "body_axis"), vec["omega"])
    else:
        coords["launch_spin"] = (dim, flat["spin"])
    if velocity is not None:
        coords["launch_velocity"] = ((dim, "horizontal"), velocity)
    for k in ("mu", "mu_static", "damping", "g", "dt", "t_end"):
        coords[k] = (dim, flat[k])
    for k in BODY_COLUMNS:
        coords[k] = (dim, columns[k])
    coords["com"] = ((dim, "body_axis"), columns["com"])
    coords["body_name"] = (dim, np.array([b.name for b in inputs.bodies])[inputs.index])
    return coords


def prepare(body, **kwargs) -> Prepared:
    """Check, broadcast and pack launches for the kernel; arguments as for
    :func:`run_batch`."""
    inputs = launch_inputs(body, **kwargs)
    n = inputs.n
    columns = {**inputs.body_columns(), **inputs.flat}
    Y = engine.pack(layout.STATE, _launch_state(inputs), n)
    prep = engine.prepared(MODEL, columns, Y, inputs.nsteps, n, inputs.shape, {})
    # G's velocity: rolling (material contact point at rest) unless given
    rolling = -engine.contact_slip_velocity(MODEL, prep.P, Y)[:, :n]
    given = inputs.vectors.get("velocity")
    if given is not None:
        v = given.T
        sliding = np.isfinite(v).all(axis=0) & np.any(v != rolling, axis=0)
        fail_where("velocity", given, sliding & np.isinf(inputs.flat["mu_static"]),
                   "makes a sliding launch, which needs a finite mu_static")
    else:
        v = rolling
    Y[:, layout.STATE.slice("velocity"), :] = engine.blocked(v, n)
    return dataclasses.replace(prep, coords=_coords(inputs, columns, given))


def run_batch(
    body: Body | Any,
    *,
    spin=None, omega=None, roll=0.0, pitch=0.0, yaw=0.0, orientation=None, velocity=None,
    mu=math.inf, mu_static=None, damping=0.0, g=9.81, dt=None, t_end,
    method: str = "rk4", record_every: int | None = None, reversal_band: float = 0.05,
    parallel: bool = True, threads: int | None = None,
) -> xr.Dataset:
    """Integrate many launches at once; return per-trajectory observables.

    Every argument except ``method``, ``record_every``, ``reversal_band``, ``parallel`` and
    ``threads`` may be an array; all are broadcast together (vector inputs ``omega``,
    ``orientation`` and ``velocity`` broadcast on their leading axes) and flattened onto a
    ``trajectory`` dimension.

    Parameters
    ----------
    body : Body or array of Body
    spin : rad/s, rotation about the world vertical (positive counter-clockwise from above).
    omega : (..., 3) rad/s, body-frame angular velocity instead of ``spin``.
    roll, pitch, yaw : rad, initial orientation R = R_z(yaw) R_y(pitch) R_x(roll).
    orientation : (..., 4) unit quaternion (w, x, y, z) instead of the angles.
    velocity : (..., 2) m/s, horizontal velocity of G (a sliding launch); default rolling.
    mu, mu_static : kinetic and static Coulomb coefficients; ``inf`` rolls without slip,
        ``0`` is frictionless. ``mu_static`` defaults to ``mu`` and must be >= ``mu``.
    damping : N m s, viscous torque −damping·ω.
    g : m/s², gravitational acceleration.
    dt : s, time step; default 1/64 of the body's shortest small-oscillation period.
    t_end : s, end time; each trajectory takes ceil(t_end/dt) steps.
    method : "rk4" (default) or "euler" (semi-implicit, first order).
    record_every : record every k-th step into time-series variables over
        (trajectory, time); needs one dt and t_end for the whole batch. Off by default.
    reversal_band : hysteresis of the reversal detector, a fraction of |initial spin|.
    parallel : spread blocks of trajectories over numba threads (``threads`` of them,
        default all); ``False`` runs on the calling thread only, releasing the GIL, for
        callers that bring their own parallelism.

    Returns
    -------
    xarray.Dataset over ``trajectory`` with ``first_reversal_time`` (s, NaN when none),
    ``n_reversals``, ``initial_spin``, ``final_spin``, ``mean_final_spin`` (rad/s),
    ``max_tilt`` (rad), ``energy_initial``, ``energy_final``, ``energy_lost`` (J),
    ``slip_fraction``, ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok, capsized,
    lifted_off, non_finite), with every input as a coordinate.
    """
    m = check_method(method)
    rec_every = check_record_every(record_every)
    band = check_band(reversal_band)
    prep = prepare(body, spin=spin, omega=omega, roll=roll, pitch=pitch, yaw=yaw,
                   orientation=orientation, velocity=velocity, mu=mu, mu_static=mu_static,
                   damping=damping, g=g, dt=dt, t_end=t_end)
    if rec_every is not None:
        check_single_step(prep)
    raw = engine.execute(prep, method=m, record_every=rec_every, band=band,
                         parallel=parallel, threads=threads)
    return results.batch_dataset(prep, raw, rec_every, attrs_for,
                                results.run_attrs(method, rec_every, band))
