"""Physics checks of MODEL.md section 9, against independent facts."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import Body

from conftest import HALF_DEGREE


def _up(q):
    """World up-vector in body components, from recorded quaternions (..., 4)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)


def test_energy_conserved_when_rolling_and_frictionless(kl):
    ds = rs.run_batch(
        kl,
        spin=5.0,
        roll=HALF_DEGREE,
        mu=[math.inf, 0.0],
        dt=2e-4,
        t_end=20.0,
        record_every=50,
    )
    assert (ds.status == 0).all()
    energy = ds.energy.values
    drift = np.abs(energy - energy[:, :1]).max(axis=1) / energy[:, 0]
    assert drift.max() < 1e-6, drift
    assert (ds.slip_fraction.values == [0.0, 1.0]).all()


def _final_state(ds):
    return np.concatenate(
        [ds.quaternion.values[..., -1, :], ds.omega.values[..., -1, :]], -1
    )


@pytest.mark.parametrize("method, order, dt0", [("rk4", 4, 1e-3), ("euler", 1, 1e-4)])
def test_convergence_order(kl, method, order, dt0):
    finals = []
    for k in range(3):
        dt = dt0 / 2**k
        ds = rs.simulate(
            kl,
            spin=5.0,
            roll=0.05,
            t_end=0.4,
            dt=dt,
            method=method,
            record_every=int(round(0.4 / dt)),
        )
        finals.append(_final_state(ds))
    e1 = np.linalg.norm(finals[0] - finals[1])
    e2 = np.linalg.norm(finals[1] - finals[2])
    assert math.log2(e1 / e2) == pytest.approx(order, abs=0.2)


def test_frictionless_conserves_momenta_and_never_reverses(kl):
    ds = rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, mu=0.0, t_end=10.0, record_every=10)
    inertia = kl.inertia
    lz = np.einsum("ti,ij,tj->t", _up(ds.quaternion.values), inertia, ds.omega.values)
    assert np.abs(lz - lz[0]).max() < 1e-9 * abs(lz[0])
    v = ds.velocity.values[:, :2]
    assert np.abs(v - v[0]).max() < 1e-12
    assert int(ds.n_reversals) == 0 and np.isnan(float(ds.first_reversal_time))
    assert (ds.spin.values > 0).all()


def test_sliding_sphere_ends_rolling_at_five_sevenths():
    radius, v0, mu, g = 0.05, 1.0, 0.3, 9.81
    sphere = Body.ellipsoid(radius, radius, radius, 1.0)
    dt = 1e-4
    ds = rs.simulate(sphere, velocity=(v0, 0.0), mu=mu, t_end=0.3, dt=dt, record_every=1)
    slipping = ds.slipping.values
    t_stick = float(ds.time[np.argmax(slipping < 0.5)])
    assert slipping[0] == 1.0 and slipping[-1] == 0.0
    assert t_stick == pytest.approx(2 * v0 / (7 * mu * g), abs=3 * dt)
    speed = np.hypot(*ds.velocity.values[-1, :2])
    assert speed == pytest.approx(5 / 7 * v0, abs=1e-3)
    # no spin is ever produced about the vertical
    assert np.abs(ds.spin.values).max() < 1e-12


@pytest.mark.parametrize("mu", [math.inf, 0.0])
@pytest.mark.parametrize("mode", ["pitch", "roll"])
def test_small_rocking_period(mu, mode):
    body = Body.semi_ellipsoid(0.08, 0.02, 0.015, 0.3)  # I_xy = 0: modes decouple
    pitch_w, roll_w = body.small_oscillation_frequencies(rolling=mu == math.inf)
    omega = pitch_w if mode == "pitch" else roll_w
    period = 2 * math.pi / omega
    amp = 1e-4
    kwargs = {mode: amp}
    ds = rs.simulate(
        body,
        spin=0.0,
        mu=mu,
        t_end=10.5 * period,
        dt=period / 2000,
        record_every=1,
        **kwargs,
    )
    # tilt component about the rocking axis: q_y (pitch) or q_x (roll)
    signal = ds.quaternion.sel(quaternion_component="y" if mode == "pitch" else "x").values
    t = ds.time.values
    s0, s1 = signal[:-1], signal[1:]
    idx = np.nonzero((s0 > 0) & (s1 <= 0))[0]  # downward zero crossings
    crossings = t[idx] + (t[idx + 1] - t[idx]) * s0[idx] / (s0[idx] - s1[idx])
    measured = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert len(crossings) >= 9
    assert measured == pytest.approx(period, rel=1e-3)


def _mirror(body: Body) -> Body:
    """Reflect y -> -y: flips I_xy and I_yz and com_y."""
    flip = np.diag([1.0, -1.0, 1.0])
    return Body(
        body.a,
        body.b,
        body.c,
        body.mass,
        flip @ body.com,
        flip @ body.inertia @ flip,
        body.full_ellipsoid,
        name="mirrored",
    )


def test_mirror_symmetry(kl):
    kw = dict(mu=0.3, t_end=6.0, record_every=10, pitch=0.01)
    ds = rs.simulate(kl, spin=5.0, roll=0.02, **kw)
    mirrored = rs.simulate(_mirror(kl), spin=-5.0, roll=-0.02, **kw)
    assert 0 < float(ds.slip_fraction) < 1
    np.testing.assert_allclose(mirrored.spin, -ds.spin, atol=1e-8 * 5)
    np.testing.assert_allclose(mirrored.tilt, ds.tilt, atol=1e-9)
    pos, mpos = ds.position.values, mirrored.position.values
    np.testing.assert_allclose(mpos[:, 0], pos[:, 0], atol=1e-10)
    np.testing.assert_allclose(mpos[:, 1], -pos[:, 1], atol=1e-10)
    assert float(mirrored.first_reversal_time) == pytest.approx(
        float(ds.first_reversal_time), abs=1e-9
    )


def test_kane_levinson_chirality(kl):
    fast = rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, t_end=10.0)
    assert 1.0 < float(fast.first_reversal_time) < 8.0
    assert float(fast.final_spin) < 0
    slow = rs.simulate(kl, spin=-5.0, roll=HALF_DEGREE, damping=1e-4, t_end=20.0)
    assert int(slow.n_reversals) == 0
    assert float(slow.final_spin) < 0


@pytest.mark.parametrize("mu", [0.3, 0.6])
def test_coulomb_slips_part_time_and_energy_never_increases(kl, mu):
    ds = rs.simulate(
        kl, spin=5.0, roll=HALF_DEGREE, mu=mu, dt=2e-4, t_end=8.0, record_every=1
    )
    assert 0.0 < float(ds.slip_fraction) < 0.5
    assert np.isfinite(float(ds.first_reversal_time))
    energy = ds.energy.values
    e0, lost = energy[0], energy[0] - energy[-1]
    assert lost > 1e-4 * e0
    # Energy never exceeds its launch value. Friction only removes energy; what is left
    # are integrator-level wiggles (RK4 error in stick, and the O(dt^2) work done at a
    # slip onset, where the first step's slip direction is fixed): each far below what
    # one step of friction removes, and together a negligible fraction of the loss.
    assert energy.max() - e0 < 1e-12 * e0
    rise = np.clip(np.diff(energy), 0.0, None)
    assert rise.max() < 1e-6 * e0
    assert rise.sum() < 1e-4 * lost


def test_coulomb_runs_converge_as_dt_shrinks(kl):
    dts = 4e-4 / np.array([1, 2, 4, 8])  # each records every 0.01 s exactly
    runs = [
        rs.simulate(
            kl,
            spin=5.0,
            roll=HALF_DEGREE,
            mu=0.3,
            dt=float(dt),
            t_end=8.0,
            record_every=int(round(0.01 / dt)),
        )
        for dt in dts
    ]
    t_rev = np.array([float(r.first_reversal_time) for r in runs])
    slip = np.array([float(r.slip_fraction) for r in runs])
    spin_diff = [
        np.abs(a.spin.values - b.spin.values).max() for a, b in zip(runs, runs[1:])
    ]
    rev_diff = np.abs(np.diff(t_rev))
    slip_diff = np.abs(np.diff(slip))
    assert all(np.diff(spin_diff) < 0), spin_diff
    assert all(np.diff(rev_diff) < 0), rev_diff
    assert slip_diff[-1] < slip_diff[0] and slip_diff[-1] < 0.01, slip
    assert rev_diff[-1] < 5e-3
