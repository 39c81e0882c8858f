"""Contact kinematics of a run, the friction impulses the kernel records, the run
pictures (time-series panels, contact paths) and the animation."""

import math

import numpy as np
import pytest
from matplotlib.collections import PolyCollection

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.rattleback.contact import contact_dataset
from rattlesweep.planar import PlanarBody, simulate_planar
from rattlesweep.plot import animate, contact_path, time_series

from conftest import HALF_DEGREE


@pytest.fixture(scope="module")
def slipping_run(kl):
    """The fast sense of kane_levinson at mu = 0.3: it slips, re-sticks and reverses."""
    return rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, mu=0.3, t_end=6.0)


def _momentum_balance_error(body, dt, mu, t_end=5.0):
    """max |∫ friction couple dt + Σ impulse couples − ΔL_z| over a fully recorded run,
    relative to max |ΔL_z|."""
    run = rs.simulate(
        body, spin=5.0, roll=HALF_DEGREE, mu=mu, t_end=t_end, dt=dt, record_every=1
    )
    c = contact_dataset(run)
    f = c.friction_couple.values
    t = c.time.values
    moment = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])
    moment += np.cumsum(c.impulse_couple.values)
    change = c.angular_momentum_z.values - c.angular_momentum_z.values[0]
    return np.abs(moment - change).max() / np.abs(change).max()


def test_contact_point_is_on_the_surface_and_on_the_floor(slipping_run):
    c = contact_dataset(slipping_run)
    a, b, cc = (slipping_run.attrs[k] for k in ("a", "b", "c"))
    x, y, z = c.contact_body.transpose("body_axis", "time").values
    np.testing.assert_allclose(x**2 / a**2 + y**2 / b**2 + z**2 / cc**2, 1.0, atol=1e-12)
    assert (z < 0).all()
    # G's recorded height plus the lever's vertical part puts the point on Z = 0
    height = slipping_run.position.sel(axis="Z").values + c.lever.sel(axis="Z").values
    assert np.abs(height).max() < 1e-12
    # it wanders over the body (up to ~50 mm along x for this pitching launch)
    assert np.ptp(x) > 0.02


def test_recorded_contact_point_is_the_one_post_processing_finds(slipping_run):
    # the kernel's series against contact_dataset's, computed independently in NumPy
    # from the recorded quaternion and position
    c = contact_dataset(slipping_run)
    recorded = slipping_run.contact_point.transpose("time", "horizontal").values
    np.testing.assert_allclose(
        recorded, c.contact_floor.transpose("time", "horizontal").values, rtol=0, atol=1e-12
    )
    assert np.ptp(recorded[:, 0]) > 0.01  # it moves: the check is not of constants
    assert slipping_run.contact_point.attrs["units"] == "m"


def test_friction_moment_accounts_for_the_vertical_angular_momentum(kl):
    """Without damping friction is the only vertical moment about G. Rolling: the
    trapezoid sum of the couple converges to ΔL_z at second order. Slipping: the
    3-D switching is at least first order in dt, and the recorded re-stick impulses are
    part of the balance (leaving them out doubles the error)."""
    dt = kl.default_dt(9.81)
    rolling = [_momentum_balance_error(kl, dt / k, math.inf) for k in (1, 2)]
    assert rolling[0] < 2e-3
    assert 3.0 < rolling[0] / rolling[1] < 5.0
    slipping = [_momentum_balance_error(kl, dt / k, 0.3) for k in (2, 4)]
    assert slipping[1] < 0.03
    assert slipping[0] / slipping[1] > 1.5


def test_friction_impulses_are_recorded_whatever_the_stride(kl):
    runs = [
        rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, mu=0.3, t_end=4.0, record_every=k)
        for k in (1, 7)
    ]
    fine, coarse = (r.friction_impulse.values for r in runs)
    assert np.count_nonzero(np.abs(fine).sum(axis=1)) > 10  # this launch re-sticks often
    # sums over each coarse sample's window of fine steps ((k-1)*7, k*7]
    n = coarse.shape[0]
    windows = np.add.reduceat(fine[1 : 7 * (n - 1) + 1], np.arange(0, 7 * (n - 1), 7))
    np.testing.assert_allclose(coarse[1:], windows, rtol=1e-12, atol=1e-15)
    rolling = rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, t_end=2.0)
    assert (rolling.friction_impulse.values == 0).all()


def test_time_series_panels_have_units_and_shade_slipping(slipping_run):
    fig = time_series(slipping_run)
    axes = fig.axes
    assert len(axes) == 6
    for ax, units in zip(axes, ["[rad/s]", "[rad]", "[rad]", "[J]", "[m/s]", "[N]"]):
        assert units in ax.get_ylabel().replace("\n", " ")
        assert any(isinstance(a, PolyCollection) for a in ax.collections)  # shading
    assert axes[-1].get_xlabel() == "time [s]"
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["slipping", "sticking"]


def test_time_series_of_a_rolling_run_has_no_shading_and_picks_variables(kl):
    run = rs.simulate(kl, spin=-5.0, roll=HALF_DEGREE, t_end=1.0)
    fig = time_series(
        run.merge(contact_dataset(run)), ["spin", "friction_force", "friction_couple"]
    )
    assert not any(ax.collections for ax in fig.axes)
    assert "[N m]" in fig.axes[2].get_ylabel().replace("\n", " ")
    assert [t.get_text() for t in fig.axes[1].get_legend().get_texts()] == ["X", "Y"]
    with pytest.raises(ValueError, match="'nope' is not a series"):
        time_series(run, ["spin", "nope"])
    with pytest.raises(ValueError, match="an xarray.Dataset over 'time'"):
        time_series(run.spin)


def test_time_series_of_the_planar_model():
    run = simulate_planar(PlanarBody(0.10, 0.05, 1.0), theta=0.6, mu=0.2, t_end=2.0)
    fig = time_series(run)
    labels = [ax.get_ylabel().replace("\n", " ") for ax in fig.axes]
    assert len(labels) == 5
    assert "[rad]" in labels[0] and "[rad/s]" in labels[1] and "[N]" in labels[4]


def test_contact_path_panels(kl, slipping_run):
    other = rs.simulate(kl, spin=-5.0, roll=HALF_DEGREE, mu=0.3, t_end=6.0)
    fig = contact_path([slipping_run, other], ["+5 rad/s", "-5 rad/s"])
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert [ax.get_title() for ax in panels] == ["+5 rad/s", "-5 rad/s"]
    assert panels[0].get_xlabel() == "contact point, body x [mm]"
    assert panels[0].get_ylabel() == "contact point, body y [mm]"
    assert fig.axes[-1].get_ylabel() == "time [s]"  # the colour bar
    floor = contact_path(slipping_run, frame="floor")
    assert floor.axes[0].get_xlabel() == "contact point, floor X [mm]"
    with pytest.raises(ValueError, match="frame must be 'body' or 'floor'"):
        contact_path(slipping_run, frame="world")
    with pytest.raises(ValueError, match="labels has 1 entries for 2 runs"):
        contact_path([slipping_run, other], ["one"])


def test_animation_has_the_requested_frames(tmp_path, slipping_run):
    from PIL import Image

    out = animate(slipping_run, tmp_path / "run.gif", frames=7, fps=5)
    with Image.open(out) as gif:
        assert gif.n_frames == 7
        assert gif.info["duration"] == 200  # ms per frame at 5 fps
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.gif"]  # no temp file left


def test_animation_refuses_bad_requests(tmp_path, slipping_run):
    n = slipping_run.sizes["time"]
    with pytest.raises(
        ValueError, match=f"frames must be an integer from 1 to the run's {n}"
    ):
        animate(slipping_run, tmp_path / "a.gif", frames=n + 1)
    with pytest.raises(ValueError, match="suffix must be one of"):
        animate(slipping_run, tmp_path / "a.avi")
    with pytest.raises(ValueError, match="fps must be > 0"):
        animate(slipping_run, tmp_path / "a.gif", fps=0)
    with pytest.raises(ValueError, match="z_stretch must be"):
        animate(slipping_run, tmp_path / "a.gif", z_stretch=0.5)
    with pytest.raises(ValueError, match="does not exist"):
        animate(slipping_run, tmp_path / "missing" / "a.gif")
    with pytest.raises(ValueError, match="run has no variable 'quaternion'"):
        animate(slipping_run.drop_vars("quaternion"), tmp_path / "a.gif")
    assert not any(tmp_path.iterdir())


def test_cli_animate_from_options_and_from_a_file(tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "spin.gif"
    assert (
        main(
            ["animate", "--spin", "-3", "--t-end", "1", "--frames", "4", "--out", str(gif)]
        )
        == 0
    )
    with Image.open(gif) as im:
        assert im.n_frames == 4
    nc = tmp_path / "run.nc"
    assert main(["simulate", "--t-end", "0.5", "--out", str(nc)]) == 0
    assert (
        main(
            [
                "animate",
                "--run",
                str(nc),
                "--frames",
                "3",
                "--out",
                str(tmp_path / "file.gif"),
            ]
        )
        == 0
    )
    assert "3 frames" in capsys.readouterr().out
    assert main(["animate", "--run", str(nc), "--out", str(tmp_path / "x.webm")]) == 2
    assert "suffix must be one of" in capsys.readouterr().err


def test_a_map_over_mu_with_rolling_among_the_values(tmp_path):
    """mu = [0.1, 0.3, inf] as an axis (the TOML reference's own example): the map draws
    one row per value, the rolling one labelled as infinity, from Python and from the
    command line."""
    from rattlesweep.plot import reversal_map
    from rattlesweep.sweep import Sweep, run_sweep

    s = Sweep(
        axes={"spin": {"start": -15, "stop": 15, "num": 5}, "mu": [0.1, 0.3, math.inf]},
        fixed={"t_end": 1.0, "roll_deg": 0.5},
    )
    ds = run_sweep(s, tmp_path / "mu", progress=False)
    fig = reversal_map(ds, x="launch_spin", y="mu")
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert labels == ["0.1", "0.3", "∞"]
    assert (
        main(
            ["plot", str(tmp_path / "mu" / "sweep.nc"), "--out", str(tmp_path / "map.png")]
        )
        == 0
    )
    assert (tmp_path / "map.png").stat().st_size > 0


def test_a_map_names_a_selected_value_that_is_not_on_its_axis():
    """A body not on the body axis raised pandas' KeyError; a word for a number, numpy's
    'could not convert string to float'."""
    import xarray as xr

    from rattlesweep.plot import reversal_map

    ds = xr.Dataset(
        {"first_reversal_time": (("body", "x", "y"), np.ones((2, 2, 2)))},
        coords={"body": ["toy", "kane_levinson"], "x": [0.0, 1.0], "y": [0.0, 1.0]},
    )
    with pytest.raises(ValueError, match=r"select: 'toyy' is not a value of body "):
        reversal_map(ds, x="x", y="y", var="first_reversal_time", select={"body": "toyy"})
    ds = ds.rename(body="mu").assign_coords(mu=[0.3, math.inf])
    with pytest.raises(ValueError, match="select: mu takes a number, got 'abc'"):
        reversal_map(ds, x="x", y="y", var="first_reversal_time", select={"mu": "abc"})
    fig = reversal_map(ds, x="x", y="y", var="first_reversal_time", select={"mu": 0.31})
    assert fig.axes  # a number near a value still selects it


def test_predicted_against_simulated_needs_shared_grid_points():
    """Grids with no point in common were reported as 'no grid point both reversed in
    the sweep and is unstable', blaming the physics."""
    import xarray as xr

    from rattlesweep.plot import reversal_vs_growth

    stability = xr.Dataset({"e_folding_time": ("launch_spin", [1.0, 2.0])})
    stability = stability.assign_coords(launch_spin=[1.0, 2.0])
    sweep = xr.Dataset({"first_reversal_time": ("launch_spin", [1.0, 2.0])})
    with pytest.raises(
        ValueError, match="no grid point: no value of launch_spin is in both"
    ):
        reversal_vs_growth(stability, sweep.assign_coords(launch_spin=[3.0, 4.0]))
    with pytest.raises(ValueError, match="the stability result has no e_folding_time"):
        reversal_vs_growth(sweep, sweep)
    assert reversal_vs_growth(stability, sweep.assign_coords(launch_spin=[1.0, 2.0])).axes


def test_a_map_title_names_the_values_shown_the_selected_first(tmp_path):
    """A map of a slice did not say which (mu = 0.3 of two), and a store's
    alphabetical coordinates pushed the configuration's t_end and roll out of the title's
    first six values."""
    import xarray as xr

    from rattlesweep.plot import reversal_map
    from rattlesweep.sweep import Sweep, run_sweep

    s = Sweep(
        axes={"spin": [-10.0, 10.0], "delta_deg": [-3.0, 3.0], "mu": [0.3, math.inf]},
        fixed={"t_end": 0.5, "roll_deg": 0.5},
    )
    ds = run_sweep(s, tmp_path / "o", progress=False)
    ds = xr.Dataset(ds.data_vars, coords=dict(sorted(ds.coords.items())), attrs=ds.attrs)
    fig = reversal_map(ds, x="launch_spin", y="delta_deg", select={"mu": 0.3})
    assert fig.get_suptitle().startswith("μ = 0.3, t_end = 0.5 s, roll = 0.5°")
