"""The largest Lyapunov exponent: against the linear stability eigenvalues, its limits,
time reversal, its independence of the batch, and the refusals."""

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import stability as st
from rattlesweep.sweep import Sweep

TOY = rs.Body.preset("toy")


def exponents(spin, t_end, **kwargs):
    """Exponents of upright launches at ``spin`` (a steady spin: no tilt) over each
    ``t_end``, (spins, t_ends)."""
    spin = np.asarray(spin, dtype=float)[:, None]
    ds = rs.run_batch(
        TOY, spin=spin, t_end=np.asarray(t_end)[None, :], lyapunov=True, **kwargs
    )
    assert (ds["status"] == 0).all()
    return ds["lyapunov"].values.reshape(spin.shape[0], -1)


def test_growth_near_unstable_spin_is_the_largest_eigenvalue_real_part():
    """Upright spin is a steady state: the shadow's growth over a late window is the
    largest real part of the tilt eigenvalues (exact to 4 digits), and the exponent
    over the whole run converges to it as the run lengthens."""
    spins = [-20.0, -10.0, -5.0]
    growth = st.eigen(TOY, np.array(spins))["growth_rate"]
    assert (growth > 3).all()  # unstable, with growth rates from 3.6 to 14 per second
    t = np.array([4.0, 8.0, 16.0, 32.0])
    lam = exponents(spins, t)
    window = (lam[:, 3] * t[3] - lam[:, 2] * t[2]) / (t[3] - t[2])
    np.testing.assert_allclose(window, growth, rtol=0.01)
    error = np.abs(lam - growth[:, None])
    # converges as the run lengthens: the launch transient's share falls as 1/t
    assert (error[:, -1] < error[:, 0] / 4).all()
    assert (error[:, -1] < 0.01 * growth).all()


def test_exponent_near_a_stable_spin_tends_to_zero():
    """At a stable upright spin the tilt modes decay (the largest real part is -0.17/s for
    the toy at +20 rad/s) but the spin and the energy are neutral: the exponent tends to
    zero, not to the decay rate."""
    growth = st.eigen(TOY, 20.0)["growth_rate"]
    assert growth < -0.1
    lam = exponents([20.0], [4.0, 32.0])[0]
    assert abs(lam[1]) < 0.05 < abs(lam[0])
    assert abs(lam[1] - growth) > 0.1


def test_attractor_forward_is_a_repeller_backward():
    """The rolling body without damping is reversible: launched back from where a run
    ended, with its angular velocity reversed, it retraces the run. The stable spin that
    attracts the tilt forward (tilt decaying, exponent falling towards zero as 1/t)
    repels it backward: the backward exponent is minus the most negative real part of
    the forward tilt eigenvalues, the growth rate of the reversed spin."""
    lam_tilt = st.eigen(TOY, 20.0)["eigenvalues"].real
    assert lam_tilt.max() < 0
    forward = rs.simulate(TOY, spin=20.0, roll_deg=0.5, t_end=1.0, lyapunov=True)
    back = rs.simulate(
        TOY,
        orientation=forward["quaternion"].values[-1],
        omega=-forward["omega"].values[-1],
        t_end=1.0,
        lyapunov=True,
    )
    tilt = forward["tilt"].values
    assert tilt[-1] < 0.9 * tilt[0]  # attracted forward
    # retraced to the launch tilt (RK4 is reversible to its truncation error, which the
    # repeller amplifies by e^14 over the second)
    np.testing.assert_allclose(back["tilt"].values[-1], tilt[0], rtol=0.05)
    np.testing.assert_allclose(float(back["lyapunov"]), -lam_tilt.min(), rtol=0.15)
    assert float(forward["lyapunov"]) < float(back["lyapunov"]) / 5


def test_exponent_depends_on_the_launch_alone():
    """A launch's exponent is the same bit for bit alone, among other launches in any
    order, on any number of threads, and in a sweep's tiles."""
    rng = np.random.default_rng(3)
    spin = rng.uniform(-20, 20, 70)
    roll = rng.uniform(-3, 3, 70)
    many = rs.run_batch(TOY, spin=spin, roll_deg=roll, t_end=1.0, lyapunov=True)
    order = rng.permutation(70)
    shuffled = rs.run_batch(
        TOY, spin=spin[order], roll_deg=roll[order], t_end=1.0, lyapunov=True, threads=2
    )
    np.testing.assert_array_equal(
        shuffled["lyapunov"].values, many["lyapunov"].values[order]
    )
    alone = rs.run_batch(TOY, spin=spin[5], roll_deg=roll[5], t_end=1.0, lyapunov=True)
    assert alone["lyapunov"].values[0] == many["lyapunov"].values[5]
    assert np.isfinite(many["lyapunov"].values).all()


def test_other_results_are_those_of_the_plain_run():
    rng = np.random.default_rng(4)
    spin, roll = rng.uniform(-20, 20, 40), rng.uniform(-3, 3, 40)
    plain = rs.run_batch(TOY, spin=spin, roll_deg=roll, t_end=1.5, stop="first_reversal")
    with_exp = rs.run_batch(
        TOY, spin=spin, roll_deg=roll, t_end=1.5, stop="first_reversal", lyapunov=True
    )
    assert set(with_exp.data_vars) - set(plain.data_vars) == {"lyapunov"}
    for name in plain.data_vars:
        np.testing.assert_array_equal(with_exp[name].values, plain[name].values)
    assert with_exp.attrs["lyapunov_interval"] == 0.05
    assert with_exp["lyapunov"].attrs["units"] == "s-1"


def test_sweep_keeps_the_exponent(tmp_path):
    sweep = Sweep(
        axes={"spin": [-10.0, 10.0], "delta_deg": [-5.0, 5.0]},
        fixed={"t_end": 1.0, "roll_deg": 0.5},
        lyapunov=True,
    )
    assert Sweep(**sweep.to_dict()) == sweep
    ds = rs.sweep.run_sweep(sweep, tmp_path / "out", progress=False)
    assert ds["lyapunov"].dims == ("launch_spin", "delta_deg")
    assert np.isfinite(ds["lyapunov"].values).all()
    bodies, inputs = sweep.points_at(np.array([3]))
    point = rs.run_batch(bodies, lyapunov=True, **inputs)
    assert point["lyapunov"].values[0] == ds["lyapunov"].values[1, 1]


@pytest.mark.parametrize(
    "name, friction",
    [
        ("mu", {"mu": 0.3}),
        ("mu_static", {"mu": 0.3, "mu_static": 0.5}),
        ("mu_spin", {"mu_spin": 1e-4}),
        ("mu_roll", {"mu_roll": 1e-4}),
    ],
)
def test_stick_slip_friction_is_refused(name, friction):
    with pytest.raises(ValueError, match="lyapunov needs rolling contact") as info:
        rs.run_batch(TOY, spin=[5.0, 6.0], t_end=1.0, lyapunov=True, **friction)
    assert name in str(info.value)
    with pytest.raises(ValueError, match="rolling contact"):
        Sweep(axes={"spin": [1.0, 2.0]}, fixed={"t_end": 1.0, **friction}, lyapunov=True)


def test_a_static_friction_that_never_gives_way_rolls():
    ds = rs.run_batch(TOY, spin=-5.0, t_end=0.5, mu=0.3, mu_static=np.inf, lyapunov=True)
    assert np.isfinite(ds["lyapunov"].values).all()


def test_a_run_of_a_few_intervals_is_said_to_be_mostly_transient():
    with pytest.warns(RuntimeWarning, match="0.2 renormalisation intervals"):
        rs.run_batch(TOY, spin=[-5.0, 5.0], t_end=0.01, lyapunov=True)
    with pytest.warns(RuntimeWarning, match="mostly the launch's transient"):
        rs.simulate(TOY, spin=-5.0, t_end=0.2, lyapunov=True)


def test_lyapunov_must_be_a_boolean():
    with pytest.raises(ValueError, match="lyapunov must be a boolean"):
        rs.run_batch(TOY, spin=5.0, t_end=1.0, lyapunov="yes")
    with pytest.raises(ValueError, match="lyapunov must be true or false"):
        Sweep(axes={"spin": [1.0, 2.0]}, fixed={"t_end": 1.0}, lyapunov=1)
