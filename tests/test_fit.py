"""`rattlesweep fit`: measurements made by the model with known inputs, noise and bias,
written in each format people record them in, are fitted back: the truth within the
stated 95 % intervals, an input the data cannot pin down reported as such, and bad
files and arguments refused by name before anything is written."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.fitting import Measurement, fit, read_measurement
from rattlesweep.fitting.measurement import write_phyphox

BODY = rs.Body.preset("kane_levinson")
TRUTH = {"mu": 0.4, "damping": 2e-4, "roll_deg": 1.0, "spin": -3.0}
BOUNDS = {"damping": (1e-5, 1e-3), "roll_deg": (0.2, 3.0), "spin": (-5.0, -1.0)}
QUICK = dict(global_size=384, global_rounds=3, profile_points=9)
BIAS = np.array([0.02, -0.01, 0.03])


def _truth_run(t_end, **inputs):
    return rs.simulate(BODY, t_end=t_end, record_every=1, **{**TRUTH, **inputs})


def _sampled(run, t, name):
    values = run[name].values
    if values.ndim == 1:
        return np.interp(t, run.time.values, values)
    return np.stack([np.interp(t, run.time.values, values[:, k]) for k in range(3)], 1)


@pytest.fixture(scope="module")
def gyro_file(tmp_path_factory):
    """A phyphox gyroscope export of 5 s at 100 Hz: rates + bias + noise 0.02 rad/s."""
    run = _truth_run(5.0)
    t = np.arange(0.0, 5.0, 0.01)
    rng = np.random.default_rng(7)
    rates = _sampled(run, t, "omega") + BIAS + rng.normal(0.0, 0.02, (len(t), 3))
    path = tmp_path_factory.mktemp("gyro") / "Gyroscope rotation rate.csv"
    write_phyphox(path, t, rates)
    return path


@pytest.fixture(scope="module")
def tracker_file(tmp_path_factory):
    """A Tracker export at 30 frames/s: the heading in degrees, offset by 40°, wrapped
    to (-180, 180], with 0.5° of noise and a frame left unmarked."""
    run = _truth_run(6.0)
    t = np.arange(0.0, 6.0, 1 / 30)
    rng = np.random.default_rng(3)
    deg = np.degrees(_sampled(run, t, "heading")) + 40.0 + rng.normal(0.0, 0.5, len(t))
    wrapped = 180.0 - (180.0 - deg) % 360.0
    rows = [f"{ti:.4f}\t0.010\t0.020\t{a:.3f}" for ti, a in zip(t, wrapped)]
    rows[10] = f"{t[10]:.4f}\t\t\t"  # a frame Tracker did not mark
    path = tmp_path_factory.mktemp("tracker") / "rattleback.txt"
    path.write_text("line A\nt\tx\ty\tθ\n" + "\n".join(rows) + "\n")
    return path


def _within(result, truth):
    for name, value in truth.items():
        f = result.fitted[name]
        assert f.low <= value <= f.high, (name, value, f)


def test_reading_a_tracker_export_unwraps_the_heading(tracker_file):
    m = read_measurement(tracker_file)
    assert m.kind == "heading" and len(m.time) == 179  # the unmarked frame dropped
    assert np.abs(np.diff(m.values)).max() < math.radians(20)  # no wrap jumps left
    assert m.values[-1] - m.values[0] < -10.0  # turned clockwise through many turns


def test_gyroscope_fit_recovers_the_truth_and_the_bias(gyro_file):
    result = fit(gyro_file, "kane_levinson", BOUNDS, {"mu": 0.4}, **QUICK)
    _within(result, {k: TRUTH[k] for k in BOUNDS})
    assert result.determined
    bias = [result.offsets[f"bias_{a}"] for a in "xy"]
    np.testing.assert_allclose(bias, BIAS[:2], atol=0.005)
    assert 0.2 < result.reduced_chi2 < 3.0
    assert result.correlation.shape == (3, 3)


def test_heading_fit_recovers_the_truth(tracker_file):
    free = {"damping": (1e-5, 1e-3), "spin": (-5.0, -1.0)}
    result = fit(tracker_file, BODY, free, {"mu": 0.4, "roll_deg": 1.0}, **QUICK)
    _within(result, {k: TRUTH[k] for k in free})
    assert result.determined


def test_the_fit_finds_the_truth_from_the_far_side_of_its_bounds(gyro_file):
    """The truth (spin -3) near the top of spin's bounds, damping's near the bottom of
    a wide range: the global stage still finds them."""
    free = {"spin": (-12.0, -2.5), "damping": (1e-4, 1e-1)}
    result = fit(gyro_file, BODY, free, {"mu": 0.4, "roll_deg": 1.0}, **QUICK)
    _within(result, {k: TRUTH[k] for k in free})


def test_a_turned_gyroscope_s_yaw_is_fitted_and_its_mass_carried():
    """A phone lying on the flat face turned by +30 degrees, 50 g and off centre: its
    yaw is recovered with its sign (the RMS alone cannot tell +30 from -30), the
    biases with it, and the fitted body carries the phone's mass."""
    from rattlesweep.fitting.sensor import rotations

    sensor = {"sensor_mass": 0.05, "sensor_position": (0.0, 0.01, 0.004)}
    loaded = BODY.with_point_masses([(0.05, (0.0, 0.01, 0.004))])
    run = rs.simulate(loaded, t_end=5.0, record_every=1, **TRUTH)
    t = np.arange(0.0, 5.0, 0.01)
    turned = _sampled(run, t, "omega") @ rotations(30.0, 0.0, 0.0).T
    rng = np.random.default_rng(1)
    data = Measurement("gyro", t, turned + BIAS + rng.normal(0.0, 0.02, turned.shape), "x")
    free = {"damping": (1e-5, 1e-3), "spin": (-5.0, -1.0), "sensor_yaw_deg": (-90, 90)}
    result = fit(data, BODY, free, {"mu": 0.4, "roll_deg": 1.0, **sensor}, **QUICK)
    _within(result, {"damping": 2e-4, "spin": -3.0, "sensor_yaw_deg": 30.0})
    assert result.fitted["sensor_yaw_deg"].high - result.fitted["sensor_yaw_deg"].low < 2
    np.testing.assert_allclose(
        [result.offsets[f"bias_{a}"] for a in "xy"], BIAS[:2], atol=0.005
    )
    assert result.body.mass == pytest.approx(BODY.mass + 0.05)
    assert "measured_feature" in result.dataset and result.dataset.sizes["feature"] == 4


@pytest.fixture(scope="module")
def slipping_gyro(tmp_path_factory):
    """4 s of rates at 100 Hz of a launch that slips 16 % of the time (mu = 0.03, roll
    6 degrees), noise 0.02 rad/s, as a phyphox export."""
    run = _truth_run(4.0, mu=0.03, roll_deg=6.0)
    assert 0.1 < float(run.slip_fraction) < 0.3
    t = np.arange(0.0, 4.0, 0.01)
    rng = np.random.default_rng(3)
    rates = _sampled(run, t, "omega") + rng.normal(0.0, 0.02, (len(t), 3))
    path = tmp_path_factory.mktemp("slip") / "Gyroscope rotation rate.csv"
    write_phyphox(path, t, rates)
    return path


def test_model_comparison_prefers_the_friction_model_that_made_the_data(
    slipping_gyro, gyro_file
):
    """Data of a slipping launch: Coulomb friction preferred, rolling far behind, and
    the friction recovered. Data of a launch that never slips: rolling contact, with
    fewer inputs, preferred over Coulomb friction that fits as well."""
    from rattlesweep.fitting.models import compare_models

    free = {"damping": (1e-5, 1e-3), "spin": (-5.0, -1.0), "mu": (0.01, 1.0)}
    models = ("rolling", "coulomb")
    slipping = compare_models(
        slipping_gyro, BODY, free, {"roll_deg": 6.0}, models=models, **QUICK
    )
    assert slipping.preferred == "coulomb"
    assert slipping["rolling"].delta > 10 and slipping["coulomb"].weight > 0.95
    _within(slipping["coulomb"].result, {"mu": 0.03, "damping": 2e-4, "spin": -3.0})
    rolling = compare_models(
        gyro_file, BODY, free, {"roll_deg": 1.0}, models=models, **QUICK
    )
    assert rolling.preferred == "rolling"
    assert rolling["coulomb"].result.chi2 <= rolling["rolling"].result.chi2 * 1.05
    with pytest.raises(ValueError, match="mu fixed: the model comparison sets"):
        compare_models(gyro_file, BODY, free, {"mu": 0.4})


def test_the_command_line_compares_models_and_writes_the_preferred_fit(
    slipping_gyro, tmp_path, capsys
):
    import tomllib

    out = tmp_path / "models"
    args = [str(slipping_gyro), "--body", "kane_levinson", "--out", str(out), "--quiet"]
    args += ["--free", "spin=-5:-1", "--free", "mu=0.01:1", "--fixed", "damping=2e-4"]
    args += ["--fixed", "roll_deg=6", "--compare-models"]
    assert main(["fit", *args]) == 0
    printed = capsys.readouterr().out
    assert "fit of the preferred model, coulomb" in printed
    table = tomllib.loads((out / "models.toml").read_text())
    assert table["preferred"] == "coulomb"
    assert set(table["models"]) == {"rolling", "coulomb", "coulomb_spin"}
    assert table["models"]["rolling"]["delta_aicc"] > 10
    fitted = tomllib.loads((out / "fit.toml").read_text())["fitted"]
    assert fitted["mu"]["low"] <= 0.03 <= fitted["mu"]["high"]
    assert table["models"]["coulomb"]["fitted"]["mu"]["determined"]
    # a plain fit replacing it takes the comparison, which named another fit, away
    plain = [str(slipping_gyro), "--body", "kane_levinson", "--out", str(out)]
    plain += ["--free", "spin=-5:-1", "--fixed", "damping=2e-4", "--fixed", "mu=0.03"]
    plain += ["--fixed", "roll_deg=6", "--quiet", "--force"]
    assert main(["fit", *plain]) == 0
    assert not (out / "models.toml").exists()
    assert "removed" in capsys.readouterr().out


def test_command_line_options_that_cannot_apply_are_refused(
    slipping_gyro, tmp_path, capsys
):
    base = [str(slipping_gyro), "--body", "kane_levinson", "--out", str(tmp_path / "x")]
    cases = [
        (["--free", "mu=0.05:1", "--compare-models"], "free at least one input besides"),
        (["--free", "spin=-5:-1", "--mirrored"], "--mirrored: for heading (video) data"),
    ]
    for extra, message in cases:
        assert main(["fit", *base, *extra]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_friction_in_a_run_that_never_slips_is_reported_not_determined(gyro_file):
    result = fit(
        gyro_file,
        BODY,
        {"mu": (0.2, 1.0), "spin": (-5.0, -1.0)},
        {"damping": 2e-4, "roll_deg": 1.0},
        **QUICK,
    )
    assert not result.fitted["mu"].determined and result.fitted["spin"].determined
    assert any(note.startswith("mu is not determined") for note in result.notes)
    assert not result.determined


def test_the_command_line_writes_the_fit_and_says_when_an_input_is_not_determined(
    gyro_file, tmp_path, capsys
):
    out = tmp_path / "fit"
    args = [str(gyro_file), "--body", "kane_levinson", "--out", str(out), "--quiet"]
    args += ["--free", "mu=0.2:1", "--free", "spin=-5:-1"]
    args += ["--fixed", "damping=2e-4", "--fixed", "roll_deg=1"]
    assert main(["fit", *args]) == 3
    captured = capsys.readouterr()
    assert "not determined" in captured.out + captured.err
    run_line = next(x for x in captured.out.splitlines() if x.startswith("run the fitted"))
    command = run_line.split(": ", 1)[1].split()
    assert command[:4] == ["rattlesweep", "simulate", "--body", str(out / "fit.toml")]
    assert sorted(p.name for p in out.iterdir()) == ["fit.nc", "fit.png", "fit.toml"]
    from rattlesweep.sweep._config.toml_io import read_toml

    doc = read_toml(out / "fit.toml")
    spin = doc["fitted"]["spin"]
    assert spin["low"] <= -3.0 <= spin["high"] and spin["units"] == "rad s-1"
    assert doc["fitted"]["mu"]["determined"] is False
    assert doc["fixed"] == {"damping": 2e-4, "roll_deg": 1.0}
    assert doc["defaults"] == {"pitch": 0.0, "mu_spin": 0.0, "mu_roll": 0.0}
    # the fitted rattleback runs at once, as the command says, and spins as fitted
    sim = tmp_path / "sim.nc"
    assert main([*command[1:], "--out", str(sim)]) == 0
    import xarray as xr

    with xr.open_dataset(sim) as ds:
        assert float(ds["spin"][0]) == pytest.approx(
            doc["fitted"]["spin"]["value"], rel=1e-5
        )
    # a second fit into the same directory is refused before any compute
    assert main(["fit", *args]) == 2
    assert "holds a fit already" in capsys.readouterr().err


def test_options_that_cannot_apply_are_refused_before_the_search(
    gyro_file, tmp_path, capsys
):
    base = [str(gyro_file), "--body", "kane_levinson", "--free", "spin=-5:-1", "--quiet"]
    afile = tmp_path / "afile"
    afile.write_text("")
    cases = [
        (["--out", str(afile)], "--out " + str(afile) + ": exists and is not a directory"),
        (
            ["--out", str(tmp_path / "o"), "--rate-columns", "a", "b", "c"],
            "name the columns of --format csv",
        ),
        (
            ["--out", str(tmp_path / "o"), "--trim-start", "6"],
            "trim_start 6 s leaves 0 samples",
        ),
        (
            ["--out", str(tmp_path / "o"), "--free", "spinn=1:2"],
            "'spinn' is not an input a fit can free",
        ),
    ]
    for extra, message in cases:
        assert main(["fit", *base, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and "fitting" not in err, err
    assert not (tmp_path / "o").exists()


def test_simulate_takes_a_preset_name_for_its_body(capsys):
    assert main(["simulate", "--body", "toy", "--t-end", "0.05"]) == 0
    assert main(["simulate", "--body", "toyy", "--t-end", "0.05"]) == 2
    assert "--body toyy: neither a preset (" in capsys.readouterr().err


def test_a_csv_and_a_netcdf_file_are_read_as_named(tmp_path):
    t = np.linspace(0.0, 2.0, 101)
    csv = tmp_path / "video.csv"
    csv.write_text("time_s,angle_deg\n" + "".join(f"{a},{b}\n" for a, b in zip(t, 30 * t)))
    m = read_measurement(
        csv, format="csv", columns={"time": "time_s", "heading": "angle_deg"}
    )
    np.testing.assert_allclose(m.values, np.radians(30 * t))
    run = rs.simulate(BODY, spin=-3.0, roll_deg=1.0, t_end=0.5, record_every=5)
    run.to_netcdf(tmp_path / "run.nc")
    m = read_measurement(tmp_path / "run.nc")
    assert m.kind == "gyro" and m.values.shape == (len(run.time), 3)
    trimmed = read_measurement(
        csv,
        format="csv",
        columns={"time": "time_s", "heading": "angle_deg"},
        trim_start=0.5,
    )
    assert trimmed.time[0] == 0.0 and len(trimmed.time) == 76


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "t,h\n" + "".join(f"{k * 0.1},{k}\n" for k in range(5)),
            "5 samples; a fit needs at least 20",
        ),
        (
            "t,h\n" + "".join(f"{0.1 * (k - (k == 7))},{k}\n" for k in range(30)),
            "time must increase from sample to sample; sample 8 (0.6 s) follows 0.6 s "
            "(a duplicated time)",
        ),
        (
            "t,h\n" + "".join(f"{0.1 * k},{'nan' if k == 4 else k}\n" for k in range(30)),
            "1 sample is not a number (NaN or empty) in the time or the values: sample 5",
        ),
        (
            "t,h\n" + "".join(f"{0.1 * k},{(100 * k) % 360 - 180}\n" for k in range(30)),
            "the heading was given in radians but lies within ±180",
        ),
        ("t,h\n", "a header and no rows of data"),
    ],
)
def test_bad_files_are_refused_by_name(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=None) as error:
        read_measurement(
            path, format="csv", columns={"time": "t", "heading": "h"}, angle_units="rad"
        )
    assert message in str(error.value) and str(path) in str(error.value)


def test_an_unknown_layout_is_refused_with_what_to_do(tmp_path):
    path = tmp_path / "mystery.csv"
    path.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(ValueError, match="a table whose layout is not known") as error:
        read_measurement(path)
    assert "--format csv --time-column T" in str(error.value)
    assert "'Gyroscope x (rad/s)'" in str(error.value)  # what a phyphox export has
    with pytest.raises(ValueError, match="cannot be read as netCDF"):
        read_measurement(path, format="netcdf")
    with pytest.raises(ValueError, match="needs its time column named .--time-column"):
        read_measurement(path, format="csv", columns={"heading": "a"})


def test_inputs_and_data_that_cannot_fit_are_refused_in_plain_words():
    t = np.linspace(0.0, 4.0, 200)
    gyro = Measurement("gyro", t, np.zeros((200, 3)) + [0.0, 0.0, -3.0], "data")
    free = {"spin": (-5.0, -1.0)}
    cases = [
        ({"roll_deg": 1, "roll": 0.02}, "not both; got roll=0.02 and roll_deg=1"),
        ({"mu": -0.3}, "mu must be >= 0 (inf allowed: rolling without slip); got -0.3"),
        (
            {"sensor_mass": 0.1, "sensor_position": (0.5, 0.0, 0.0)},
            "sensor_position (0.5, 0, 0) m is not on the body",
        ),
    ]
    for fixed, message in cases:
        with pytest.raises(ValueError) as error:
            fit(gyro, BODY, free, fixed)
        assert message in str(error.value) and "array" not in str(error.value)
    late = Measurement("gyro", t + 12.3, gyro.values, "data")
    with pytest.raises(ValueError, match=r"the data start at t = 12.3 s.*trim_start="):
        fit(late, BODY, free)


def test_the_trim_hint_counts_on_the_file_s_clock(gyro_file, tmp_path, capsys):
    """Data recorded 12.3 s before the release: the hint gives the release on the
    file's own clock, whatever --trim-start was given already."""
    shifted = tmp_path / "late.csv"
    m = read_measurement(gyro_file)
    write_phyphox(shifted, m.time + 12.3, m.values)
    base = [str(shifted), "--body", "kane_levinson", "--free", "spin=-5:-1"]
    for trim in ("0", "11", "1.3"):
        out = ["--out", str(tmp_path / f"o{trim}"), "--trim-start", trim]
        assert main(["fit", *base, *out]) == 2
        assert "Give --trim-start 12.3 " in capsys.readouterr().err


@pytest.mark.parametrize(
    "free, fixed, message",
    [
        (
            {"spin": (-1.0, -5.0)},
            {},
            "spin bounds must have low < high, got -1:-5 (inverted)",
        ),
        ({"spin": (-5.0, -1.0)}, {"spin": -3.0}, "spin both free and fixed"),
        ({"roll_deg": (0, 2), "roll": (0, 0.1)}, {}, "roll given twice"),
        ({"colour": (0, 1)}, {}, "'colour' is not an input a fit can free"),
        ({"mu": (0.0, 1.0)}, {}, "mu must be > 0 for a fit"),
        ({"spin": (-5.0, -1.0)}, {"t_end": 3.0}, "t_end is set by the measurement"),
        (
            {"sensor_yaw_deg": (-90, 90)},
            {},
            "sensor_yaw_deg: a sensor's axes apply to gyroscope data",
        ),
        (
            {"spin": (-5.0, -1.0)},
            {"sensor_position": (0, 0, 0.01)},
            "sensor_position is given without sensor_mass",
        ),
        (
            {"spin": (-5.0, -1.0)},
            {"sensor_mass": -0.1},
            "sensor_mass must be a positive number of kg, got -0.1",
        ),
    ],
)
def test_bad_arguments_are_refused_before_any_compute(free, fixed, message):
    t = np.linspace(0.0, 2.0, 50)
    data = Measurement("heading", t, -3.0 * t, "data")
    with pytest.raises(ValueError, match=None) as error:
        fit(data, BODY, free, fixed)
    assert message in str(error.value)
