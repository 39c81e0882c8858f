"""Property-based tests (hypothesis) of bodies, launches and batches.

Every input either gets a ``ValueError`` (the documented error type) whose message names
a parameter the caller got wrong, or a result in which every ``ok`` trajectory is
finite, the energy never rises beyond the integrator's error, and each launch's result
does not depend on its position in the batch (nor on the batch's other launches, its
size, or the serial or threaded entry).

The number of examples per property comes from the hypothesis profile chosen in
tests/conftest.py (``ci`` by default; ``HYPOTHESIS_PROFILE=long`` for a long run).
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np
import pytest

pytest.importorskip("hypothesis")

from hypothesis import assume, event, given, note
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import rattlesweep as rs
from rattlesweep.rattleback import batch
from rattlesweep._core.workspace import NON_FINITE, OK
from rattlesweep import CoarseStepWarning
from rattlesweep.rattleback.launch import quaternion_from_angles
from strategies import (
    LAUNCH_ARGS,
    any_scalar,
    any_vector,
    arbitrary_inertia,
    arbitrary_value,
    finite,
    valid_bodies,
    valid_launch,
)
from property_checks import (
    OBSERVABLES,
    assert_names,
    assert_same_results,
    check_trajectories,
    rerun_batch,
)

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


# --- bodies ---------------------------------------------------------------------------
BODY_NAMES = {"a", "b", "c", "mass", "com", "inertia", "delta", "full_ellipsoid", "g"}


@given(
    kind=st.sampled_from(["explicit", "semi", "ellipsoid", "masses"]),
    a=any_scalar(finite(0.01, 0.3)),
    b=any_scalar(finite(0.005, 0.1)),
    c=any_scalar(finite(0.005, 0.1)),
    mass=any_scalar(finite(0.01, 2.0)),
    delta=any_scalar(finite(-1.0, 1.0)),
    com=any_vector(3, finite(-0.01, 0.01)),
    inertia=arbitrary_inertia(),
    full=st.booleans(),
    masses=st.lists(
        st.tuples(any_scalar(finite(0.001, 0.1)), any_vector(3, finite(-0.01, 0.01))),
        max_size=3,
    ),
)
def test_any_body_is_refused_by_name_or_usable(
    kind, a, b, c, mass, delta, com, inertia, full, masses
):
    """A body constructor either refuses its input with a ValueError naming a parameter,
    or makes a body whose derived quantities are finite and positive."""
    try:
        if kind == "explicit":
            body = rs.Body(a, b, c, mass, com, inertia, full)
        elif kind == "semi":
            body = rs.Body.semi_ellipsoid(a, b, c, mass, delta)
        elif kind == "ellipsoid":
            body = rs.Body.ellipsoid(a, b, c, mass)
        else:
            body = rs.Body.preset("toy").with_point_masses(masses)
    except ValueError as exc:
        names = BODY_NAMES | {f"masses[{i}]" for i in range(len(masses))}
        assert_names(exc, names)
        event("refused")
        return
    event("accepted")
    for g in (1.0, 9.81):
        try:
            dt = body.default_dt(g)
        except ValueError as exc:  # the body is checked at g = 1: a larger g may overflow
            assert g > 1.0
            assert_names(exc, {"g"})
            continue
        assert math.isfinite(dt) and dt > 0
        freqs = body.small_oscillation_frequencies(g)
        assert all(math.isfinite(f) and f >= 0 for f in freqs)
    assert math.isfinite(body.misalignment) and math.isfinite(body.com_height)
    assert body.com_height > 0
    assert (
        rs.Body(
            body.a, body.b, body.c, body.mass, body.com, body.inertia, body.full_ellipsoid
        )
        == body
    )


@given(body=valid_bodies(), data=st.data())
def test_valid_bodies_run_cleanly(body, data):
    """A short launch of any valid body, at most at its default step, runs with finite
    results and no energy gain."""
    kw = data.draw(valid_launch(body, max_steps=200))
    ds = rs.run_batch(body, **kw)
    check_trajectories(ds, rerun_batch(functools.partial(rs.run_batch, body), ds, kw))


# --- launches -------------------------------------------------------------------------
def _run_or_validate(body, kw):
    """run_batch(body, **kw) and the arguments it ran with, and whether it warned of a
    coarse step. An accepted launch that would take more than 5000 steps is checked by
    the validation alone (batch.max_steps) and run with an end time of at most 5000 of
    its steps (a strong gravity's default step can be far below a microsecond)."""
    launch = {
        k: v
        for k, v in kw.items()
        if k not in ("method", "record_every", "reversal_band", "parallel", "threads")
    }
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CoarseStepWarning)
        steps = batch.max_steps(body, **launch)
        if steps > 5000:
            short = 1e-3
            steps = batch.max_steps(body, **{**launch, "t_end": short})
            kw = {**kw, "t_end": short * min(1.0, 5000 / steps)}
        ds = rs.run_batch(body, **kw)
    coarse = any(issubclass(w.category, CoarseStepWarning) for w in caught)
    return ds, kw, coarse


ACCURACY_NEUTRAL = {
    "method",
    "record_every",
    "reversal_band",
    "parallel",
    "threads",
    "mu",
    "mu_static",
    "mu_spin",
    "mu_roll",
    "damping",
}
"""Arguments that cannot take a valid launch out of what its step resolves."""


def _check_accepted(body, ds, kw, coarse, changed):
    """The checks of an accepted launch: all of them when it is resolved (no coarse
    step, and only ACCURACY_NEUTRAL arguments changed), else finiteness alone (a
    launch too fast for its step is valid input, not accurate output)."""
    if coarse or not set(changed) <= ACCURACY_NEUTRAL:
        ok = ds.status.values == OK
        for name in OBSERVABLES:
            if name not in ("first_reversal_time", "mean_final_spin"):
                assert np.all(np.isfinite(ds[name].values[ok])), name
    else:
        shrink = 2.0 if kw.get("method") == "euler" else 8.0
        check_trajectories(
            ds, rerun_batch(functools.partial(rs.run_batch, body), ds, kw), shrink
        )


@given(body=valid_bodies(), data=st.data())
def test_bad_launch_arguments_are_refused_by_name(body, data):
    """A valid launch with some arguments replaced by arbitrary values: a ValueError that
    names one of the replaced arguments, or a run whose ok trajectories are clean."""
    kw = data.draw(valid_launch(body))
    changed = data.draw(
        st.lists(st.sampled_from(LAUNCH_ARGS), min_size=1, max_size=3, unique=True)
    )
    for name in changed:
        kw[name] = data.draw(arbitrary_value(name), label=name)
    try:
        ds, kw, coarse = _run_or_validate(body, kw)
    except ValueError as exc:
        # a rule that ties two arguments names both: "mu_static must be >= mu", ...
        assert_names(exc, changed)
        event("refused")
        return
    event("accepted")
    _check_accepted(body, ds, kw, coarse, changed)


@given(body=valid_bodies(), data=st.data())
def test_one_bad_argument_is_named(body, data):
    """A valid launch with exactly one argument replaced: if it is refused, the message
    names that argument (or the argument it is tied to by the rule it breaks)."""
    kw = data.draw(valid_launch(body))
    name = data.draw(st.sampled_from(LAUNCH_ARGS))
    kw[name] = data.draw(arbitrary_value(name), label=name)
    partners = {
        "spin": {"omega"},
        "omega": {"spin"},
        "orientation": {"roll", "pitch"},
        "roll": {"orientation"},
        "pitch": {"orientation"},
        "yaw": {"orientation"},
        "mu": {"mu_static", "velocity"},
        "mu_static": {"velocity"},
        "velocity": {"mu_static"},
        "t_end": {"record_every"},
        "dt": {"record_every"},
    }
    try:
        ds, kw, coarse = _run_or_validate(body, kw)
    except ValueError as exc:
        assert_names(exc, {name} | partners.get(name, set()))
        event("refused")
        return
    event("accepted")
    _check_accepted(body, ds, kw, coarse, [name])


# --- batches --------------------------------------------------------------------------
@st.composite
def batches(draw, max_size: int = 8):
    """A batch of 1..max_size valid launches, each with its own body, as per-launch
    keyword arguments that share their keys (so that they stack into arrays)."""
    n = draw(st.integers(1, max_size))
    bodies = [draw(valid_bodies()) for _ in range(n)]
    launches = [draw(valid_launch(b, max_steps=150)) for b in bodies]
    # one set of keys for the whole batch: take the first launch's, fill the others in
    first = launches[0]
    keys = set(first)
    for b, kw in zip(bodies, launches):
        if "omega" in keys and "omega" not in kw:
            kw["omega"] = (0.0, 0.0, kw.pop("spin"))
        if "spin" in keys and "spin" not in kw:
            kw["spin"] = float(kw.pop("omega")[2])
        if "orientation" in keys and "orientation" not in kw:
            kw["orientation"] = tuple(
                quaternion_from_angles(
                    kw.pop("roll"), kw.pop("pitch"), kw.pop("yaw")
                ).tolist()
            )
        if "roll" in keys and "roll" not in kw:
            kw.pop("orientation")
            kw.update(roll=0.01, pitch=0.0, yaw=0.0)
        if "velocity" in keys:
            kw.setdefault("velocity", (0.0, 0.0))
            if not math.isfinite(kw.get("mu_static", kw["mu"])):
                kw["mu"], kw["mu_static"] = 0.3, 0.5
        elif "velocity" in kw:
            del kw["velocity"]
        if "mu_static" in keys or "velocity" in keys:
            kw.setdefault("mu_static", kw["mu"])
        elif "mu_static" in kw:
            del kw["mu_static"]
        if "dt" in keys and "dt" not in kw:
            kw["dt"] = 0.5 * b.default_dt(kw["g"])
            # at least one step: a given dt longer than t_end is refused
            kw["t_end"] = max(min(kw["t_end"], 100 * kw["dt"]), kw["dt"])
        elif "dt" not in keys and "dt" in kw:
            del kw["dt"]  # the default step then: at least one of it
            kw["t_end"] = max(kw["t_end"], b.default_dt(kw["g"]))
        for k in ("damping", "mu_spin", "mu_roll"):
            if k in keys:
                kw.setdefault(k, 0.0)
            else:
                kw.pop(k, None)
    return bodies, launches


def _stack(bodies, launches, order):
    arr = np.empty(len(order), dtype=object)
    arr[:] = [bodies[i] for i in order]
    kw = {k: np.array([launches[i][k] for i in order], dtype=float) for k in launches[0]}
    return arr, kw


@given(data=batches(), parallel=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_results_do_not_depend_on_position_in_the_batch(data, parallel, seed):
    """The same launches in another order, with other neighbours (padding launches
    added), on the other entry point, give the same results bit for bit; each launch
    alone gives its result in the batch."""
    bodies, launches = data
    n = len(launches)
    note(f"{n} launches: {launches}")
    arr, kw = _stack(bodies, launches, range(n))
    ds = rs.run_batch(arr, parallel=parallel, **kw)
    assert ds.sizes["trajectory"] == n
    check_trajectories(ds, rerun_batch(functools.partial(rs.run_batch, arr), ds, kw))

    order = np.random.default_rng(seed).permutation(n)
    # padding: the same launches again, so the batch spans more blocks at other offsets
    extra = int(np.random.default_rng(seed + 1).integers(0, 40))
    order_padded = np.concatenate([np.resize(order, extra), order])
    arr2, kw2 = _stack(bodies, launches, order_padded)
    ds2 = rs.run_batch(arr2, parallel=not parallel, **kw2)
    back = ds2.isel(trajectory=extra + np.argsort(order))
    assert_same_results(ds, back, "(reordered and padded)")

    alone_at = int(order[0])
    arr1, kw1 = _stack(bodies, launches, [alone_at])
    alone = rs.run_batch(arr1, parallel=False, **kw1)
    assert_same_results(ds.isel(trajectory=[alone_at]), alone, f"(launch {alone_at} alone)")


SCALAR_ARGS = ("spin", "roll", "pitch", "mu", "damping", "g", "t_end")
VALID = {
    "spin": finite(-30, 30),
    "roll": finite(-0.1, 0.1),
    "pitch": finite(-0.1, 0.1),
    "mu": st.sampled_from([0.0, 0.2, 1.0, math.inf]),
    "damping": finite(0, 1e-4),
    "g": finite(3.0, 20.0),
    "t_end": finite(0.001, 0.02),
}


@given(
    data=st.data(),
    shapes=hnp.mutually_broadcastable_shapes(
        num_shapes=len(SCALAR_ARGS) + 1, min_dims=0, max_dims=3, min_side=0, max_side=3
    ),
)
def test_broadcasting(data, shapes):
    """Inputs of any broadcast-compatible shapes (empty and size-1 axes included) give
    one trajectory per element of their broadcast shape, each labelled with its inputs
    and with the result of that launch alone."""
    arg_shapes, body_shape = shapes.input_shapes[:-1], shapes.input_shapes[-1]
    shape = shapes.result_shape
    kw = {
        name: data.draw(hnp.arrays(float, s, elements=VALID[name]), label=name)
        for name, s in zip(SCALAR_ARGS, arg_shapes)
    }
    presets = [rs.Body.preset(p) for p in ("toy", "kane_levinson")]
    bodies = np.empty(body_shape, dtype=object)
    for idx in np.ndindex(body_shape):
        bodies[idx] = presets[data.draw(st.integers(0, 1))]
    if bodies.size == 0:  # an empty array of bodies is refused (it has no body type)
        with pytest.raises(ValueError, match="body"):
            rs.run_batch(bodies, **kw)
        return
    body_arg = bodies if bodies.ndim else bodies[()]
    ds = rs.run_batch(body_arg, **kw)
    n = int(np.prod(shape))
    assert ds.sizes["trajectory"] == n
    assert ds.attrs["batch_shape"] == list(shape)
    launch_names = {"spin": "launch_spin", "roll": "roll_deg", "pitch": "pitch_deg"}
    for name, values in kw.items():
        given = np.degrees(values) if name in ("roll", "pitch") else values
        np.testing.assert_array_equal(
            ds[launch_names.get(name, name)].values, np.broadcast_to(given, shape).ravel()
        )
    flat_bodies = np.broadcast_to(bodies, shape).ravel()
    np.testing.assert_array_equal(ds.body_name.values, [b.name for b in flat_bodies])
    check_trajectories(ds, rerun_batch(functools.partial(rs.run_batch, body_arg), ds, kw))
    if n:
        i = data.draw(st.integers(0, n - 1))
        one = rs.run_batch(
            flat_bodies[i],
            **{k: np.broadcast_to(v, shape).ravel()[i] for k, v in kw.items()},
        )
        assert_same_results(ds.isel(trajectory=[i]), one)


@given(
    data=st.data(),
    shapes=st.lists(
        hnp.array_shapes(min_dims=1, max_dims=2, min_side=0, max_side=3),
        min_size=2,
        max_size=2,
    ),
)
def test_incompatible_shapes_are_refused_by_name(data, shapes):
    try:
        np.broadcast_shapes(*shapes)
    except ValueError:
        pass
    else:
        assume(False)
    kw = {"spin": np.zeros(shapes[0]), "mu": np.full(shapes[1], 0.3)}
    with pytest.raises(ValueError, match="cannot be broadcast") as info:
        rs.run_batch(rs.Body.preset("toy"), t_end=0.01, **kw)
    assert_names(info.value, {"spin", "mu"})


# --- single runs ----------------------------------------------------------------------
@given(body=valid_bodies(), data=st.data())
def test_simulate_records_a_clean_history(body, data):
    """simulate(): a finite history while ok, the energy never above its launch value,
    and the observables of the same launch in a batch."""
    kw = data.draw(valid_launch(body, max_steps=300))
    run = rs.simulate(body, record_every=1, **kw)
    ds = rs.run_batch(body, record_every=1, **kw)
    check_trajectories(
        ds, rerun_batch(functools.partial(rs.run_batch, body, record_every=1), ds, kw)
    )
    for name in OBSERVABLES:
        np.testing.assert_array_equal(run[name].values, ds[name].values[0], err_msg=name)
    np.testing.assert_array_equal(run.energy.values, ds.energy.values[0])


def test_mean_final_spin_of_a_short_run_is_finite():
    """mean_final_spin, the mean over the last 10 % of the run, of an ok run of 9 steps:
    found NaN by the property tests."""
    toy = rs.Body.preset("toy")
    ds = rs.run_batch(toy, spin=3.0, roll=0.01, t_end=9 * toy.default_dt())
    assert int(ds.status[0]) == OK and int(ds.steps[0]) == 9
    assert np.isfinite(ds.mean_final_spin.values[0])


def test_a_launch_whose_energy_overflows_is_non_finite():
    """A finite launch state with an infinite energy (found by the property tests:
    velocity (0, 1e300) ran frictionless and came back ok with an infinite energy) is
    refused to run and gets the non_finite status."""
    toy = rs.Body.preset("toy")
    ds = rs.run_batch(
        toy,
        spin=0.0,
        velocity=[(0.0, 1e300), (0.0, 0.01)],
        mu=0.0,
        mu_static=0.0,
        t_end=0.01,
    )
    assert list(ds.status.values) == [NON_FINITE, OK]  # and a clean neighbour
    assert int(ds.steps[0]) == 0 and np.isnan(ds.energy_initial.values[0])
    assert np.isfinite(ds.energy_final.values[1])
