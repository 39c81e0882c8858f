"""Each input described once (rattlesweep.inputs): every result carries the description's
units and long name, every function takes the described inputs with the described
defaults, and validation refuses what each described rule refuses, naming the input."""

import inspect
import math
import re

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.rattleback.batch import launch_inputs, max_steps
from rattlesweep._core.rattleback import layout as rattleback_layout
from rattlesweep._core.planar import layout as planar_layout
from rattlesweep._core.workspace import COMMON_PARAMS
from rattlesweep.inputs import (
    AT_LEAST_MU,
    BAND,
    FINITE,
    HALF_TURN,
    NONNEG,
    NONNEG_INF,
    PLANAR,
    POSITIVE,
    RATTLEBACK,
    UNIT_QUATERNION,
)
from rattlesweep.planar.batch import prepare as prepare_planar

TOY = rs.Body.preset("toy")
LAMINA = rs.PlanarBody(0.10, 0.05, 1.0)
T_END = 0.02

# each rule: a value it accepts at its edge, and one it refuses
EDGES = {
    id(POSITIVE): (1e-3, 0.0),
    id(NONNEG): (0.0, -1e-9),
    id(NONNEG_INF): (math.inf, -1e-9),
    id(FINITE): (0.0, math.inf),
    id(HALF_TURN): (1.5, 1.6),
    id(BAND): (0.0, 1.0),
    id(AT_LEAST_MU): (math.inf, -1e-9),
    id(UNIT_QUATERNION): ((1.0, 0.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0)),
}

# arguments that are another form of a described input (the angles in degrees)
FORMS = {"roll_deg", "pitch_deg", "yaw_deg"}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Every input of each model in a batch, a single run and (3-D) sweeps."""
    friction = dict(mu=0.3, mu_static=0.4, mu_spin=1e-5, mu_roll=1e-6)
    launch = dict(**friction, damping=1e-8, g=9.8, dt=1e-3, t_end=T_END)
    batches = [
        rs.run_batch(
            TOY,
            spin=[2.0, -2.0],
            roll_deg=0.5,
            pitch_deg=0.25,
            yaw_deg=10.0,
            velocity=(0.01, 0.0),
            **launch,
        ),
        rs.run_batch(
            TOY, omega=[0.1, 0.0, 2.0], orientation=[1.0, 0.0, 0.0, 0.0], **launch
        ),
    ]
    runs = [
        rs.simulate(
            TOY,
            spin=2.0,
            roll_deg=0.5,
            pitch_deg=0.25,
            yaw_deg=10.0,
            velocity=(0.01, 0.0),
            **launch,
        ),
        rs.simulate(TOY, omega=[0.1, 0.0, 2.0], orientation=[1.0, 0.0, 0.0, 0.0], **launch),
    ]
    out = tmp_path_factory.mktemp("inputs")
    fixed = dict(
        a=0.06,
        b=0.01,
        c=0.01,
        mass=0.02,
        roll=0.01,
        pitch=0.005,
        yaw=0.1,
        **{k: v for k, v in launch.items() if k != "t_end"},
        t_end=0.01,
    )
    sweeps = [
        rs.run_sweep(
            rs.Sweep(axes={"spin": [2.0, -2.0], "delta_deg": [1.0]}, fixed=fixed),
            out / "fixed",
            progress=False,
            workers=1,
        ),
        # the body's default step (a variable), the angles and spin as axes and draws
        rs.run_sweep(
            rs.Sweep(
                axes={"spin": [2.0], "roll_deg": [0.5], "pitch": [0.01]},
                fixed={"t_end": 0.01, "yaw_deg": 3.0},
                random={"mu": {"uniform": [0.2, 0.3]}},
            ),
            out / "default_dt",
            progress=False,
            workers=1,
        ),
    ]
    planar = dict(
        theta=0.1,
        rate=0.5,
        velocity=0.01,
        mu=0.3,
        mu_static=0.4,
        mu_roll=1e-6,
        g=9.8,
        dt=1e-3,
        t_end=T_END,
    )
    return {
        "rattleback": (batches, runs, sweeps),
        "planar": (
            [rs.run_planar_batch(LAMINA, **planar)],
            [rs.simulate_planar(LAMINA, **planar)],
            [],
        ),
    }


@pytest.mark.parametrize("model", ["rattleback", "planar"])
def test_every_input_carries_its_description_in_every_result(results, model):
    inputs = RATTLEBACK if model == "rattleback" else PLANAR
    batches, runs, sweeps = results[model]
    seen = {"batch": set(), "simulate": set(), "sweep": set()}
    for spec in inputs.values():
        if not spec.in_results:  # run settings: global attributes without units
            continue
        name, want = spec.result_name, spec.attrs
        for ds in batches:
            if name in ds.coords:
                assert {k: ds[name].attrs[k] for k in want} == want, name
                seen["batch"].add(spec.name)
        for ds in runs:
            if name in ds.attrs:
                assert ds.attrs[f"{name}_units"] == want["units"], name
                assert ds.attrs[f"{name}_long_name"] == want["long_name"], name
                seen["simulate"].add(spec.name)
        for ds in sweeps:
            if name in ds.variables:
                assert {k: ds[name].attrs[k] for k in want} == want, name
                seen["sweep"].add(spec.name)
    # every input results hold is in each kind of result (delta: in sweeps only)
    kept = {s.name for s in inputs.values() if s.in_results and s.name != "delta"}
    assert seen["batch"] == kept
    assert seen["simulate"] == kept
    if model == "rattleback":
        assert seen["sweep"] == {s.name for s in inputs.values() if s.sweep}
    # ... and no input a result holds lacks a description
    described = {s.result_name for s in inputs.values()} | {
        "body_name",
        "trajectory",
        "time",
    }
    for ds in batches:
        assert set(ds.coords) - described <= {
            "quaternion_component",
            "body_axis",
            "horizontal",
        }


def test_a_swept_default_step_and_draws_carry_the_inputs_long_names(results):
    _, _, sweeps = results["rattleback"]
    dt, mu = sweeps[1].dt, sweeps[1].mu
    assert dt.dims == sweeps[1].outcome.dims  # a variable: each point's own default
    assert (dt.attrs["units"], dt.attrs["long_name"]) == ("s", RATTLEBACK["dt"].long_name)
    assert "damping" in dt.attrs["comment"]
    assert mu.attrs["long_name"] == RATTLEBACK["mu"].long_name
    assert "random draw" in mu.attrs["comment"]


def test_the_kernel_packs_inputs_in_their_described_units():
    """Every parameter row the kernel packs an input into carries the input's units and
    long name, so that the two cannot drift apart."""
    for rows, inputs in (
        (rattleback_layout.PARAMS, RATTLEBACK),
        (planar_layout.PARAMS, PLANAR),
    ):
        for row in (*COMMON_PARAMS, *rows):
            if row.name in inputs:
                assert row.units == inputs[row.name].units, row.name
                assert row.long_name == inputs[row.name].long_name, row.name


FUNCTIONS = {
    "rattleback": (rs.run_batch, rs.simulate),
    "planar": (rs.run_planar_batch, rs.simulate_planar),
}


@pytest.mark.parametrize("model", ["rattleback", "planar"])
def test_the_functions_take_the_described_inputs_with_their_defaults(model):
    inputs = RATTLEBACK if model == "rattleback" else PLANAR
    arguments = {s.name for s in inputs.values() if s.group != "body"}
    for function in FUNCTIONS[model]:
        params = inspect.signature(function).parameters
        names = set(params) - {"body"} - FORMS
        # a single run is on the calling thread and runs to t_end
        single = function.__name__.startswith("simulate")
        assert names == arguments - ({"parallel", "threads", "stop"} if single else set())
        for name in names:
            spec, given = inputs[name], params[name].default
            if spec.required:
                assert given is inspect.Parameter.empty, name
            elif given is not None:
                assert given == spec.default, (function.__name__, name)


def test_omitted_inputs_take_their_described_defaults():
    batch = rs.run_batch(TOY, t_end=T_END)
    run = rs.simulate(TOY, t_end=T_END)
    numbers = [
        s for s in RATTLEBACK.values() if s.in_results and isinstance(s.default, float)
    ]
    assert {s.name for s in numbers} >= {"spin", "roll", "mu", "mu_spin", "damping", "g"}
    for spec in numbers:
        if spec.name == "delta":
            continue
        np.testing.assert_array_equal(
            batch[spec.result_name].values, spec.default, spec.name
        )
        assert run.attrs[spec.result_name] == spec.default, spec.name
    assert batch.mu_static.values[0] == batch.mu.values[0]  # "`mu`"
    assert batch.attrs["method"] == RATTLEBACK["method"].default
    assert batch.attrs["reversal_band"] == RATTLEBACK["reversal_band"].default
    assert batch.attrs["record_every"] == -1 and "stop" not in batch.attrs
    # the default step: the body's, or its smallest principal moment / damping if shorter,
    # as the description says
    assert batch.dt.values[0] == TOY.default_dt(9.81)
    i_min = np.linalg.eigvalsh(TOY.inertia)[0]
    for damping, want in (
        (1e3 * i_min / TOY.default_dt(9.81), TOY.default_dt(9.81) / 1e3),
        (1e-3 * i_min / TOY.default_dt(9.81), TOY.default_dt(9.81)),
    ):
        dt = launch_inputs(TOY, damping=damping, t_end=T_END).flat["dt"][0]
        assert dt == pytest.approx(want, rel=1e-12)
    text = RATTLEBACK["dt"].default_text
    assert "damping" in text and "smallest principal moment of inertia" in text
    assert "damping" not in PLANAR  # nor in its default step's description
    assert "damping" not in PLANAR["dt"].default_text
    planar = rs.run_planar_batch(LAMINA, theta=0.1, t_end=T_END)
    for spec in PLANAR.values():
        if spec.in_results and isinstance(spec.default, float):
            np.testing.assert_array_equal(planar[spec.result_name].values, spec.default)
    assert planar.dt.values[0] == LAMINA.default_dt(9.81)


def _launch(model, name, value):
    """The keyword arguments of a launch with input ``name`` set to ``value``."""
    kwargs = {"t_end": T_END} if model == "rattleback" else {"theta": 0.1, "t_end": T_END}
    kwargs[name] = value
    if name == "dt":
        kwargs["t_end"] = 1.0  # so that the accepted small step is at most t_end
    return kwargs


def _ruled(inputs):
    return [
        (s.name, s)
        for s in inputs.values()
        if s.rule is not None and s.group not in ("body", "run")
    ]


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("name,spec", _ruled(RATTLEBACK))
def test_a_batch_obeys_each_rattleback_rule(name, spec):
    good, bad = EDGES[id(spec.rule)]
    max_steps(TOY, **_launch("rattleback", name, good))  # every check, no kernel
    if spec.launch_state and not np.all(np.isfinite(bad)):
        # a launch value: not refused but a status
        ds = rs.run_batch(TOY, **_launch("rattleback", name, bad))
        assert list(rs.decode(ds).status.values) == ["non_finite"]
        return
    with pytest.raises(ValueError, match=rf"^{name} {re.escape(spec.rule.message)}; got"):
        rs.run_batch(TOY, **_launch("rattleback", name, bad))
    with pytest.raises(ValueError, match=rf"^{name} {re.escape(spec.rule.message)}; got"):
        rs.simulate(TOY, **_launch("rattleback", name, bad))


@pytest.mark.parametrize("name,spec", _ruled(PLANAR))
def test_a_batch_obeys_each_planar_rule(name, spec):
    good, bad = EDGES[id(spec.rule)]
    prepare_planar(LAMINA, **_launch("planar", name, good))  # every check, no kernel
    for function in FUNCTIONS["planar"]:
        with pytest.raises(
            ValueError, match=rf"^{name} {re.escape(spec.rule.message)}; got"
        ):
            function(LAMINA, **_launch("planar", name, bad))


def test_both_models_check_an_input_as_given_before_broadcasting_it():
    # mu_roll (2, 1) against a launch input (3,): the bad value is at (1, 0) as given,
    # at 3 in the flattened (2, 3) broadcast
    mu_roll = [[0.0], [-1.0]]
    rule = re.escape(NONNEG.message)
    with pytest.raises(ValueError, match=rf"^mu_roll {rule}; got -1.0 at index \(1, 0\)$"):
        launch_inputs(TOY, spin=[1.0, 2.0, 3.0], mu_roll=mu_roll, t_end=T_END)
    with pytest.raises(ValueError, match=rf"^mu_roll {rule}; got -1.0 at index \(1, 0\)$"):
        prepare_planar(LAMINA, theta=[0.1, 0.2, 0.3], mu_roll=mu_roll, t_end=T_END)


def test_a_run_setting_obeys_its_rule():
    spec = RATTLEBACK["reversal_band"]
    good, bad = EDGES[id(spec.rule)]
    max_steps(TOY, t_end=T_END)
    assert rs.run_batch(TOY, t_end=T_END, reversal_band=good).attrs["reversal_band"] == good
    with pytest.raises(ValueError, match=rf"^reversal_band {re.escape(spec.rule.message)}"):
        rs.run_batch(TOY, t_end=T_END, reversal_band=bad)


@pytest.mark.parametrize("name", [s.name for s in RATTLEBACK.values() if s.sweep])
def test_a_sweep_obeys_each_rule(name):
    spec = RATTLEBACK[name]
    good, bad = EDGES[id(spec.rule)]
    if spec.group == "body":  # a semi-ellipsoid that stands, given by its parameters
        fixed = {"a": 0.06, "b": 0.01, "c": 0.01, "mass": 0.02, "delta": good}
    else:
        fixed = {name: good}
    fixed = {"t_end": 1.0, **fixed}
    axes = {"g": [9.8]} if name != "g" else {"mu": [0.5]}
    rs.Sweep(axes=axes, fixed=fixed)
    with pytest.raises(ValueError, match=rf"{name} {re.escape(spec.rule.message)}; got"):
        rs.Sweep(axes=axes, fixed={**fixed, name: bad})
    with pytest.raises(ValueError, match=rf"{name} {re.escape(spec.rule.message)}; got"):
        rs.Sweep(
            axes={**axes, name: [fixed[name], bad]},
            fixed={k: v for k, v in fixed.items() if k != name},
        )
