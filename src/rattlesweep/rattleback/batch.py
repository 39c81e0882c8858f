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
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._keywords import (
    accepted,
    angles,
    check_keywords,
    document,
    launch_values,
    per_launch,
)
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
from .._shadows import (
    DISPLACEMENT,
    check_rolling,
    shadowed,
    warn_short,
    with_lyapunov,
)
from .._run import announce_compile, contact_slip_velocity, execute
from .._steps import step_counts, time_steps
from .._validation import as_float_array, check_boolean, fail_where
from .._core.models import RATTLEBACK
from .._core.workspace import BLOCK
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
    "run_attrs",
    "run_batch",
    "split_angles",
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

LAUNCH = per_launch(INPUTS)
"""The inputs of each launch, by name."""
ANGLES = angles(INPUTS)
"""The launch angles, which a caller may give in degrees (``roll_deg``)."""
ACCEPTED = accepted(INPUTS)
"""The names :func:`run_batch` and :func:`rattlesweep.simulate` take launch inputs by."""

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


def launch_inputs(body: Bodies, *, announce: bool = True, **given: Any) -> Inputs:
    """Check and broadcast launch inputs (``given``: the per-launch inputs of
    :func:`run_batch` by name, angles in radians), without the kernel. Raises ValueError
    naming the parameter, the value and the rule for any invalid input. Non-finite
    launch values (spin, omega, angles, orientation, velocity) are not errors: those
    trajectories get the status ``non_finite``. ``announce`` warns
    (:class:`~rattlesweep.LongRunWarning`) of a batch of more than
    :data:`~rattlesweep._steps.LONG_RUN_STEPS` steps."""
    check_keywords(launch_inputs, given, tuple(LAUNCH))
    if given.get("spin") is not None and given.get("omega") is not None:
        raise ValueError(
            "give either spin (about the vertical) or omega (body frame), not both"
        )
    if given.get("orientation") is not None and any(
        np.any(as_float_array(k, given[k]) != 0)
        for k in ("roll", "pitch", "yaw")
        if given.get(k) is not None
    ):
        raise ValueError("give either orientation or roll/pitch/yaw, not both")
    scalars = launch_values(given, LAUNCH)
    spin = scalars.pop("spin")
    if given.get("omega") is None:  # given, omega is the launch's rotation instead
        scalars["spin"] = spin
    vectors: dict[str, np.ndarray] = {}
    for name, spec in LAUNCH.items():
        width, value = spec.width, given.get(name)
        if width > 1 and value is not None:
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


def split_angles(
    body: Bodies, inputs: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """The keyword inputs of :func:`run_batch` or :func:`rattlesweep.simulate` as the
    inputs other than the angles, the angles in radians (from the radian or the degree
    form of each: :func:`rattlesweep.rattleback.launch.angles_in_radians`; warns at the
    caller's caller), and the angles the user gave in degrees, by angle."""
    names = [*ANGLES, *(f"{k}_deg" for k in ANGLES)]
    bodies = as_bodies(body, Body)
    full = all(b.full_ellipsoid for b in bodies.flat)
    forms = {k: inputs.get(k) for k in names}
    radians = angles_in_radians(forms, full_ellipsoid=full, stacklevel=4)
    degrees = {k: forms[f"{k}_deg"] for k in ANGLES if forms[f"{k}_deg"] is not None}
    return {k: v for k, v in inputs.items() if k not in names}, radians, degrees


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


def _displaced(
    state: dict[str, np.ndarray], columns: dict[str, np.ndarray], shadow: np.ndarray
) -> None:
    """Launch each shadow lane (``shadow``) turned by :data:`DISPLACEMENT` rad about its
    body x and y axes, its angular velocity raised by DISPLACEMENT sqrt(g/c) in each body
    component: a displacement in every direction :func:`separation
    <rattlesweep._core.rattleback.model.separation>` measures."""
    e = DISPLACEMENT
    w, x, y, z = state["quaternion"][shadow].T
    # q ⊗ (1, e/2, e/2, 0): a turn by e about body x and by e about body y
    turned = np.stack(
        [
            w - 0.5 * e * (x + y),
            x + 0.5 * e * (w - z),
            y + 0.5 * e * (w + z),
            z + 0.5 * e * (x - y),
        ],
        axis=-1,
    )
    state["quaternion"][shadow] = turned / np.linalg.norm(turned, axis=-1, keepdims=True)
    rate = np.sqrt(columns["g"][shadow] / columns["c"][shadow])
    state["omega"][shadow] += e * rate[:, None]


def prepare(
    body: Bodies,
    *,
    stop: str | None = None,
    lyapunov: bool = False,
    degrees: Mapping[str, ArrayLike] | None = None,
    announce: bool = True,
    **kwargs: Any,
) -> Prepared:
    """Check, broadcast and pack launches for the kernel; arguments as for
    :func:`run_batch`, angles in radians; ``degrees`` maps ``roll``, ``pitch``, ``yaw``
    to the values the user gave in degrees, which the coordinates keep as given
    (``announce`` as for :func:`launch_inputs`). With ``lyapunov``, each launch is
    packed beside its shadow (:mod:`rattlesweep._shadows`)."""
    rule = check_stop(stop)
    lyapunov = check_boolean("lyapunov", lyapunov)
    inputs = launch_inputs(body, announce=announce, **kwargs)
    n = inputs.n
    columns = {**inputs.body_columns(), **inputs.flat, "stop_rule": np.full(n, rule)}
    state = _launch_state(inputs)
    if lyapunov:
        check_rolling(inputs.flat, inputs.shape)
        if announce:  # run_batch or simulate -> prepare: warn at the user's call
            warn_short(inputs.flat["t_end"], stacklevel=3)
        prep = shadowed(
            with_lyapunov(MODEL), columns, state, inputs.nsteps, n, inputs.shape, _displaced
        )
    else:
        prep = prepared(MODEL, columns, state, inputs.nsteps, n, inputs.shape, {})
    # G's velocity: rolling (material contact point at rest) unless given
    announce_compile(prep)  # before the first kernel, naming what the batch compiles
    every_lane = -contact_slip_velocity(MODEL, prep.P, prep.Y)
    rolling = prep.per_trajectory(every_lane.reshape(2, -1, BLOCK).transpose(1, 0, 2))
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
    if prep.lanes is not None:  # every lane rolls: a sliding launch is refused above
        v = every_lane
    prep.Y[:, layout.STATE.slice("velocity"), :] = blocked(v, v.shape[1])
    return dataclasses.replace(prep, coords=_coords(inputs, columns, given, degrees or {}))


@document(INPUTS)
def run_batch(
    body: Bodies,
    *,
    method: str = INPUTS["method"].default,
    record_every: int | None = None,
    reversal_band: float = INPUTS["reversal_band"].default,
    stop: str | None = None,
    lyapunov: bool = False,
    parallel: bool = INPUTS["parallel"].default,
    threads: int | None = None,
    **inputs: ArrayLike | None,
) -> xr.Dataset:
    """Integrate many launches at once; return per-trajectory observables.

    Every per-launch input (the launch, the friction, the numerics) may be an array;
    all are broadcast together with the body (vector inputs ``omega``, ``orientation``
    and ``velocity`` on their leading axes) and flattened onto a ``trajectory``
    dimension. ``method``, ``record_every``, ``reversal_band``, ``stop``, ``lyapunov``,
    ``parallel`` and ``threads`` are options of the whole batch. The inputs and their
    descriptions: :data:`rattlesweep.inputs.RATTLEBACK`.

    ``lyapunov=True`` adds ``lyapunov`` (1/s): each launch's largest finite-time
    Lyapunov exponent over its run, from a shadow launch renormalised every 0.05 s (the
    chaos guide, docs/guide/chaos.md). It needs rolling contact (``mu`` = inf, the
    default, or ``mu_static`` = inf; ``mu_spin`` = ``mu_roll`` = 0) and costs about
    twice the plain batch.

    Parameters
    ----------
    body : Body or array_like of Body
        The body of each launch.
    {inputs}

    Returns
    -------
    xarray.Dataset
        Over ``trajectory``: ``first_reversal_time`` (s, NaN when none; the spin's
        first crossing beyond the band), ``n_reversals`` (reversals of the heading, the
        long axis seen from above: each time it turns back by more than 0.1 rad from
        the furthest it had turned), ``initial_spin``, ``final_spin``, ``mean_final_spin``
        (rad/s), ``max_tilt`` (rad), ``energy_initial``, ``energy_final``, ``energy_lost``
        (J), ``slip_fraction``, ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok,
        capsized, lifted_off, non_finite), ``lyapunov`` (1/s) with ``lyapunov=True``,
        with every input as a coordinate.

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule, before any
        computation. Non-finite launch values are not errors: those trajectories get
        the status ``non_finite``.
    TypeError
        For a name that is neither an input nor an option, listing both; for a
        required input not given (``t_end``).

    Warns
    -----
    CoarseStepWarning
        When a given ``dt`` is more than 4 times the default step.
    LongRunWarning
        Before a batch of more than 10**9 steps in all (a quarter of an hour of a
        core or more), with the step count and where it comes from.
    """
    check_keywords(run_batch, inputs, ACCEPTED, INPUTS)
    m = check_method(method)
    rec_every = check_record_every(record_every)
    band = check_band(reversal_band)
    given, radians, degrees = split_angles(body, inputs)
    prep = prepare(body, **given, **radians, degrees=degrees, stop=stop, lyapunov=lyapunov)
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
        prep,
        raw,
        rec_every,
        attrs_for,
        run_attrs(method, rec_every, band, stop, lyapunov=prep.lanes is not None),
    )


def run_attrs(
    method: str,
    record_every: int | None,
    band: float,
    stop: str | None = None,
    *,
    lyapunov: bool = False,
) -> dict[str, Any]:
    """Global attributes of a rattleback result."""
    attrs = results.run_attrs(method, record_every, band, stop, lyapunov=lyapunov)
    attrs["title"] = TITLE
    return attrs
