"""Write ``event_reference.npz``: event-driven Coulomb stick/slip references
(``tests/event_reference.py``) against which the kernel's fixed-step switching is checked,
so that the default test run need not recompute them.

Cases (launch states read from the public API at t = 0, see ``launch_state``):

* ``a``: kane_levinson, spin +5 rad/s, pitch 0.5 deg, mu = 0.3, t_end = 3 s
* ``b``: the same launch, mu = 0.1, t_end = 3 s
* ``c``: the same launch, mu = 0.3, t_end = 6 s (through the first reversal)
* ``e``: the same launch, mu = 0.1, t_end = 6.5 s (through its first reversal)
* ``d03``, ``d01``: planar PlanarBody(0.10, 0.05, 1.0) (the homogeneous lamina of
  make_reference.py), theta0 = 0.3 rad from rest (rolling launch), mu = 0.3 and 0.1,
  t_end = 3 s

Each 3-D case stores ``<case>/t``, ``/spin`` (rad/s, at the samples), ``/slipping``,
``/switch_t`` (s), ``/switch_kind`` (+1 stick->slip, -1 slip->stick), ``/first_zero``,
``/first_reversal`` (s, NaN if none), ``/slip_fraction`` (over [0, t_end]),
``/slip_fraction_3`` (over [0, 3 s]), ``/y0`` (launch state), ``/mu``, ``/t_end``,
``/seconds`` (time to compute). Planar cases store ``/theta`` (rad) instead of ``/spin``
and ``/y0`` = (theta, theta_dot, x_G, x_G_dot). Global: ``rtol``, ``atol``, ``method``,
``scipy_version``, ``pitch``, ``spin0``.

Run: ``.venv/bin/python tests/data/make_event_reference.py`` (about a minute on one core).
``--compare-kernel`` prints how the kernel does against the stored references at the
default dt, dt/4 and dt/16 instead (no file is written).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import rattlesweep as rs
from rattlesweep.planar import PlanarBody, simulate_planar

HERE = Path(__file__).parent
PATH = HERE / "event_reference.npz"
sys.path.insert(0, str(HERE.parent))
from event_reference import (  # noqa: E402
    SCIPY_VERSION,
    launch_state,
    planar_events,
    rattleback_events,
)

RTOL, ATOL, METHOD = 1e-10, 1e-12, "LSODA"
SPIN0, PITCH = 5.0, math.radians(0.5)
CASES_3D = {"a": (0.3, 3.0), "b": (0.1, 3.0), "c": (0.3, 6.0), "e": (0.1, 6.5)}
THETA0 = 0.3
CASES_PLANAR = {"d03": (0.3, 3.0), "d01": (0.1, 3.0)}
SAMPLE_RATE = 1000  # samples per second (+1): 3001 on [0, 3]


def planar_body():
    return PlanarBody(0.10, 0.05, 1.0)


def launch_3d(mu):
    body = rs.Body.preset("kane_levinson")
    run = rs.simulate(
        body, spin=SPIN0, pitch=PITCH, mu=mu, t_end=body.default_dt(), record_every=1
    )
    return body, launch_state(run)


def launch_planar(mu):
    body = planar_body()
    run = simulate_planar(
        body, theta=THETA0, mu=mu, t_end=body.default_dt(), record_every=1
    )
    return body, launch_state(run)


def switch_arrays(res):
    kinds = {"stick->slip": 1, "slip->stick": -1}
    return (
        np.array([t for t, _ in res.switch_times], dtype=float),
        np.array([kinds[k] for _, k in res.switch_times], dtype=np.int8),
    )


def compute_3d(mu, t_end, *, rtol=RTOL, atol=ATOL, method=METHOD):
    body, y0 = launch_3d(mu)
    t = np.linspace(0.0, t_end, int(round(t_end * SAMPLE_RATE)) + 1)
    start = time.perf_counter()
    res = rattleback_events(
        body, y0, mu=mu, t_end=t_end, t_eval=t, rtol=rtol, atol=atol, method=method
    )
    seconds = time.perf_counter() - start
    if res.status != "ok":
        raise RuntimeError(f"reference run ended {res.status} at {res.t_final}")
    sw_t, sw_k = switch_arrays(res)
    return res, {
        "t": t,
        "spin": res.spin,
        "slipping": res.slipping,
        "switch_t": sw_t,
        "switch_kind": sw_k,
        "first_zero": res.first_zero_of_spin,
        "first_reversal": res.first_reversal_time,
        "slip_fraction": res.slip_fraction,
        "slip_fraction_3": res.slip_fraction_until(min(3.0, t_end)),
        "y0": y0,
        "mu": mu,
        "t_end": t_end,
        "seconds": seconds,
        "initial_slipping": int(res.initial_mode != "stick"),
    }


def compute_planar(mu, t_end, *, rtol=RTOL, atol=ATOL, method=METHOD):
    body, y0 = launch_planar(mu)
    t = np.linspace(0.0, t_end, int(round(t_end * SAMPLE_RATE)) + 1)
    start = time.perf_counter()
    res = planar_events(
        body,
        y0[0],
        y0[1],
        y0[3],
        mu=mu,
        t_end=t_end,
        t_eval=t,
        rtol=rtol,
        atol=atol,
        method=method,
    )
    seconds = time.perf_counter() - start
    if res.status != "ok":
        raise RuntimeError(f"reference run ended {res.status} at {res.t_final}")
    sw_t, sw_k = switch_arrays(res)
    return res, {
        "t": t,
        "theta": res.theta,
        "slipping": res.slipping,
        "switch_t": sw_t,
        "switch_kind": sw_k,
        "slip_fraction": res.slip_fraction,
        "slip_fraction_3": res.slip_fraction_until(min(3.0, t_end)),
        "y0": y0,
        "mu": mu,
        "t_end": t_end,
        "seconds": seconds,
        "initial_slipping": int(res.initial_mode != "stick"),
    }


def build():
    out = {
        "rtol": RTOL,
        "atol": ATOL,
        "method": METHOD,
        "scipy_version": SCIPY_VERSION,
        "pitch": PITCH,
        "spin0": SPIN0,
        "theta0": THETA0,
    }
    for case, (mu, t_end) in CASES_3D.items():
        _, d = compute_3d(mu, t_end)
        out.update({f"{case}/{k}": v for k, v in d.items()})
        print(
            f"{case}: mu={mu} t_end={t_end}: first zero {d['first_zero']:.6f} s, first "
            f"reversal {d['first_reversal']:.6f} s, slip fraction {d['slip_fraction']:.5f}"
            f" ([0, 3]: {d['slip_fraction_3']:.5f}), {d['switch_t'].size} switches, "
            f"{d['seconds']:.1f} s",
            flush=True,
        )
    for case, (mu, t_end) in CASES_PLANAR.items():
        _, d = compute_planar(mu, t_end)
        out.update({f"{case}/{k}": v for k, v in d.items()})
        print(
            f"{case}: mu={mu} t_end={t_end}: slip fraction {d['slip_fraction']:.5f}, "
            f"{d['switch_t'].size} switches, initially slipping "
            f"{d['initial_slipping']}, {d['seconds']:.2f} s",
            flush=True,
        )
    np.savez_compressed(PATH, **out)
    print(f"wrote {PATH}")


# --------------------------------------------------------------------------------------
def first_zero_sampled(t, x):
    """First sign change of a sampled series, linearly interpolated (NaN if none)."""
    s = np.sign(x)
    i = np.flatnonzero(s[1:] * s[0] < 0)
    if i.size == 0:
        return math.nan
    i = i[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def compare_kernel(divisors=(1, 4, 16), cases=("a", "b", "c", "e", "d03", "d01")):
    """Kernel runs at dt_default/k, recorded at every step, against the references
    (recomputed here for their dense output, so that the error is taken at every kernel
    step; also checked against the stored samples). Prints first zero / first reversal /
    slip fraction / max error. Writes nothing."""
    stored = np.load(PATH)
    print(
        f"reference: {stored['method']} rtol={stored['rtol']} atol={stored['atol']}, "
        f"scipy {stored['scipy_version']}"
    )
    for case in cases:
        planar = case.startswith("d")
        mu, t_end = (CASES_PLANAR if planar else CASES_3D)[case]
        res, d = (compute_planar if planar else compute_3d)(mu, t_end)
        key = "theta" if planar else "spin"
        drift = np.abs(d[key] - stored[f"{case}/{key}"]).max()
        if planar:
            print(
                f"\nplanar case {case} (mu={mu}, t_end={t_end}): reference slip "
                f"fraction {d['slip_fraction']:.5f}, {d['switch_t'].size} switches "
                f"(recomputed in {d['seconds']:.1f} s, max change from stored {drift:.1e})"
            )
        else:
            print(
                f"\n3-D case {case} (mu={mu}, t_end={t_end}): reference first zero "
                f"{d['first_zero']:.6f}, first reversal {d['first_reversal']:.6f}, slip "
                f"fraction {d['slip_fraction']:.5f} ([0, 3]: {d['slip_fraction_3']:.5f}) "
                f"(recomputed in {d['seconds']:.1f} s, max change from stored {drift:.1e})"
            )
        for k in divisors:
            if planar:
                body = planar_body()
                dt = body.default_dt() / k
                ds = simulate_planar(
                    body, theta=THETA0, mu=mu, t_end=t_end, dt=dt, record_every=1
                )
                t, x = ds.time.values, ds.angle.values
                err = np.abs(x - res.theta_at(t)).max()
                sl = ds.slipping.values
                print(
                    f"  dt/{k:<2d} = {dt:.3e}: slip fraction "
                    f"{float(ds.slip_fraction):.5f} (recorded mean {sl[1:].mean():.5f}), "
                    f"{np.count_nonzero(np.diff(sl))} mode changes at samples, "
                    f"max |dtheta| {err:.2e} rad, status {int(ds.status)}"
                )
            else:
                body = rs.Body.preset("kane_levinson")
                dt = body.default_dt() / k
                ds = rs.simulate(
                    body, spin=SPIN0, pitch=PITCH, mu=mu, t_end=t_end, dt=dt, record_every=1
                )
                t, x = ds.time.values, ds.spin.values
                err = np.abs(x - res.spin_at(t)).max()
                three = t <= 3.0 + 1e-12
                print(
                    f"  dt/{k:<2d} = {dt:.3e}: first zero {first_zero_sampled(t, x):.6f},"
                    f" first reversal {float(ds.first_reversal_time):.6f}, slip fraction "
                    f"{float(ds.slip_fraction):.5f} (recorded mean "
                    f"{ds.slipping.values[1:].mean():.5f}; [0, 3] "
                    f"{ds.slipping.values[1:][three[1:]].mean():.5f}), "
                    f"max |dn| {err:.2e} rad/s, status {int(ds.status)}"
                )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--compare-kernel",
        action="store_true",
        help="compare the kernel with the stored references instead",
    )
    args = parser.parse_args()
    compare_kernel() if args.compare_kernel else build()
