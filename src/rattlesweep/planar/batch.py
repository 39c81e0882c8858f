"""Batches of planar launches through the shared batch layer: validation and
broadcasting (:mod:`rattlesweep._launches`), packing (:mod:`rattlesweep._pack`), the
kernel run (:mod:`rattlesweep._run`) and results (:mod:`rattlesweep._results`).

:func:`run_planar_batch` broadcasts every per-trajectory input (arrays of bodies too) and
flattens the batch onto one ``trajectory`` dimension whose coordinates are the inputs, as
:func:`rattlesweep.run_batch` does for the 3-D body.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._keywords import accepted, check_keywords, document, launch_values
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

ACCEPTED = accepted(INPUTS)
"""The names :func:`run_planar_batch` and :func:`simulate_planar` take inputs by."""
LAUNCH = tuple(s.name for s in INPUTS.values() if s.in_results and s.group != "body")
"""The inputs of a launch that results hold (under their result names)."""
BODY = tuple(s.name for s in INPUTS.values() if s.group == "body")
"""The body's parameters, results' coordinates too."""


def prepare(body: PlanarBodies, **given: Any) -> Prepared:
    """Check, broadcast and pack planar launches for the kernel.

    ``given``: the per-launch inputs of :func:`run_planar_batch` by name. Raises
    ValueError naming the parameter, the value and the rule for any invalid input.
    Non-finite launch values (theta, rate, velocity) are not errors: those trajectories
    get the status ``non_finite``.
    """
    check_keywords(prepare, given, ACCEPTED)
    scalars = launch_values(given, INPUTS)
    launch = launches(body, PlanarBody, scalars, INPUTS)
    flat = launch.flat
    flat["mu_spin"] = np.zeros(launch.n)  # a row of the shared layout: none in the plane
    table, index, n = launch.bodies, launch.index, launch.n
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


@document(INPUTS)
def run_planar_batch(
    body: PlanarBodies,
    *,
    method: str = INPUTS["method"].default,
    record_every: int | None = None,
    parallel: bool = INPUTS["parallel"].default,
    threads: int | None = None,
    **inputs: ArrayLike | None,
) -> xr.Dataset:
    """Integrate many planar launches at once; return per-trajectory observables.

    Every per-launch input may be an array; all are broadcast together with the body and
    flattened onto a ``trajectory`` dimension. ``method``, ``record_every``,
    ``parallel`` and ``threads`` are options of the whole batch. The inputs and their
    descriptions: :data:`rattlesweep.inputs.PLANAR`.

    Parameters
    ----------
    body : PlanarBody or array_like of PlanarBody
        The body of each launch.
    {inputs}

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
    TypeError
        For a name that is neither an input nor an option, listing both; for a
        required input not given (``theta``, ``t_end``).
    """
    check_keywords(run_planar_batch, inputs, ACCEPTED, INPUTS)
    m = check_method(method)
    rec_every = check_record_every(record_every)
    prep = prepare(body, **inputs)
    if rec_every is not None:
        check_single_step(prep)
    raw = execute(
        prep, method=m, record_every=rec_every, parallel=parallel, threads=threads
    )
    return results.batch_dataset(
        prep, raw, rec_every, attrs_for, run_attrs(method, rec_every)
    )
