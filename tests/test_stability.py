"""Linear stability of steady spin: against the kernel, closed forms, symmetries and the
nonlinear simulation."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import stability as st
from rattlesweep.rattleback.batch import prepare
from rattlesweep._core.models import RATTLEBACK
from rattlesweep._core.rattleback import layout as L
from rattlesweep._core.stepper import rolling_derivative
from rattlesweep.rattleback.launch import quaternion_from_angles

KL = rs.Body.preset("kane_levinson")
TOY = rs.Body.preset("toy")
GOLDEN = rs.Body.preset("golden")


def kernel_jacobian(body, spin, damping=0.0, h=1e-6):
    """Central-difference Jacobian of the kernel's rolling right-hand side in the tilt
    coordinates (γx, γy, ωx, ωy), ωz held at ``spin``."""
    # γ = (−sin p, sin r cos p, cos r cos p): γx = −pitch, γy = roll to first order
    rows = []
    for k in range(4):
        for sign in (1.0, -1.0):
            x = np.zeros(4)
            x[k] = sign * h
            rows.append(x)
    x = np.array(rows)
    q = quaternion_from_angles(x[:, 1], -x[:, 0], np.zeros(len(x)))
    omega = np.stack([x[:, 2], x[:, 3], np.full(len(x), spin)], axis=1)
    prep = prepare(body, orientation=q, omega=omega, damping=damping, t_end=1.0)
    D = np.zeros_like(prep.Y)
    rolling_derivative(RATTLEBACK, prep.P, prep.Y, D)
    Y = prep.Y.transpose(1, 0, 2).reshape(L.N_STATE, -1)[:, : len(x)]
    Dn = D.transpose(1, 0, 2).reshape(L.N_STATE, -1)[:, : len(x)]
    q, qd = Y[L.Q0 : L.Q0 + 4], Dn[L.Q0 : L.Q0 + 4]
    # γ̇ from the kernel's quaternion rate: γx = 2(q1 q3 − q0 q2), γy = 2(q2 q3 + q0 q1)
    gx_dot = 2 * (qd[1] * q[3] + q[1] * qd[3] - qd[0] * q[2] - q[0] * qd[2])
    gy_dot = 2 * (qd[2] * q[3] + q[2] * qd[3] + qd[0] * q[1] + q[0] * qd[1])
    f = np.stack([gx_dot, gy_dot, Dn[L.OMEGA_X], Dn[L.OMEGA_Y]])  # (4, 8)
    return (f[:, 0::2] - f[:, 1::2]) / (2 * h)


@pytest.mark.parametrize("body", [KL, TOY, GOLDEN], ids=["kane_levinson", "toy", "golden"])
@pytest.mark.parametrize("spin", [-7.0, 0.0, 3.0, 20.0])
@pytest.mark.parametrize("damping", [0.0, 1e-4])
def test_linearisation_is_the_jacobian_of_the_kernel(body, spin, damping):
    A = st.linearisation(body, spin, damping=damping)
    J = kernel_jacobian(body, spin, damping)
    np.testing.assert_allclose(A, J, rtol=0, atol=1e-7 * np.abs(A).max())


def test_zero_spin_frequencies_equal_the_closed_forms():
    body = rs.Body.semi_ellipsoid(0.06, 0.02, 0.015, 0.05, 0.0)  # I_xy = 0
    m, g, ell = body.mass, 9.81, body.com_height
    a, b, c = body.a, body.b, body.c
    wp = math.sqrt(m * g * (a * a / c - ell) / (body.inertia[1, 1] + m * ell * ell))
    wr = math.sqrt(m * g * (b * b / c - ell) / (body.inertia[0, 0] + m * ell * ell))
    pitch, roll = st.zero_spin_frequencies(body, g=g)
    assert pitch == pytest.approx(wp, rel=1e-12) and roll == pytest.approx(wr, rel=1e-12)
    lam = st.eigen(body, 0.0)["eigenvalues"]
    np.testing.assert_allclose(np.sort(np.abs(lam.imag)), [wr, wr, wp, wp], rtol=1e-12)
    np.testing.assert_allclose(lam.real, 0.0, atol=1e-12 * wp)
    # coupled modes (I_xy != 0) agree with the body's own generalised eigenproblem
    for preset in (KL, TOY, GOLDEN):
        np.testing.assert_allclose(
            st.zero_spin_frequencies(preset),
            preset.small_oscillation_frequencies(),
            rtol=1e-10,
        )


def test_zero_misalignment_gives_zero_growth():
    body = rs.Body.semi_ellipsoid(0.0475, 0.0095, 0.011, 0.011, 0.0)
    spins = np.linspace(-40, 40, 81)
    e = st.eigen(body, spins)
    scale = np.abs(e["eigenvalues"]).max(axis=-1)
    assert np.all(np.abs(e["growth_rate"]) <= 1e-10 * scale)
    assert np.all(e["mode"] == st.NEUTRAL)


def test_mirror_symmetry_spin_and_misalignment():
    spins = np.linspace(-25, 25, 51)
    for delta in (0.02, 0.1):
        plus = rs.Body.semi_ellipsoid(0.0475, 0.0095, 0.011, 0.011, delta)
        minus = rs.Body.semi_ellipsoid(0.0475, 0.0095, 0.011, 0.011, -delta)
        a = st.eigen(plus, spins)["eigenvalues"]
        b = st.eigen(minus, -spins)["eigenvalues"]
        key = lambda z: np.sort_complex(np.round(z, 9))
        np.testing.assert_allclose(key(a), key(b), atol=1e-9)
        assert not np.allclose(key(a), key(st.eigen(plus, -spins)["eigenvalues"]))


def test_trace_identity():
    spins = np.linspace(-30, 30, 61)
    for body in (KL, TOY, GOLDEN):
        for damping in (0.0, 3e-5):
            lam = st.eigen(body, spins, damping=damping)["eigenvalues"]
            expected = st.trace_identity(body, spins, damping=damping)
            np.testing.assert_allclose(
                lam.real.sum(axis=-1), expected, rtol=1e-9, atol=1e-12 * np.abs(lam).max()
            )
        # without damping the trace is a fixed multiple of I_xy n l (a^2 - b^2)
        ratio = st.trace_identity(body, spins[spins != 0]) / (
            body.inertia[0, 1]
            * spins[spins != 0]
            * body.com_height
            * (body.a**2 - body.b**2)
        )
        np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)
        assert ratio[0] > 0


def test_small_spin_closed_form_converges_to_the_eigenvalues():
    for body in (KL, TOY):
        errors = []
        for n in (0.4, 0.2, 0.1):
            exact = st.eigen(body, n)
            p, r = st.small_spin_growth_rates(body, n)
            errors.append(
                abs(p - exact["pitch_growth_rate"]) / abs(exact["pitch_growth_rate"])
            )
            assert r == pytest.approx(float(exact["roll_growth_rate"]), rel=0.01)
        assert errors[-1] < 1e-3
        # the expansion is first order in n and the real part has no n^2 term, so the
        # relative error falls as n^2: halving n quarters it
        assert errors[1] / errors[0] == pytest.approx(0.25, abs=0.03)
        assert errors[2] / errors[1] == pytest.approx(0.25, abs=0.03)


def measured_growth(body, spin, t_end, amplitude=1e-7):
    """Growth rate of the tilt of a nonlinear rolling run launched along the fastest
    growing eigenvector, from a fit to the maxima of the tilt before it saturates."""
    A = st.linearisation(body, spin)
    lam, vec = np.linalg.eig(A)
    k = int(np.argmax(lam.real))
    v = vec[:, k].real if abs(vec[:, k].real).max() > 1e-3 else vec[:, k].imag
    v = amplitude * v / np.hypot(v[0], v[1])
    q = quaternion_from_angles(np.array([v[1]]), np.array([-v[0]]), np.zeros(1))[0]
    run = rs.simulate(
        body, orientation=q, omega=(v[2], v[3], spin), t_end=t_end, record_every=1
    )
    tilt, t = run.tilt.values, run.time.values
    peak = (tilt[1:-1] > tilt[:-2]) & (tilt[1:-1] >= tilt[2:])
    tp, yp = t[1:-1][peak], tilt[1:-1][peak]
    keep = yp < 1e3 * amplitude  # linear regime: tilt below 1e-4 rad
    slope = np.polyfit(tp[keep], np.log(yp[keep]), 1)[0]
    return slope, lam.real.max()


@pytest.mark.parametrize("spin", [4.0, -4.0])
def test_nonlinear_growth_matches_the_linear_prediction(spin):
    # kane_levinson: +4 rad/s pitch-driven (fast), -4 rad/s roll-driven (slow)
    predicted = st.eigen(KL, spin)["growth_rate"]
    t_end = 7.0 / predicted  # seven e-folds: tilt 1e-7 -> 1e-4 rad
    measured, lam = measured_growth(KL, spin, t_end)
    assert predicted > 0
    assert measured == pytest.approx(predicted, rel=0.01)


def test_asymptotically_stable_sense_decays_in_simulation():
    # golden at +2 rad/s: every eigenvalue has a negative real part without any damping
    e = st.eigen(GOLDEN, 2.0)
    assert e["mode"] == st.STABLE
    measured, lam = measured_growth(GOLDEN, 2.0, t_end=-3.0 / float(e["growth_rate"]))
    assert measured == pytest.approx(float(e["growth_rate"]), rel=0.01)


def test_bad_inputs_are_refused():
    off_axis = rs.Body(
        0.05, 0.01, 0.01, 0.01, (0.001, 0.0, -0.003), np.diag([1e-6, 8e-6, 8.5e-6])
    )
    with pytest.raises(ValueError, match="com x = y = 0"):
        st.eigen(off_axis, 1.0)
    tilted = rs.Body(
        0.05,
        0.01,
        0.01,
        0.01,
        (0.0, 0.0, -0.003),
        [[1e-6, 0, 1e-7], [0, 8e-6, 0], [1e-7, 0, 8.5e-6]],
    )
    with pytest.raises(ValueError, match="I_xz = I_yz = 0"):
        st.linearisation(tilted, 1.0)
    with pytest.raises(ValueError, match="spin must be finite"):
        st.eigen(KL, [1.0, math.nan])
    with pytest.raises(ValueError, match="g must be finite and > 0"):
        st.eigen(KL, 1.0, g=-9.81)
    with pytest.raises(ValueError, match="body must be a Body"):
        st.eigen("kane_levinson", 1.0)


def test_stability_dataset_on_a_sweep_grid_and_cli(tmp_path, capsys):
    from rattlesweep.cli import main
    from rattlesweep.plot import reversal_vs_growth, stability_map
    from rattlesweep.sweep import Sweep, run_sweep

    toml = tmp_path / "grid.toml"
    toml.write_text(
        "[axes]\nspin = { start = -20, stop = 20, num = 9 }\n"
        "delta_deg = { start = -6, stop = 6, num = 5 }\n"
        "[fixed]\nt_end = 3.0\nroll_deg = 0.5\n"
    )
    sweep = Sweep.from_toml(toml)
    ds = st.stability_dataset(sweep)
    assert ds.growth_rate.dims == ("launch_spin", "delta_deg")
    assert (
        ds.delta_deg.attrs["units"] == "degree" and ds.growth_rate.attrs["units"] == "s-1"
    )
    # one point against a direct evaluation
    body = rs.Body.semi_ellipsoid(TOY.a, TOY.b, TOY.c, TOY.mass, math.radians(-3.0))
    direct = st.eigen(body, 15.0)
    point = ds.sel(launch_spin=15.0, delta_deg=-3.0)
    assert float(point.growth_rate) == pytest.approx(
        float(direct["growth_rate"]), rel=1e-12
    )
    assert int(point["mode"]) == int(direct["mode"])
    assert np.all(ds.sel(delta_deg=0.0).growth_rate == pytest.approx(0.0, abs=1e-9))
    # a stability-only configuration needs no t_end
    no_t = Sweep(axes={"spin": [1.0, 2.0]}, fixed={"body": "kane_levinson"})
    assert st.stability_dataset(no_t).growth_rate.shape == (2,)

    # maps with the simulated boundary, predicted vs simulated, and the CLI
    sim = run_sweep(sweep, tmp_path / "sim", progress=False)
    fig = stability_map(ds, "launch_spin", "delta_deg", overlay=sim)
    labels = {t.get_text() for t in fig.legends[0].get_texts()}
    assert "simulated reversal boundary" in labels
    assert any(ax.collections and len(ax.collections) > 1 for ax in fig.axes)
    fig = reversal_vs_growth(ds, sim)
    ax = fig.axes[0]
    assert ax.get_xlabel().endswith("[s]") and ax.get_ylabel().endswith("[s]")
    median = ax.get_legend().get_texts()[-1].get_text()
    assert median.startswith("first reversal = ") and "the median ratio" in median
    assert all(c.get_alpha() == 0.5 for c in ax.collections)  # overlaps show
    legend = reversal_vs_growth(ds, sim, color_by="delta_deg")  # 5 values: a legend
    values = [t.get_text() for t in legend.axes[0].get_legend().get_texts()][:-1]
    assert values == ["δ = -6°", "δ = -3°", "δ = 3°", "δ = 6°"]  # δ = 0 never reverses
    bar = reversal_vs_growth(ds, sim, color_by="launch_spin")  # 9 values: a colour bar
    labels = [t.get_text() for t in bar.axes[0].get_legend().get_texts()]
    assert labels == [median]  # the values on the colour bar, not in the legend
    assert bar.axes[1].get_ylabel() == "initial spin about the vertical [rad/s]"
    # faster growth, earlier reversal: the two times are positively correlated
    both = xr_points(ds, sim)
    assert np.corrcoef(np.log(both[0]), np.log(both[1]))[0, 1] > 0.5

    out = tmp_path / "stab.nc"
    assert main(["stability", str(toml), "--out", str(out)]) == 0
    # counted by the mode: the delta_deg = 0 row (growth rates of rounding size) and
    # the zero spin are neutral, not unstable (the summary counted them unstable)
    modes = rs.decode(ds["mode"]).values.ravel()
    unstable = np.isin(modes, ["pitch_unstable", "roll_unstable"]).mean()
    neutral = (modes == "neutral").mean()
    assert 0 < neutral and 0 < unstable < 1 - neutral
    assert (
        f"; {unstable:.0%} unstable, {neutral:.0%} neutral, largest growth rate"
        in capsys.readouterr().out
    )
    assert (
        main(
            [
                "plot",
                str(out),
                "--overlay",
                str(tmp_path / "sim" / "sweep.nc"),
                "--out",
                str(tmp_path / "m.png"),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "plot",
                str(out),
                "--versus",
                str(tmp_path / "sim" / "sweep.nc"),
                "--out",
                str(tmp_path / "v.png"),
            ]
        )
        == 0
    )
    assert (tmp_path / "m.png").stat().st_size > 10_000
    assert (tmp_path / "v.png").stat().st_size > 10_000


def xr_points(stab, sim):
    import xarray as xr

    a, b = xr.align(stab.e_folding_time, sim.first_reversal_time, join="inner")
    ok = np.isfinite(a.values) & np.isfinite(b.values)
    return a.values[ok], b.values[ok]


@pytest.mark.parametrize(
    "name,bad", [("g", -1.0), ("damping", -1e-3), ("g", [9.81, 0.0])], ids=str
)
def test_a_bad_input_is_refused_as_run_batch_refuses_it(name, bad):
    with pytest.raises(ValueError) as batch:
        rs.run_batch(TOY, spin=1.0, t_end=0.01, **{name: bad})
    for function in (st.eigen, st.linearisation, st.small_spin_growth_rates):
        with pytest.raises(ValueError) as linear:
            function(TOY, 1.0, **{name: bad})
        assert str(linear.value) == str(batch.value), function.__name__


def test_a_non_finite_spin_is_refused_as_a_sweep_refuses_it():
    # a batch gives a non-finite spin a status; a sweep, like the linearisation, refuses it
    with pytest.raises(ValueError) as swept:
        rs.Sweep(axes={"g": [9.8]}, fixed={"t_end": 1.0, "spin": math.inf})
    with pytest.raises(ValueError) as linear:
        st.eigen(TOY, math.inf)
    assert str(linear.value) == "spin must be finite; got inf"
    assert str(swept.value).endswith(str(linear.value))


def test_a_growth_map_draws_the_zero_growth_line_where_the_sign_changes():
    """With damping, upright spin is stable (negative growth) near zero spin and for
    the 'right' sense: the map draws the zero of the growth rate, dashed, with a legend
    entry saying which side is stable; a map whose growth never changes sign draws
    none."""
    from rattlesweep.plot import stability_map

    shell = {"a": 0.05, "b": 0.01, "c": 0.01, "mass": 0.01}
    axes = {
        "spin": {"start": -8, "stop": 8, "num": 9},
        "delta_deg": {"start": -5, "stop": 5, "num": 5},
    }
    damped = st.stability_dataset(rs.Sweep(axes=axes, fixed={**shell, "damping": 2e-6}))
    assert float(damped.growth_rate.min()) < 0 < float(damped.growth_rate.max())
    fig = stability_map(damped, "launch_spin", "delta_deg")
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["growth rate 0: linear stability boundary (stable where < 0)"]
    line = fig.axes[0].collections[-1]
    assert line.get_linestyle()[0][1] is not None  # dashed
    level = next(iter(line.get_paths())).vertices  # points on the zero of the growth
    assert level.size
    spins = st.stability_dataset(
        rs.Sweep(axes={"spin": [4.0, 8.0], "delta_deg": [2.0, 5.0]}, fixed=shell)
    )
    assert float(spins.growth_rate.min()) > 0
    assert not stability_map(spins, "launch_spin", "delta_deg").legends


def test_the_command_line_plot_of_a_growth_map_draws_its_zero(tmp_path, monkeypatch):
    from rattlesweep.cli import main
    from rattlesweep.plot import maps

    shell = {"a": 0.05, "b": 0.01, "c": 0.01, "mass": 0.01, "damping": 2e-6}
    config = tmp_path / "s.toml"
    config.write_text(
        rs.Sweep(
            axes={"spin": [-6.0, -1.0, 1.0, 6.0], "delta_deg": [-4.0, 4.0]}, fixed=shell
        ).to_toml()
    )
    assert main(["stability", str(config), "--out", str(tmp_path / "s.nc")]) == 0
    drawn = {}
    real = maps.reversal_map

    def watched(*args, **kwargs):
        drawn["zero_line"] = kwargs.get("zero_line")
        return real(*args, **kwargs)

    monkeypatch.setattr(maps, "reversal_map", watched)
    import rattlesweep.plot as plot

    monkeypatch.setattr(plot, "reversal_map", watched)
    assert main(["plot", str(tmp_path / "s.nc"), "--out", str(tmp_path / "s.png")]) == 0
    assert drawn["zero_line"] == maps.GROWTH_ZERO


def test_a_friction_axis_is_said_to_repeat_the_values(tmp_path, capsys):
    """Friction does not enter the linearisation: along a mu axis the values repeat,
    and the file and the command say so once."""
    from rattlesweep.cli import main

    sweep = rs.Sweep(axes={"spin": [-5.0, 5.0], "mu": [0.2, 0.5, math.inf]}, fixed={})
    ds = st.stability_dataset(sweep)
    growth = ds.growth_rate.transpose("launch_spin", "mu").values
    assert (growth == growth[:, :1]).all()
    assert ds.attrs["friction"].startswith(st.FRICTION_NOTE)
    assert ds.attrs["friction"].endswith("the values repeat along mu")
    plain = st.stability_dataset(rs.Sweep(axes={"spin": [-5.0, 5.0]}, fixed={}))
    assert plain.attrs["friction"] == st.FRICTION_NOTE
    config = tmp_path / "s.toml"
    config.write_text(sweep.to_toml())
    assert main(["stability", str(config), "--out", str(tmp_path / "s.nc")]) == 0
    out = capsys.readouterr().out
    assert out.count("the values repeat along mu") == 1
