"""Poincaré sections and maps of the Lyapunov exponent."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import stability as st
from rattlesweep.plot import lyapunov_map, poincare_plot
from rattlesweep.plot.chaos import LYAPUNOV_ZERO

from figure_checks import layout_problems

ALIGNED = rs.Body.semi_ellipsoid(0.05, 0.01, 0.01, 0.01, 0.0)  # no misalignment


def test_periodic_rocking_crosses_its_section_at_one_point_once_a_period():
    """Small rolling about the long axis of an aligned body is a normal mode, periodic
    at the linear roll frequency: the roll rate's upward zero crossings come once a
    period, each at the same state (the roll at its most negative)."""
    roll = math.radians(0.3)
    run = rs.simulate(ALIGNED, roll=roll, t_end=4.0, record_every=1)
    section = rs.poincare_section(run, "omega_x", direction="up")
    period = 2 * math.pi / float(st.zero_spin_frequencies(ALIGNED)[1])
    assert section.sizes["crossing"] == pytest.approx(4.0 / period, abs=1)
    np.testing.assert_allclose(np.diff(section["crossing_time"]), period, rtol=1e-3)
    np.testing.assert_allclose(section["gamma_y"], -math.sin(roll), rtol=1e-3)
    np.testing.assert_allclose(section["omega_x"], 0.0, atol=1e-12)
    assert section.attrs["section"] == "omega_x = 0 rad s-1, crossed upward"
    both = rs.poincare_section(run, "omega_x", direction="both")
    assert both.sizes["crossing"] == pytest.approx(2 * section.sizes["crossing"], abs=1)
    fig = poincare_plot(section, "gamma_x", "gamma_y")
    assert layout_problems(fig) == []


def test_a_section_says_what_it_cannot_show():
    """A plane the run never crosses gives an empty section and says the range it
    spanned; a coarse record says it blurs the section; a level must be a number."""
    run = rs.simulate(ALIGNED, roll_deg=0.3, t_end=0.5, record_every=5)
    with pytest.warns(
        RuntimeWarning, match="never crosses energy = 0 J upward: energy spans"
    ):
        empty = rs.poincare_section(run, "energy")
    assert empty.sizes["crossing"] == 0
    with pytest.warns(RuntimeWarning, match="records every 5th step"):
        coarse = rs.poincare_section(run, "gamma_y")
    assert coarse.attrs["section"] == "gamma_y = 0, crossed upward"
    with pytest.raises(ValueError, match="level must be a finite number"):
        rs.poincare_section(run, level=float("nan"))


def test_a_section_names_its_choices():
    run = rs.simulate(ALIGNED, roll_deg=0.3, t_end=0.2)
    with pytest.raises(ValueError, match="plane must be one of .*'tilt_rate'"):
        rs.poincare_section(run, "tilt_speed")
    with pytest.raises(ValueError, match="direction must be"):
        rs.poincare_section(run, direction="upward")
    with pytest.raises(ValueError, match="result of rattlesweep.simulate"):
        rs.poincare_section(run.drop_vars("quaternion"))
    with pytest.raises(ValueError, match="'spin_rate' is not a variable of the section"):
        poincare_plot(rs.poincare_section(run), "spin_rate", "tilt")


@pytest.fixture(scope="module")
def chaos_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("chaos") / "out"
    sweep = rs.Sweep(
        axes={
            "spin": {"start": -20, "stop": 20, "num": 9},
            "delta_deg": {"start": -6, "stop": 6, "num": 5},
        },
        fixed={"t_end": 2.0, "roll_deg": 0.5},
        lyapunov=True,
    )
    return rs.run_sweep(sweep, out, progress=False), out


def test_a_lyapunov_map_centres_its_colours_and_shows_the_stability(chaos_sweep):
    ds, _ = chaos_sweep
    stability = st.stability_dataset(ds.attrs["sweep_config"])
    fig = lyapunov_map(ds, "launch_spin", "delta_deg", stability=stability)
    mesh = fig.axes[0].collections[0]
    assert mesh.norm.vmin == -mesh.norm.vmax > -np.inf
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any(label.startswith("exponent > 0") for label in labels)
    assert any(label.startswith("exponent near 0") for label in labels)
    assert "linear stability boundary" in labels
    assert LYAPUNOV_ZERO in labels or float(ds.lyapunov.min()) > 0
    hatched = [c for c in fig.axes[0].collections if c.get_hatch() == "//"]
    assert hatched  # the toy's upright spin is unstable over part of the map
    assert layout_problems(fig) == []
    # unstable everywhere: every cell hatched to its edges, and no boundary to list
    everywhere = stability.assign(growth_rate=abs(stability.growth_rate) + 1.0)
    fig = lyapunov_map(ds, "launch_spin", "delta_deg", stability=everywhere)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "linear stability boundary" not in labels
    assert "hatched: steady upright spin linearly unstable" in labels
    (hatch,) = [c for c in fig.axes[0].collections if c.get_hatch() == "//"]
    corners = np.concatenate([p.vertices for p in hatch.get_paths()])
    spins, deltas = ds.launch_spin.values, ds.delta_deg.values
    assert corners[:, 0].min() == pytest.approx(spins[0] - (spins[1] - spins[0]) / 2)
    assert corners[:, 1].max() == pytest.approx(deltas[-1] + (deltas[1] - deltas[0]) / 2)
    bar = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"][0]
    assert bar.get_ylabel() == "largest finite-time Lyapunov exponent [1/s]"


def test_the_command_line_draws_a_lyapunov_map(chaos_sweep, tmp_path, capsys):
    from rattlesweep.cli import main

    _, out = chaos_sweep
    png = tmp_path / "map.png"
    assert main(["plot", str(out), "--var", "lyapunov", "--out", str(png)]) == 0
    assert png.stat().st_size > 10_000
    assert "not drawn" not in capsys.readouterr().out


def test_a_map_without_exponents_says_how_to_get_them():
    ds = rs.Sweep(axes={"spin": [1.0, 2.0], "delta_deg": [1.0, 2.0]}, fixed={})
    with pytest.raises(ValueError, match="lyapunov = true"):
        lyapunov_map(st.stability_dataset(ds), "launch_spin", "delta_deg")


def test_the_stability_boundary_runs_only_where_unstable_meets_stable():
    """Neutral cells (growth 0: no misalignment, no spin) meet neither side: the
    boundary runs along cell edges between unstable and stable cells only."""
    from rattlesweep.plot.chaos import _boundary

    growth = np.array(
        [
            [1.0, 1.0, -1.0],
            [0.0, 0.0, 0.0],  # a neutral row between two unstable ones
            [2.0, 1.0, 0.5],
        ]
    )
    across, along = _boundary(growth)
    assert across.tolist() == [[False, True], [False, False], [False, False]]
    assert not along.any()
