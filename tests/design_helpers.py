"""What the design tests (test_design.py, test_design_trial.py) share: the example
shell, the Part a design.toml describes, and launches the search never made."""

import contextlib
import io

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.design import Coin, Material, Part, PrintSettings

SHELL = (0.07, 0.02, 0.018)  # m: 140 x 40 x 18 mm


def design_help():
    """What ``rattlesweep design --help`` prints."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as done:
        main(["design", "--help"])
    assert done.value.code == 0
    return out.getvalue()


def part_from(doc):
    """The Part that a design.toml describes, rebuilt from its tables."""
    shell, coin, pr = doc["shell"], doc["coins"], doc["print"]
    settings = PrintSettings(
        Material(pr["material"], pr["density"], pr["density_source"]),
        pr["infill"],
        pr["wall"],
        pr["clearance"],
        pr["rim"],
    )
    the_coin = Coin(
        coin["name"],
        coin["mass"],
        coin["diameter"],
        coin["thickness"],
        coin["inner_diameter"],
        coin["source"],
    )
    (x, y, _), (x2, y2, _) = coin["centres"]
    assert (x2, y2) == (-x, -y)
    return Part(shell["a"], shell["b"], shell["c"], the_coin, x, y, settings)


def launches():
    """Launches as a person makes them, none of them the search's: spins 3-10 rad/s,
    tilts below 1 degree, friction over 0.2-0.5 (its ends included)."""
    rng = np.random.default_rng(33)
    n = 24
    spin = rng.uniform(3.0, 10.0, n)
    tilt = np.radians(rng.uniform(0.05, 0.95, n))
    heading = rng.uniform(0, 2 * np.pi, n)
    mu = np.concatenate([[0.2, 0.5, 0.2, 0.5], rng.uniform(0.2, 0.5, n - 4)])
    return spin, tilt * np.cos(heading), tilt * np.sin(heading), mu


def reversals(body, sign):
    """First reversal times (s, NaN for none within 15 s) of launches spun with sign."""
    spin, roll, pitch, mu = launches()
    ds = rs.run_batch(
        body,
        spin=sign * spin,
        roll=roll,
        pitch=pitch,
        mu=mu,
        t_end=15.0,
        stop="first_reversal",
    )
    assert (ds.status.values == 0).all()
    return ds.first_reversal_time.values
