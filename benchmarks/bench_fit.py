"""Benchmark of `rattlesweep fit` against the usual route, one model run at a time.

    python benchmarks/bench_fit.py [--seconds 10] [--ivp-runs 60]
    python benchmarks/bench_fit.py --coverage 20 [--seconds 5]

Data: 10 s of 100 Hz gyroscope rates made by the model (kane_levinson body, mu = 0.4,
damping 2e-4 N m s, roll 1 degree, spin -3 rad/s), plus a bias per axis and noise of
0.02 rad/s. Every route fits damping, roll_deg, spin and mu (bounds 1e-5..1e-3,
0.2..3, -5..-1, 0.1..1) to the same features (rattlesweep.fitting.objective), with the
kernels warm:

1. `rattlesweep.fitting.fit`: batches of candidates as lanes of `run_batch`, with the
   profile-likelihood intervals;
2. `scipy.optimize.least_squares` (trust-region reflective, 2-point Jacobian, from the
   middle of the bounds, no intervals) around one `rattlesweep.simulate` per
   evaluation: the route a user of any simulator takes;
3. the same around a one-lane batch without building a dataset (the kernel's own cost
   per run: the fairest one-at-a-time baseline);
4. the same around `scipy.integrate.solve_ivp` of the same equations (the event-driven
   stick/slip solution of tests/event_reference.py, LSODA, rtol 1e-6), stopped after
   ``--ivp-runs`` runs (0: skipped) since a run takes seconds; its per-run time and the
   time it would need for route 2's runs are printed.

It prints each route's wall time, model runs and fitted values, and the time per model
run. ``--coverage N`` instead fits damping, roll_deg and spin (mu fixed at the truth) to
N recordings that differ in their noise draw, and prints how often each 95 % interval
holds the truth.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import rattlesweep as rs
from rattlesweep.fitting import Measurement, fit
from rattlesweep.fitting.api import _Runner
from rattlesweep.fitting.objective import compare, measured_features
from rattlesweep.fitting.parameters import bounds_from

TRUTH = {"damping": 2e-4, "roll_deg": 1.0, "spin": -3.0, "mu": 0.4}
FREE = {
    "damping": (1e-5, 1e-3),
    "roll_deg": (0.2, 3.0),
    "spin": (-5.0, -1.0),
    "mu": (0.1, 1.0),
}


def data(seconds: float, seed: int = 0) -> Measurement:
    body = rs.Body.preset("kane_levinson")
    run = rs.simulate(body, t_end=seconds, record_every=1, **TRUTH)
    t = np.arange(0.0, seconds, 0.01)
    omega = np.stack(
        [np.interp(t, run.time.values, run.omega.values[:, k]) for k in range(3)], 1
    )
    rng = np.random.default_rng(seed)
    return Measurement(
        "gyro", t, omega + [0.02, -0.01, 0.03] + rng.normal(0, 0.02, omega.shape), "bench"
    )


def _least_squares(m: Measurement, series) -> tuple[dict, int, float, bool]:
    """least_squares from the middle of the bounds; ``series(values)`` gives (times,
    body rates (times, 3)) of one run. Returns the fitted values, runs, seconds and
    whether it converged within its budget."""
    from scipy.optimize import least_squares

    bounds = bounds_from(FREE)
    measured = measured_features(m, 0.5)
    runs = [0]

    def residuals(u: np.ndarray) -> np.ndarray:
        runs[0] += 1
        values = {b.name: float(b.value(np.array(u[k]))) for k, b in enumerate(bounds)}
        t, omega = series(values)
        return compare(m, measured, t, omega[None]).residuals[0]

    began = time.perf_counter()
    sol = least_squares(
        residuals, np.full(len(bounds), 0.5), bounds=(0.0, 1.0), diff_step=2e-3
    )
    seconds = time.perf_counter() - began
    values = {b.name: float(b.value(np.array(sol.x[k]))) for k, b in enumerate(bounds)}
    return values, runs[0], seconds, bool(sol.success)


def around_simulate(m: Measurement, body: rs.Body, dt: float, every: int):
    def series(values):
        run = rs.simulate(
            body, t_end=m.duration + 2 * dt * every, dt=dt, record_every=every, **values
        )
        return run.time.values, run.omega.values

    return _least_squares(m, series)


def around_one_lane(m: Measurement, body: rs.Body):
    runner = _Runner(
        m, measured_features(m, 0.5), body, bounds_from(FREE), {}, True, None, 1.0
    )
    bounds = runner.bounds

    def series(values):
        cube = np.array([[b.unit(values[b.name]) for b in bounds]])
        t, omega = runner.run(cube)
        return t, omega[0]

    return _least_squares(m, series)


class _Budget(Exception):
    pass


def around_solve_ivp(m: Measurement, body: rs.Body, runs: int, dt: float, every: int):
    """least_squares around the event-driven solve_ivp solution, stopped after ``runs``
    runs: (values at the last evaluation, runs, seconds, converged)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from event_reference import launch_state, rattleback_events

    times = np.arange(0.0, m.duration + 2 * dt * every, dt * every)
    last: dict = {}

    def series(values):
        if len(last) >= runs:
            raise _Budget
        start = rs.simulate(
            body,
            t_end=dt,
            dt=dt,
            spin=values["spin"],
            roll_deg=values["roll_deg"],
            mu=values["mu"],
            record_every=1,
        )
        ev = rattleback_events(
            body,
            launch_state(start),
            mu=values["mu"],
            damping=values["damping"],
            t_end=times[-1],
            rtol=1e-6,
            atol=1e-8,
            t_eval=times,
        )
        last[len(last)] = values
        return ev.t, ev.y[:, 4:7]

    began = time.perf_counter()
    try:
        values, n, _, converged = _least_squares(m, series)
    except _Budget:
        values, n, converged = last[len(last) - 1], len(last), False
    return values, n, time.perf_counter() - began, converged


def coverage(draws: int, seconds: float) -> None:
    free = {k: FREE[k] for k in ("damping", "roll_deg", "spin")}
    inside = {k: 0 for k in free}
    began = time.perf_counter()
    for seed in range(draws):
        result = fit(data(seconds, seed + 1), "kane_levinson", free, {"mu": TRUTH["mu"]})
        for k in free:
            f = result.fitted[k]
            inside[k] += f.low <= TRUTH[k] <= f.high
    print(
        f"coverage of the 95 % intervals over {draws} noise draws of {seconds:g} s "
        f"({time.perf_counter() - began:.0f} s):"
    )
    for k, n in inside.items():
        print(f"  {k:<10} {n}/{draws} = {n / draws:.0%}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="length of the data (s)")
    ap.add_argument("--coverage", type=int, default=0, help="noise draws (0: the timing)")
    ap.add_argument(
        "--ivp-runs", type=int, default=60, help="runs of the solve_ivp route (0: none)"
    )
    args = ap.parse_args()
    if args.coverage:
        coverage(args.coverage, args.seconds)
        return
    m = data(args.seconds)
    body = rs.Body.preset("kane_levinson")
    rs.run_batch(body, spin=[-3.0], mu=0.4, t_end=0.01)  # warm
    began = time.perf_counter()
    result = fit(m, "kane_levinson", FREE)
    batch_s = time.perf_counter() - began
    probe = _Runner(
        m, measured_features(m, 0.5), body, bounds_from(FREE), {}, True, None, 1.0
    )
    dt, every = probe.dt, probe.record_every
    routes = {
        "simulate": around_simulate(m, body, dt, every),
        "one lane": around_one_lane(m, body),
    }
    if args.ivp_runs:
        routes["solve_ivp"] = around_solve_ivp(m, body, args.ivp_runs, dt, every)
    print(f"4-input fit of {args.seconds:g} s of 100 Hz gyroscope data, kernels warm")
    head = ("input", "truth", "batch fit", "95 % interval", *routes)
    print(("{:<10} {:>10} {:>12} {:>26}" + " {:>12}" * len(routes)).format(*head))
    for name, truth in TRUTH.items():
        f = result.fitted[name]
        interval = f"{f.low:.4g} .. {f.high:.4g}" + ("" if f.determined else " (n.d.)")
        row = (name, truth, f.value, interval, *(r[0][name] for r in routes.values()))
        print(
            ("{:<10} {:>10.4g} {:>12.4g} {:>26}" + " {:>12.4g}" * len(routes)).format(*row)
        )
    per_batch = batch_s / result.evaluations
    print(
        f"batch fit:           {batch_s:7.1f} s, {result.evaluations:6d} model runs "
        f"({1e3 * per_batch:.2f} ms each), with intervals"
    )
    for name, (_, runs, seconds, converged) in routes.items():
        per = seconds / runs
        state = "converged" if converged else "stopped, not converged"
        print(
            f"around {name + ':':<13} {seconds:7.1f} s, {runs:6d} model runs "
            f"({1e3 * per:.1f} ms each), no intervals, {state}; per run the batch is "
            f"{per / per_batch:.0f} x faster; the batch fit's runs would take "
            f"{per * result.evaluations:.0f} s"
        )
    if "solve_ivp" in routes:
        per = routes["solve_ivp"][2] / routes["solve_ivp"][1]
        print(
            f"solve_ivp at route 'simulate''s {routes['simulate'][1]} runs: about "
            f"{per * routes['simulate'][1]:.0f} s"
        )


if __name__ == "__main__":
    main()
