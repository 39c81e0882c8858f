"""The command line's first impressions: ``--version``, the defaults in every ``--help``,
and ``simulate`` taking every launch and friction input and a body from a TOML table,
each checked against the Python call it stands for. Short runs (t_end <= 0.5 s)."""

import argparse
import math

import numpy as np
import pytest
import xarray as xr

import rattlesweep as rs
from rattlesweep.cli import build_parser, main

COINS = """\
[body]
name = "two coins"
a = 0.05
b = 0.01
c = 0.01
mass = 0.02
com = [0.0, 0.0, -0.004]
inertia = [[4e-7, 5e-8, 0.0], [5e-8, 1.4e-5, 0.0], [0.0, 0.0, 1.4e-5]]
"""


def _parsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [("rattlesweep", parser), *sub.choices.items()]


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"rattlesweep {rs.__version__}"


@pytest.mark.parametrize("name,parser", _parsers(), ids=[n for n, _ in _parsers()])
def test_every_help_shows_the_defaults(name, parser):
    text = " ".join(parser.format_help().split())
    formatter = parser._get_formatter()
    for action in parser._actions:
        if (
            not action.option_strings
            or action.required
            or action.default is False
            or isinstance(action, (argparse._HelpAction, argparse._VersionAction))
        ):
            continue  # positionals, required options, flags, --help
        shown = " ".join(formatter._format_action(action).split())
        assert "default" in shown, f"{name} {action.option_strings[0]}: {shown}"
        assert shown in text
    if name == "simulate":
        assert "--spin SPIN rad/s about the vertical" in text and "(default: 5.0)" in text


@pytest.mark.parametrize("name,parser", _parsers(), ids=[n for n, _ in _parsers()])
def test_no_command_takes_an_abbreviated_option(name, parser):
    assert not parser.allow_abbrev


@pytest.mark.parametrize("option", ["--roll", "--delta"])
def test_an_angle_without_its_units_suffix_is_refused_not_taken_as_degrees(option, capsys):
    # argparse took --roll 0.3 as --roll-deg 0.3: 0.3 degrees where radians were meant
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", option, "0.3", "--t-end", "0.1"])
    assert exit_.value.code == 2
    assert f"unrecognized arguments: {option} 0.3" in capsys.readouterr().err


def test_simulate_takes_every_launch_and_friction_input_and_a_body_file(tmp_path, capsys):
    (tmp_path / "coins.toml").write_text(COINS)
    out = tmp_path / "run.nc"
    dt = 2e-4
    rc = main(
        [
            "simulate",
            "--body",
            str(tmp_path / "coins.toml"),
            "--spin",
            "-3",
            "--roll-deg",
            "1",
            "--pitch-deg",
            "-0.5",
            "--yaw-deg",
            "30",
            "--velocity",
            "0.01",
            "-0.02",
            "--mu",
            "0.4",
            "--mu-static",
            "0.5",
            "--mu-spin",
            "1e-4",
            "--mu-roll",
            "2e-4",
            "--damping",
            "1e-7",
            "--g",
            "9.7",
            "--dt",
            str(dt),
            "--t-end",
            "0.3",
            "--method",
            "euler",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    assert "status: ok" in capsys.readouterr().out
    body = rs.Body(
        0.05,
        0.01,
        0.01,
        0.02,
        (0.0, 0.0, -0.004),
        [[4e-7, 5e-8, 0.0], [5e-8, 1.4e-5, 0.0], [0.0, 0.0, 1.4e-5]],
        name="two coins",
    )
    expected = rs.simulate(
        body,
        spin=-3.0,
        roll_deg=1.0,
        pitch_deg=-0.5,
        yaw_deg=30.0,
        velocity=(0.01, -0.02),
        mu=0.4,
        mu_static=0.5,
        mu_spin=1e-4,
        mu_roll=2e-4,
        damping=1e-7,
        g=9.7,
        dt=dt,
        t_end=0.3,
        method="euler",
    )
    with xr.open_dataset(out) as got:
        assert got.attrs["body_name"] == "two coins"
        for key in (
            "launch_spin",
            "roll_deg",
            "pitch_deg",
            "yaw_deg",
            "mu",
            "mu_static",
            "mu_spin",
            "mu_roll",
            "damping",
            "g",
            "dt",
            "t_end",
            "inertia_xy",
            "method",
        ):
            assert got.attrs[key] == expected.attrs[key], key
        np.testing.assert_array_equal(got.spin.values, expected.spin.values)
        np.testing.assert_array_equal(got.velocity.values, expected.velocity.values)


def test_simulate_a_semi_ellipsoid_from_its_misalignment(tmp_path):
    out = tmp_path / "run.nc"
    assert (
        main(
            [
                "simulate",
                "--delta-deg",
                "4",
                "--c",
                "0.012",
                "--t-end",
                "0.05",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    toy = rs.Body.preset("toy")
    body = rs.Body.semi_ellipsoid(toy.a, toy.b, 0.012, toy.mass, math.radians(4))
    with xr.open_dataset(out) as got:
        assert got.attrs["c"] == 0.012 and got.attrs["a"] == toy.a
        assert got.attrs["inertia_xy"] == pytest.approx(body.inertia[0, 1], rel=1e-12)


@pytest.mark.parametrize(
    "argv,message",
    [
        (
            ["--preset", "toy", "--delta-deg", "3"],
            "--preset and --a/--b/--c/--mass/--delta-deg",
        ),
        (["--body", "{coins}", "--preset", "toy"], "--preset and --body"),
        (["--body", "{bad}"], "body table lacks ['inertia']"),
        (["--body", "{empty}"], "has no [body] table"),
        (["--body", "{missing}"], "cannot read"),
    ],
)
def test_simulate_refuses_an_unclear_or_bad_body(tmp_path, capsys, argv, message):
    files = {
        "coins": COINS,
        "bad": COINS.replace("inertia", "# inertia"),
        "empty": "x = 1\n",
    }
    for name, text in files.items():
        (tmp_path / f"{name}.toml").write_text(text)
    argv = [
        a.format(**{k: str(tmp_path / f"{k}.toml") for k in [*files, "missing"]})
        for a in argv
    ]
    assert main(["simulate", *argv, "--t-end", "0.01"]) == 2
    err = capsys.readouterr().err
    assert message in err
    if not message.startswith("--"):  # a bad file: the message names it
        assert f"{tmp_path}/" in err and ".toml" in err


def test_the_top_help_speaks_to_users_and_a_mistyped_option_gets_a_suggestion(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "Simulate rattlebacks (celts) and map where their spin reverses" in out
    assert "parser" not in out.split("positional arguments")[0]
    for argv, hint in (
        (["simulate", "--roll", "0.5"], "--roll: did you mean --roll-deg? (angles on the"),
        (["simulate", "--spinn", "3"], "--spinn: did you mean --spin?"),
    ):
        with pytest.raises(SystemExit) as done:
            main(argv)
        assert done.value.code == 2 and hint in capsys.readouterr().err
