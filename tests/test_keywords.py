"""The public entry points take the per-launch inputs the descriptions name
(rattlesweep.inputs), and nothing else names them: an input added to a description is
taken by run_batch, simulate, the planar functions, a sweep (as an axis), the command
line and the explorer, is documented in their signatures and docstrings, and is carried
into results, with no other edit. An unknown name is refused before anything runs."""

import argparse
import inspect
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import rattlesweep as rs
from rattlesweep._keywords import accepted, per_launch
from rattlesweep.cli import build_parser
from rattlesweep.explore import settings
from rattlesweep.inputs import PLANAR, RATTLEBACK
from rattlesweep.sweep._config.params import PARAMS

SRC = str(Path(rs.__file__).resolve().parents[1])
TOY = rs.Body.preset("toy")
LAMINA = rs.PlanarBody(0.10, 0.05, 1.0)

FUNCTIONS = [
    (rs.run_batch, RATTLEBACK, {"t_end": 0.02}, TOY),
    (rs.simulate, RATTLEBACK, {"t_end": 0.02}, TOY),
    (rs.run_planar_batch, PLANAR, {"theta": 0.1, "t_end": 0.02}, LAMINA),
    (rs.simulate_planar, PLANAR, {"theta": 0.1, "t_end": 0.02}, LAMINA),
]
IDS = [f[0].__name__ for f in FUNCTIONS]

NEW_INPUT = """
    import dataclasses, math, sys
    import rattlesweep.inputs as inputs

    # a made-up friction input, described as any other, in both models' descriptions
    new = dataclasses.replace(
        inputs.RATTLEBACK["mu_roll"],
        name="mu_air",
        units="N m s",
        long_name="air drag coefficient",
        doc="Air drag: a couple -mu_air omega.",
        details="",
    )
    for table in (inputs.RATTLEBACK, inputs.PLANAR, inputs.INPUTS):
        table["mu_air"] = new

    import inspect
    import xarray as xr
    import rattlesweep as rs
    from rattlesweep.cli import main
    from rattlesweep.explore.caps import Caps
    from rattlesweep.explore.settings import defaults, run_spec

    toy = rs.Body.preset("toy")
    lamina = rs.PlanarBody(0.10, 0.05, 1.0)
    attrs = {"units": "N m s", "long_name": "air drag coefficient"}
    for function in (rs.run_batch, rs.simulate, rs.run_planar_batch, rs.simulate_planar):
        assert "mu_air" in inspect.signature(function).parameters, function
        assert "mu_air : " in function.__doc__, function
    batch = rs.run_batch(toy, spin=5.0, mu_air=[0.0, 0.25], t_end=0.02)
    assert batch.mu_air.values.tolist() == [0.0, 0.25]
    assert {k: batch.mu_air.attrs[k] for k in attrs} == attrs
    assert rs.run_batch(toy, t_end=0.02).mu_air.values.tolist() == [0.0]  # its default
    run = rs.simulate(toy, spin=5.0, mu_air=0.25, t_end=0.02)
    assert run.attrs["mu_air"] == 0.25 and run.attrs["mu_air_units"] == "N m s"
    planar = rs.run_planar_batch(lamina, theta=0.1, mu_air=[0.0, 0.25], t_end=0.02)
    assert planar.mu_air.values.tolist() == [0.0, 0.25]
    assert rs.simulate_planar(lamina, theta=0.1, mu_air=0.25, t_end=0.02).attrs[
        "mu_air"
    ] == 0.25
    sweep = rs.Sweep(axes={"mu_air": [0.0, 0.25]}, fixed={"t_end": 0.02, "spin": 5.0})
    mapped = rs.run_sweep(sweep, sys.argv[1] + "/sweep", workers=1, progress=False)
    assert mapped.mu_air.values.tolist() == [0.0, 0.25]
    assert {k: mapped.mu_air.attrs[k] for k in attrs} == attrs
    out = sys.argv[1] + "/one.nc"
    assert main(["simulate", "--mu-air", "0.25", "--t-end", "0.02", "--out", out]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["mu_air"] == 0.25
    run_spec(defaults(), Caps())  # the explorer's runs take the input's default
    print("taken everywhere")
"""


def test_a_new_input_needs_only_its_description(tmp_path):
    """The count of the issue: an input added to the descriptions (here at run time, in
    a fresh interpreter, before the package's other modules load) is taken by every
    entry point, swept, offered by the command line, and carried into every result with
    its units and long name. The kernel packs a parameter row by the input's name: a row
    and its physics are the kernel's part, and without one the input is carried and not
    read."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([SRC, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(NEW_INPUT), str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.splitlines()[-1] == "taken everywhere"


@pytest.mark.parametrize("function,inputs,required,body", FUNCTIONS, ids=IDS)
def test_an_unknown_input_is_refused_before_anything_runs(
    function, inputs, required, body, monkeypatch
):
    import rattlesweep._run as run

    def no_run(*args, **kwargs):
        raise AssertionError("the kernel ran")

    for module in (
        "rattlesweep.rattleback.batch",
        "rattlesweep.rattleback.simulate",
        "rattlesweep.planar.batch",
        "rattlesweep.planar.simulate",
    ):
        monkeypatch.setattr(sys.modules[module], "execute", no_run)
    monkeypatch.setattr(run, "execute", no_run)
    with pytest.raises(TypeError) as refused:
        function(body, mu_rol=0.1, **required)
    message = str(refused.value)
    assert f"{function.__name__}() got an unknown keyword 'mu_rol'" in message
    assert "(did you mean 'mu_roll'?)" in message
    inputs_list, options = (
        ", ".join(accepted(inputs)),
        ", ".join(_options(function, inputs)),
    )
    assert message.endswith(f"its inputs are {inputs_list}; its options are {options}")


def _options(function, inputs):
    """The keyword-only parameters of a public function that are not inputs."""
    return [
        p.name
        for p in inspect.signature(function).parameters.values()
        if p.kind is p.KEYWORD_ONLY and p.name not in accepted(inputs)
    ]


@pytest.mark.parametrize("function,inputs,required,body", FUNCTIONS, ids=IDS)
def test_a_misspelt_option_is_refused_with_the_option_it_meant(
    function, inputs, required, body
):
    assert {"method", "record_every"} <= set(_options(function, inputs))
    with pytest.raises(TypeError) as refused:
        function(body, metod="rk4", **required)
    message = str(refused.value)
    assert f"{function.__name__}() got an unknown keyword 'metod'" in message
    assert "(did you mean 'method'?)" in message
    assert f"; its options are {', '.join(_options(function, inputs))}" in message


def test_a_body_parameter_given_to_a_launch_says_it_belongs_to_the_body():
    # delta_deg to simulate was answered with "did you mean 'yaw_deg'?"
    for key in ("delta_deg", "mass"):
        with pytest.raises(TypeError) as refused:
            rs.simulate(rs.Body.preset("toy"), t_end=0.1, **{key: 3.0})
        assert (
            f"simulate() got an unknown keyword {key!r} (it describes the body: give it "
            "where the body is made)" in str(refused.value)
        )


@pytest.mark.parametrize("function,inputs,required,body", FUNCTIONS, ids=IDS)
def test_a_missing_required_input_is_a_type_error_and_none_a_value_error(
    function, inputs, required, body
):
    for name in required:
        given = {k: v for k, v in required.items() if k != name}
        units = inputs[name].units
        with pytest.raises(TypeError, match=rf"^{name} \({units}\) is required$"):
            function(body, **given)
        # given as None: a value the input cannot take, as before the descriptions
        with pytest.raises(ValueError, match=rf"^{name} \({units}\) is required$"):
            function(body, **given, **{name: None})


def _entry(doc, name):
    """The text of a parameter's entry in a numpydoc docstring, on one line."""
    lines = doc.split(f"\n    {name} : ", 1)[1].splitlines()[1:]
    body = []
    for line in lines:
        if not line.startswith(" " * 8):
            break
        body.append(line.strip())
    return " ".join(body)


@pytest.mark.parametrize("function,inputs,required,body", FUNCTIONS, ids=IDS)
def test_the_docstrings_show_every_input_with_units_rule_and_default(
    function, inputs, required, body
):
    doc = function.__doc__
    for name in accepted(inputs):
        assert f"\n    {name} : " in doc, (function.__name__, name)
    for name, spec in per_launch(inputs).items():
        text = _entry(doc, name)
        assert text.startswith(spec.doc), (name, text)
        if spec.units != "1":
            assert f"Units: {spec.units}." in text, (name, text)
        if spec.rule is not None:
            assert "Rule: " in text, (name, text)
        assert ("Required." if spec.required else "Default: ") in text, (name, text)


def test_the_command_line_offers_each_launch_input_with_a_default():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    simulate = sub.choices["simulate"]
    options = {o for a in simulate._actions for o in a.option_strings}
    offered = [
        spec
        for spec in per_launch(RATTLEBACK).values()
        if spec.required or spec.default is not None or spec.default_doc
    ]
    assert {s.name for s in offered} >= {"spin", "roll", "velocity", "mu_roll", "t_end"}
    for spec in offered:
        key = f"{spec.name}_deg" if spec.result_units == "degree" else spec.name
        assert f"--{key.replace('_', '-')}" in options, spec.name


def test_the_explorer_shows_only_described_inputs():
    """The page's controls, labels, units and map axes are its own choice, keyed by the
    descriptions' names: each is a described input (a map axis a sweepable one)."""
    numeric = [c for c in settings.CONTROLS if c not in ("preset", "masses")]
    for control in numeric:
        name = control.removesuffix("_deg")
        assert name in RATTLEBACK, control
        if control != name:
            assert RATTLEBACK[name].result_units == "degree", control
    assert set(settings.UNITS) == set(settings.LABELS) == set(numeric)
    for axis in settings.MAP_AXES:
        assert axis in numeric and axis.removesuffix("_deg") in PARAMS, axis
    assert set(settings._RANGES) <= set(settings.MAP_AXES)
    assert set(settings.LAUNCH) == {
        c for c in numeric if c.removesuffix("_deg") in per_launch(RATTLEBACK)
    }


def test_an_option_without_a_description_is_refused():
    from rattlesweep._keywords import document

    def run(body, *, colour=None, **inputs):
        """{inputs}"""

    with pytest.raises(
        TypeError, match=r"run: the options \['colour'\] have no description"
    ):
        document(RATTLEBACK)(run)
