"""Public API: input validation, result metadata, files, command line."""

import math
import os
import warnings

import netCDF4
import numpy as np
import pytest
import xarray as xr

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.io import write_netcdf


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(mu=-0.1), r"mu must be >= 0.*-0\.1"),
        (dict(mu=float("nan")), "mu must be >= 0"),
        (dict(mu=0.5, mu_static=0.3), "mu_static must be >= mu"),
        (dict(damping=-1.0), "damping must be finite and >= 0"),
        (dict(g=0.0), "g must be finite and > 0"),
        (dict(dt=-1e-3), "dt must be finite and > 0"),
        (dict(t_end=[1.0, math.inf]), r"t_end must be finite and > 0.*index \(1,\)"),
        (dict(spin=1.0, omega=(0, 0, 1)), "either spin .* or omega"),
        (dict(orientation=(1, 0, 0, 0), roll=0.1), "either orientation or roll"),
        (dict(orientation=(1, 0, 0, 0), roll=[[0.1], [0.2, 0.3]]), "roll must be a number"),
        (dict(orientation=(1.0, 0.1, 0.0, 0.0)), "unit quaternion"),
        (dict(omega=(1.0, 2.0)), "omega must have a last axis of length 3"),
        (dict(spin=[1.0, 2.0], mu=[0.1, 0.2, 0.3]), "cannot be broadcast"),
        (dict(velocity=(0.1, 0.0)), "sliding launch.*finite mu_static"),
        (dict(method="rk45"), "method must be one of"),
        (dict(record_every=0), "record_every must be a positive integer"),
        (dict(reversal_band=1.5), "reversal_band must be in"),
        (dict(reversal_band="abc"), "reversal_band must be in"),
        (dict(reversal_band=None), "reversal_band must be in"),
        (dict(threads=0), "threads must be an integer"),
        (dict(t_end=None), "t_end"),
    ],
)
def test_bad_input_is_refused_with_a_clear_message(kl, kwargs, message):
    args = dict(spin=None, t_end=1.0)
    args.update(kwargs)
    if args["spin"] is None:
        del args["spin"]
    with pytest.raises(ValueError, match=message):
        rs.run_batch(kl, **args)


def test_tilt_past_the_rim_is_refused():
    toy = rs.Body.preset("toy")
    with (
        pytest.raises(ValueError, match="rim of the semi-ellipsoid"),
        pytest.warns(rs.UnitsWarning, match="roll_deg"),
    ):
        rs.simulate(toy, roll=math.radians(95), t_end=1.0)
    with pytest.raises(ValueError, match="rim of the semi-ellipsoid"):
        rs.simulate(toy, roll_deg=95, t_end=1.0)
    # a full ellipsoid has no rim
    ds = rs.simulate(rs.Body.preset("kane_levinson"), roll=math.radians(95), t_end=0.01)
    assert int(ds.status) == 0


def test_simulate_refuses_arrays_and_non_bodies(kl):
    with pytest.raises(ValueError, match="scalar for simulate"):
        rs.simulate(kl, spin=[1.0, 2.0], t_end=1.0)
    with pytest.raises(ValueError, match="body must be a Body"):
        rs.simulate("kane_levinson", t_end=1.0)
    with pytest.raises(ValueError, match="body must be a Body"):
        rs.run_batch(["kane_levinson"], t_end=1.0)


def test_results_carry_units_and_inputs(kl):
    ds = rs.simulate(kl, spin=5.0, roll=0.01, mu=0.3, t_end=0.2)
    for name, var in ds.variables.items():
        if name in ("horizontal", "quaternion_component", "body_axis", "axis"):
            continue
        assert "long_name" in var.attrs, name
        assert "units" in var.attrs or "flag_values" in var.attrs, name
    assert ds.spin.attrs["units"] == "rad s-1"
    assert ds.attrs["mu"] == 0.3 and ds.attrs["dt_units"] == "s"
    assert ds.attrs["rattlesweep_version"] == rs.__version__
    assert ds.attrs["dt"] == pytest.approx(kl.default_dt())
    batch = rs.run_batch(kl, spin=[1.0, 2.0], mu=0.3, t_end=0.1)
    assert (
        batch.mu.dims == ("trajectory",) and batch.launch_spin.attrs["units"] == "rad s-1"
    )
    assert batch.com.dims == ("trajectory", "body_axis")


def test_netcdf_round_trip_and_atomic_write(kl, tmp_path):
    ds = rs.simulate(kl, spin=5.0, roll=0.01, t_end=0.2)
    path = write_netcdf(ds, tmp_path / "sub" / "run.nc")
    assert sorted(os.listdir(path.parent)) == ["run.nc"]  # no temporary left behind
    back = xr.open_dataset(path)
    np.testing.assert_array_equal(back.spin.values, ds.spin.values)
    assert back.status.attrs["flag_meanings"] == "ok capsized lifted_off non_finite"
    with netCDF4.Dataset(path) as nc:
        assert nc.variables["spin"].units == "rad s-1"
        assert nc.variables["spin"].filters()["zlib"]
    batch = rs.run_batch(
        np.array([kl, rs.Body.preset("toy")], dtype=object), spin=3.0, t_end=0.1
    )
    back = xr.open_dataset(write_netcdf(batch, tmp_path / "batch.nc"))
    assert list(back.body_name.values) == ["kane_levinson", "toy"]


def test_failed_write_leaves_no_file(kl, tmp_path):
    ds = rs.simulate(kl, spin=5.0, t_end=0.05)
    ds.attrs["bad"] = {"not": "serialisable"}
    with pytest.raises(Exception):
        write_netcdf(ds, tmp_path / "run.nc")
    assert os.listdir(tmp_path) == []


def test_cli_simulate_writes_netcdf_and_png(tmp_path, capsys):
    # kane_levinson with its air damping: the +5 rad/s launch reverses, -5 rad/s does not
    base = ["simulate", "--t-end", "8", "--damping", "1e-4"]
    assert (
        main(
            base
            + [
                "--spin",
                "5",
                "--out",
                str(tmp_path / "p.nc"),
                "--png",
                str(tmp_path / "p.png"),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "reversals: 1;" in out and "first reversal: none" not in out
    ds = xr.open_dataset(tmp_path / "p.nc")
    assert ds.n_reversals >= 1 and "config" in ds.attrs
    assert main(base + ["--spin", "-5"]) == 0
    assert "first reversal: none" in capsys.readouterr().out
    png = (tmp_path / "p.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def test_cli_simulate_and_errors(tmp_path, capsys):
    assert (
        main(
            ["simulate", "--spin", "-5", "--t-end", "1", "--out", str(tmp_path / "one.nc")]
        )
        == 0
    )
    assert "status: ok" in capsys.readouterr().out
    assert (tmp_path / "one.nc").exists()
    assert main(["simulate", "--mu", "-1", "--t-end", "1"]) == 2
    assert "mu must be >= 0" in capsys.readouterr().err


def test_an_empty_batch_gives_an_empty_result():
    """An empty axis is a batch of no launches, as in NumPy: an empty result over
    ``trajectory`` with the usual variables, not an error."""
    from rattlesweep.planar import PlanarBody, run_planar_batch

    toy = rs.Body.preset("toy")
    for ds in (
        rs.run_batch(toy, spin=[], t_end=0.1),
        rs.run_batch(toy, spin=[], t_end=0.1, record_every=3),
        rs.run_batch(toy, spin=[[1.0], [2.0]], mu=[[]], t_end=0.1),
    ):
        assert ds.sizes["trajectory"] == 0
        assert ds.first_reversal_time.shape == (0,) and ds.status.dtype == np.int8
        assert ds.com.shape == (0, 3)
    assert rs.run_batch(toy, spin=[[1.0], [2.0]], mu=[[]], t_end=0.1).attrs[
        "batch_shape"
    ] == [2, 0]
    planar = run_planar_batch(PlanarBody(0.1, 0.05, 1.0), theta=[], t_end=0.1)
    assert planar.sizes["trajectory"] == 0 and planar.max_angle.shape == (0,)
    # counting the steps of an empty batch (what a sweep asks of its corners) is no error
    assert rs.rattleback.batch.max_steps(toy, spin=[], t_end=0.1) == 0


def test_a_record_that_cannot_fit_is_refused_before_compute(kl):
    with pytest.raises(
        ValueError, match=r"record would need [\d.]+ GiB.*record_every.*t_end"
    ):
        rs.simulate(kl, spin=5.0, t_end=1e5, record_every=1)
    # the same run recorded sparsely is fine
    assert rs.simulate(kl, spin=5.0, t_end=0.5, record_every=50).sizes["time"] > 1


@pytest.mark.filterwarnings("ignore::rattlesweep.CoarseStepWarning")  # dt on purpose
def test_more_steps_than_the_kernel_can_count_are_refused(kl):
    """t_end / dt beyond 2**53 steps (and beyond int64, where the step count wrapped to
    a negative number and the run came back "ok" with a negative end time) is refused
    naming both arguments."""
    from rattlesweep.planar import PlanarBody, run_planar_batch

    for t_end in (1e300, 1.34e17):
        with pytest.raises(
            ValueError,
            match=r"t_end / dt must be at most 2\*\*53 steps.*"
            r"t_end = .* dt = ",
        ):
            rs.run_batch(kl, spin=[1.0, 2.0], t_end=[1.0, t_end], dt=0.0145)
    with pytest.raises(ValueError, match=r"t_end / dt .* at index \(1,\)"):
        run_planar_batch(PlanarBody(0.1, 0.05, 1.0), theta=0.1, t_end=[1.0, 1e300])
    assert (
        2**52 < rs.rattleback.batch.max_steps(kl, spin=1.0, t_end=2.0**53, dt=1.0) <= 2**53
    )
    # the step is the default one of that g, damping and body: the message names them
    with pytest.raises(
        ValueError, match=r"dt = .* \(the body's default step at g = 1e\+200"
    ):
        rs.run_batch(kl, spin=1.0, t_end=1.0, g=1e200)
    with pytest.raises(
        ValueError,
        match=r"default step at g = 9.81, damping = 1e\+300, "
        r"body = 'kane_levinson' with a = 0.2, b = 0.03, "
        r"c = 0.02 m\)",
    ):
        rs.run_batch(kl, spin=1.0, t_end=1.0, damping=1e300)
    # a g so large that the default step overflows
    with pytest.raises(ValueError, match=r"g = 1.7e\+308 m s-2 is too large for body"):
        rs.run_batch(kl, spin=1.0, t_end=1.0, g=1.7e308)


def test_launch_angles_follow_the_documented_rotation_order():
    """R = R_z(yaw) R_y(pitch) R_x(roll), body to world, from hand-built matrices; the
    other order (R_x R_y) differs at second order and is not accepted."""
    from rattlesweep.rattleback.launch import quaternion_from_angles, rotation_matrices

    def rx(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    def ry(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])

    def rz(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    roll, pitch, yaw = 0.3, -0.2, 1.1
    got = rotation_matrices(quaternion_from_angles(roll, pitch, yaw))
    np.testing.assert_allclose(got, rz(yaw) @ ry(pitch) @ rx(roll), atol=1e-15)
    assert np.abs(got - rz(yaw) @ rx(roll) @ ry(pitch)).max() > 1e-3
    # positive roll raises the body's +y side; positive pitch lowers its +x end
    assert (rotation_matrices(quaternion_from_angles(0.1, 0.0, 0.0)) @ [0, 1, 0])[2] > 0
    assert (rotation_matrices(quaternion_from_angles(0.0, 0.1, 0.0)) @ [1, 0, 0])[2] < 0
    # and the kernel starts from it: a launch's recorded quaternion is the same
    run = rs.simulate(rs.Body.preset("toy"), roll=roll, pitch=pitch, yaw=yaw, t_end=0.01)
    np.testing.assert_allclose(
        run.quaternion.isel(time=0).values,
        quaternion_from_angles(roll, pitch, yaw),
        atol=1e-15,
    )


def test_a_coarse_time_step_is_flagged_at_the_callers_line():
    from rattlesweep import CoarseStepWarning
    from rattlesweep.planar import PlanarBody, simulate_planar

    toy = rs.Body.preset("toy")
    default = toy.default_dt()
    with pytest.warns(
        CoarseStepWarning,
        match=r"30 times the default step of body 'toy'"
        r".*unstable from about 29 times",
    ) as caught:
        rs.run_batch(toy, spin=[5.0, -5.0], roll=0.01, dt=30 * default, t_end=0.5)
    assert caught[0].filename == __file__
    with pytest.warns(CoarseStepWarning) as caught:
        simulate_planar(
            PlanarBody(0.1, 0.05, 1.0),
            theta=0.2,
            dt=10 * PlanarBody(0.1, 0.05, 1.0).default_dt(),
            t_end=0.1,
        )
    assert caught[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error", CoarseStepWarning)
        rs.simulate(toy, spin=5.0, dt=2 * default, t_end=0.1)  # fine: no warning


def test_the_default_step_follows_strong_damping():
    """Damping relaxes the angular velocity at damping / I about a principal axis; a step
    much longer than that made RK4 unstable (the energy of a damped run grew 1e5-fold in
    one default step with status ok). The default step is at most I_min / damping, and a
    given step beyond 4 times that warns."""
    from rattlesweep import CoarseStepWarning

    body = rs.Body.semi_ellipsoid(0.01, 0.004, 0.003, 0.01)
    i_min = np.linalg.eigvalsh(body.inertia)[0]
    damping = 50 * i_min / body.default_dt()
    ds = rs.run_batch(
        body,
        spin=[0.0, 3.0],
        roll=0.03,
        damping=damping,
        t_end=5 * body.default_dt(),
        record_every=1,
    )
    np.testing.assert_allclose(ds.dt.values, i_min / damping, rtol=1e-12)
    assert (ds.status == 0).all()
    energy = ds.energy.values
    assert np.all(np.diff(energy, axis=1) <= 0), "damping only removes energy"
    # the light damping of Kane and Levinson's body leaves its default step as it was
    kl = rs.Body.preset("kane_levinson")
    assert float(rs.run_batch(kl, damping=1e-4, t_end=0.1).dt[0]) == kl.default_dt()
    with pytest.warns(CoarseStepWarning, match="follows its damping"):
        rs.run_batch(body, roll=0.03, damping=damping, dt=body.default_dt(), t_end=0.01)


def test_angles_in_degrees_are_the_radian_launches_and_keep_their_values(kl):
    toy = rs.Body.preset("toy")
    deg = np.array([0.5, 1.0, 3.0])
    a = rs.run_batch(
        toy, spin=[[2.0], [-3.0]], roll_deg=deg, pitch_deg=1.5, yaw_deg=30.0, t_end=0.2
    )
    b = rs.run_batch(
        toy,
        spin=[[2.0], [-3.0]],
        roll=np.radians(deg),
        pitch=math.radians(1.5),
        yaw=math.radians(30.0),
        t_end=0.2,
    )
    for name in ("final_spin", "max_tilt", "energy_initial", "status"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    # the user's degrees exactly, not degrees -> radians -> degrees
    np.testing.assert_array_equal(a.roll_deg.values, np.tile(deg, 2))
    assert np.all(a.yaw_deg.values == 30.0)
    np.testing.assert_allclose(b.roll_deg.values, np.tile(deg, 2), rtol=1e-14)
    for name in ("roll_deg", "pitch_deg", "yaw_deg"):
        assert a[name].attrs["units"] == "degree" and name not in ("roll", "pitch", "yaw")
    assert "roll" not in a.variables
    run = rs.simulate(toy, spin=2.0, pitch_deg=2.0, t_end=0.05)
    assert run.attrs["pitch_deg"] == 2.0 and run.attrs["pitch_deg_units"] == "degree"
    assert run.attrs["roll_deg"] == 0.0
    # delta_deg where a body is made
    assert rs.Body.semi_ellipsoid(
        0.1, 0.02, 0.01, 0.02, delta_deg=5.0
    ) == rs.Body.semi_ellipsoid(0.1, 0.02, 0.01, 0.02, math.radians(5.0))


@pytest.mark.parametrize("call", ["run_batch", "simulate"])
def test_both_forms_of_one_angle_are_refused_naming_both(call):
    toy = rs.Body.preset("toy")
    for rad, deg in (("roll", "roll_deg"), ("pitch", "pitch_deg"), ("yaw", "yaw_deg")):
        with pytest.raises(
            ValueError,
            match=rf"either {rad} \(rad\) or {deg}.*"
            rf"{rad}=0\.1 and {deg}=5",
        ):
            getattr(rs, call)(toy, spin=1.0, t_end=0.01, **{rad: 0.1, deg: 5})
    with pytest.raises(ValueError, match=r"either delta \(rad\) or delta_deg"):
        rs.Body.semi_ellipsoid(0.1, 0.02, 0.01, 0.02, 0.1, delta_deg=5.0)
    with pytest.raises(ValueError, match=r"delta_deg must be a finite number \(degrees\)"):
        rs.Body.semi_ellipsoid(0.1, 0.02, 0.01, 0.02, delta_deg=math.nan)


def test_degrees_typed_as_radians_draw_a_units_warning(kl):
    toy = rs.Body.preset("toy")
    with pytest.warns(
        rs.UnitsWarning,
        match=r"roll = 30 rad \(1719 degrees\).*"
        r"roll_deg=30",
    ) as record:
        rs.run_batch(toy, spin=1.0, roll=[0.01, 30.0], t_end=0.01)
    assert record[0].filename == __file__  # at the caller's line
    assert issubclass(rs.UnitsWarning, UserWarning)
    with (
        pytest.warns(rs.UnitsWarning, match="pitch_deg=-2"),
        pytest.raises(ValueError, match="rim"),
    ):
        rs.simulate(toy, spin=1.0, pitch=-2.0, t_end=0.01)
    # a full ellipsoid may lie on its side (up to 180 degrees) without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.UnitsWarning)
        rs.run_batch(toy, spin=1.0, roll=[0.3, -1.5], pitch=0.2, yaw=30.0, t_end=0.01)
        rs.simulate(kl, spin=1.0, roll=2.5, t_end=0.01)
        rs.simulate(toy, spin=1.0, roll_deg=30.0, t_end=0.01)
    with pytest.warns(rs.UnitsWarning, match="roll = 4 rad"):
        rs.run_batch(kl, spin=1.0, roll=4.0, t_end=0.01)
