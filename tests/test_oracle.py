"""The kernel against an independent NumPy model of its equations (tests/numpy_oracle.py).

Both integrate the rolling (mu = inf) equations of MODEL.md sections 3-4 with the same
classic RK4 at the same dt from the same initial state (read from the kernel's record at
t = 0), so they may differ only by rounding, amplified by the instability that drives the
reversal. Measured: at most 4e-16 of |n(0)| over the first second, 2.2e-12 through the
kane_levinson reversal at 5.8 s (1e-13 for the toy), first reversal times within 1.1e-13 s.
TOL = 1e-10 leaves a factor 45 for other compilers and CPUs; an error in the equations
shows up far above it within one second (test_a_wrong_model_is_detected: the smallest,
dropping the contact point's migration over the body, gives 7e-9).
"""

import math
import types

import numpy as np
import pytest

import rattlesweep as rs
from numpy_oracle import NumpyRolling, first_reversal

TOL = 1e-10  # spin: max |n_kernel - n_oracle| / |n(0)|; first reversal time: s
ROLL = math.radians(0.5)
BAND = 0.05  # run_batch's default reversal_band
# body: (fast spin, rad/s; t_end, s, past the fast launch's first reversal). The fast
# sense has I_xy * n > 0 (MODEL.md section 2); both senses run.
CASES = {"kane_levinson": (5.0, 6.2), "toy": (-10.0, 2.0)}


def kernel_launch(body, spins, t_end):
    """Kernel run recorded at every step (public API); its t = 0 state as an oracle
    state."""
    ds = rs.run_batch(
        body,
        spin=spins,
        roll=ROLL,
        t_end=t_end,
        record_every=1,
        reversal_band=BAND,
        parallel=False,
    )
    y0 = np.concatenate(
        [
            ds.quaternion.values[:, 0].T,
            ds.omega.values[:, 0].T,
            ds.position.values[:, 0, :2].T,
            ds.velocity.values[:, 0, :2].T,
        ]
    )
    return ds, y0


@pytest.fixture(scope="module", params=sorted(CASES))
def run(request):
    body = rs.Body.preset(request.param)
    fast, t_end = CASES[request.param]
    spins = np.array([fast, -fast])
    ds, y0 = kernel_launch(body, spins, t_end)
    dt = float(ds.dt.values[0])
    _, oracle_spin = NumpyRolling(body).rk4(y0, dt, ds.time.size - 1)
    return types.SimpleNamespace(
        body=body, spins=spins, ds=ds, y0=y0, dt=dt, oracle_spin=oracle_spin.T
    )


def relative_gap(spin_a, spin_b, spins):
    return np.abs(spin_a - spin_b).max(axis=-1) / np.abs(spins)


def test_spin_histories_agree(run):
    ok = run.ds.status.attrs["flag_meanings"].split().index("ok")
    assert np.all(run.ds.status.values == ok)
    assert run.oracle_spin.shape == run.ds.spin.shape
    gap = relative_gap(run.ds.spin.values, run.oracle_spin, run.spins)
    assert np.all(gap <= TOL), gap  # NaN fails too


def test_first_reversal_times_agree(run):
    t = run.ds.time.values
    kernel = run.ds.first_reversal_time.values
    oracle = np.array([first_reversal(t, s, BAND) for s in run.oracle_spin])
    # the fast launch reverses within the run, the other one does not
    assert np.isfinite(kernel[0]) and np.isnan(kernel[1]), kernel
    assert np.isnan(oracle[1])
    assert abs(kernel[0] - oracle[0]) <= TOL, (kernel[0], oracle[0])


def test_launch_states_agree(run):
    """The oracle's own rolling launch (roll about body x, spin about the vertical, G
    moving so that the contact point is at rest) is the kernel's t = 0 state."""
    np.testing.assert_allclose(
        NumpyRolling(run.body).initial(run.spins, ROLL), run.y0, rtol=0, atol=1e-15
    )


class _ContactFromC(NumpyRolling):
    def contact(self, up):  # rho measured from C instead of G
        rho, an, sigma = super().contact(up)
        return rho + self.G, an, sigma


class _WrongNormalisation(NumpyRolling):
    def contact(self, up):  # s_P = -A n_hat / |A n_hat| instead of / sqrt(n_hat^T A n_hat)
        an = self.A * up
        sigma = np.sqrt((an * an).sum(0))
        return -an / sigma - self.G, an, sigma


class _NoMigration(NumpyRolling):
    def contact(self, up):  # ds_P/dt = 0: the contact point does not move over the body
        rho, an, sigma = super().contact(up)
        return rho, np.zeros_like(an), sigma


def _mirrored_inertia(body):
    inertia = np.array(body.inertia)
    inertia[0, 1] = inertia[1, 0] = -inertia[0, 1]
    return types.SimpleNamespace(
        a=body.a,
        b=body.b,
        c=body.c,
        mass=body.mass,
        com=body.com,
        inertia=inertia,
        full_ellipsoid=body.full_ellipsoid,
    )


WRONG_MODELS = {
    "inertia product sign": lambda body: NumpyRolling(_mirrored_inertia(body)),
    "contact point from C": _ContactFromC,
    "contact point normalisation": _WrongNormalisation,
    "contact point migration dropped": _NoMigration,
}


@pytest.mark.parametrize("wrong", sorted(WRONG_MODELS))
def test_a_wrong_model_is_detected(wrong):
    """The comparison can fail: a model with one of these errors, against the kernel
    over 1 s of both kane_levinson launches, is far outside TOL."""
    body = rs.Body.preset("kane_levinson")
    spins = np.array([5.0, -5.0])
    ds, y0 = kernel_launch(body, spins, 1.0)
    _, spin = WRONG_MODELS[wrong](body).rk4(y0, float(ds.dt.values[0]), ds.time.size - 1)
    gap = relative_gap(ds.spin.values, spin.T, spins)
    assert np.all(gap > 10 * TOL), gap
