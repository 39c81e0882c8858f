"""Batches of planar launches through the shared batch layer: validation and
broadcasting (:mod:`rattlesweep._launches`), packing (:mod:`rattlesweep._pack`), the
kernel run (:mod:`rattlesweep._run`) and results (:mod:`rattlesweep._results`).

:func:`run_planar_batch` broadcasts every per-trajectory input (arrays of bodies too) and
flattens the batch onto one ``trajectory`` dimension whose coordinates are the inputs, as
:func:`rattlesweep.run_batch` does for the 3-D body.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._launches import launches
from .._model import Model, Prepared
from .._options import check_method, check_record_every, check_single_step
from .._pack import prepared
from .._run import execute
from .._steps import step_counts, time_steps
from .._validation import fail_where
from .._core.models import PLANAR
from .._core.planar import layout
from ..inputs import PLANAR as INPUTS
from .body import PlanarBodies, PlanarBody
from .metadata import attrs_for

__all__ = ["MODEL", "prepare", "run_attrs", "run_planar_batch"]

TITLE = "rattlesweep planar rocking semi-ellipse simulation"

MODEL = Model(
    PLANAR,
    layout,
    observables=(
        "energy_initial",
        "energy_final",
        "energy_lost",
        "slip_fraction",
        "max_angle",
        "final_angle",
        "final_rate",
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
"""The planar model as the batch layer sees it."""

LAUNCH = tuple(s.name for s in INPUTS.values() if s.in_results and s.group != "body")
"""The inputs of a launch that results hold (under their result names)."""
BODY = tuple(s.name for s in INPUTS.values() if s.group == "body")
"""The body's parameters, results' coordinates too."""


def prepare(
    body: PlanarBodies,
    *,
    theta: ArrayLike,
    rate: ArrayLike = 0.0,
    velocity: ArrayLike | None = None,
    mu: ArrayLike = math.inf,
    mu_static: ArrayLike | None = None,
    mu_roll: ArrayLike = 0.0,
    g: ArrayLike = 9.81,
    dt: ArrayLike | None = None,
    t_end: ArrayLike,
) -> Prepared:
    """Check, broadcast and pack planar launches for the kernel.

    See :func:`run_planar_batch` for the arguments. Raises ValueError naming the parameter,
    the value and the rule for any invalid input. Non-finite launch values (theta, rate,
    velocity) are not errors: those trajectories get the status ``non_finite``.
    """
    if theta is None:
        raise ValueError("theta (rad) is required")
    if t_end is None:
        raise ValueError("t_end (s) is required")
    scalars = {
        "theta": theta,
        "rate": rate,
        "mu": mu,
        "mu_static": mu if mu_static is None else mu_static,
        "mu_roll": mu_roll,
        "mu_spin": 0.0,
        "g": g,
        "t_end": t_end,
    }
    if velocity is not None:
        scalars["velocity"] = velocity
    if dt is not None:
        scalars["dt"] = dt
    launch = launches(body, PlanarBody, scalars, INPUTS)
    flat, table, index, n = launch.flat, launch.bodies, launch.index, launch.n
    # warn at the user's call: run_planar_batch or simulate_planar -> prepare
    flat["dt"], default_from = time_steps(table, index, flat, stacklevel=3)
    columns = {
        k: np.array([getattr(b, k) for b in table], dtype=float)[index] for k in BODY
    }

    # initial state: rolling (contact point at rest) unless a velocity is given
    rate0 = flat["rate"]
    h = np.array([table[i].height(t) for i, t in zip(index, flat["theta"])])
    rolling = 0.0 - rate0 * h  # (not -rate0 * h: no -0.0 for a launch at rest)
    if "velocity" in flat:
        v0 = flat["velocity"]
        sliding = np.isfinite(v0) & np.isfinite(rolling) & (v0 != rolling)
        fail_where(
            "velocity",
            v0,
            sliding & np.isinf(flat["mu_static"]),
            "makes a sliding launch, which needs a finite mu_static",
        )
    else:
        v0 = rolling
    state = {"angle": flat["theta"], "rate": rate0, "x_G": np.zeros(n), "velocity_x": v0}
    dim = "trajectory"
    used = {**flat, "velocity": v0, **columns}  # the velocity actually used
    coords = {INPUTS[k].result_name: used[k] for k in (*LAUNCH, *BODY)}
    coords["body_name"] = np.array([b.name for b in table])[index]
    steps = step_counts(
        flat["t_end"],
        flat["dt"],
        default_from,
        (table, index),
        announce=False,
        stacklevel=3,
    )
    return prepared(
        MODEL,
        {**columns, **flat},
        state,
        steps,
        n,
        launch.shape,
        {k: (dim, v) for k, v in coords.items()},
    )


def run_attrs(method: str, record_every: int | None) -> dict[str, Any]:
    """Global attributes of a planar result."""
    attrs = results.run_attrs(method, record_every, None)
    attrs["title"] = TITLE
    attrs["model"] = "rocking half-ellipse lamina"
    return attrs


def run_planar_batch(
    body: PlanarBodies,
    *,
    theta: ArrayLike,
    rate: ArrayLike = 0.0,
    velocity: ArrayLike | None = None,
    mu: ArrayLike = math.inf,
    mu_static: ArrayLike | None = None,
    mu_roll: ArrayLike = 0.0,
    g: ArrayLike = 9.81,
    dt: ArrayLike | None = None,
    t_end: ArrayLike,
    method: str = "rk4",
    record_every: int | None = None,
    parallel: bool = True,
    threads: int | None = None,
) -> xr.Dataset:
    """Integrate many planar launches at once; return per-trajectory observables.

    Every argument except ``method``, ``record_every``, ``parallel`` and ``threads`` may be
    an array; all are broadcast together and flattened onto a ``trajectory`` dimension.

    Parameters
    ----------
    body : PlanarBody or array_like of PlanarBody
        The body of each launch.
    theta : array_like
        Initial rocking angle (rad, counter-clockwise), ``abs(theta) < pi/2``.
    rate : array_like, optional
        Initial dθ/dt (rad/s). Default 0.
    velocity : array_like, optional
        Initial horizontal velocity of G (m/s). Default: rolling, ẋ_G = −rate·h(θ); any
        other velocity launches the body sliding.
    mu, mu_static : array_like, optional
        Kinetic and static Coulomb coefficients; ``inf`` (the default) rolls without
        slip, ``0`` is frictionless; ``mu_static`` defaults to ``mu`` and must be
        >= ``mu``.
    mu_roll : array_like, optional
        Rolling resistance (m): a couple of at most mu_roll·N opposing the rocking, which
        holds the body still while the couple needed stays within the bound (the
        dry-friction oscillator). Default 0.
    g : array_like, optional
        Gravitational acceleration (m/s²). Default 9.81.
    dt : array_like, optional
        Time step (s). Default: 1/64 of the body's shorter small-rocking period.
    t_end : array_like
        End time (s); each trajectory takes ceil(t_end/dt) steps, at most 2**53.
    method : {"rk4", "euler"}, optional
        Classic RK4 (default) or semi-implicit Euler (first order).
    record_every : int, optional
        Record every k-th step into time series over (trajectory, time); needs one
        ``dt`` and ``t_end`` for the whole batch. Off by default.
    parallel : bool, optional
        Spread blocks of trajectories over numba threads (default); ``False`` runs on
        the calling thread only, releasing the GIL.
    threads : int, optional
        Number of numba threads for a parallel run (default: all).

    Returns
    -------
    xarray.Dataset
        Over ``trajectory``: ``energy_initial``, ``energy_final``, ``energy_lost`` (J),
        ``slip_fraction``, ``max_angle``, ``final_angle`` (rad), ``final_rate`` (rad/s),
        ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok, capsized, lifted_off,
        non_finite), with every input as a coordinate (``launch_angle``,
        ``launch_rate``, ``launch_velocity`` — the velocity actually used —, ``mu``, ...,
        and the body's ``a``, ``b``, ``mass``, ``com_depth``, ``inertia``,
        ``body_name``).

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule.
    """
    m = check_method(method)
    rec_every = check_record_every(record_every)
    prep = prepare(
        body,
        theta=theta,
        rate=rate,
        velocity=velocity,
        mu=mu,
        mu_static=mu_static,
        mu_roll=mu_roll,
        g=g,
        dt=dt,
        t_end=t_end,
    )
    if rec_every is not None:
        check_single_step(prep)
    raw = execute(
        prep, method=m, record_every=rec_every, parallel=parallel, threads=threads
    )
    return results.batch_dataset(
        prep, raw, rec_every, attrs_for, run_attrs(method, rec_every)
    )
