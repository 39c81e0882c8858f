"""Benchmark of `rattlesweep fit` against the usual route, one model run at a time.

    python benchmarks/bench_fit.py [--seconds 10]
    python benchmarks/bench_fit.py --coverage 20 [--seconds 5]

Data: 10 s of 100 Hz gyroscope rates made by the model (kane_levinson body, mu = 0.4,
damping 2e-4 N m s, roll 1 degree, spin -3 rad/s), plus a bias per axis and noise of
0.02 rad/s. Both routes fit damping, roll_deg, spin and mu (bounds 1e-5..1e-3,
0.2..3, -5..-1, 0.1..1) to the same features (rattlesweep.fitting.objective), with the
kernels warm:

1. `rattlesweep.fitting.fit`: batches of candidates as lanes of `run_batch`, with the
   profile-likelihood intervals;
2. `scipy.optimize.least_squares` (trust-region reflective, 2-point Jacobian) around
   one `simulate` per evaluation, from the middle of the bounds, without intervals.

It prints each route's wall time, model runs and fitted values, and the time per model
run. ``--coverage N`` instead fits damping, roll_deg and spin (mu fixed at the truth) to
N recordings that differ in their noise draw, and prints how often each 95 % interval
holds the truth.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import rattlesweep as rs
from rattlesweep.fitting import Measurement, fit
from rattlesweep.fitting.api import _Runner
from rattlesweep.fitting.objective import measured_features
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


def one_at_a_time(m: Measurement) -> tuple[dict, int, float]:
    from scipy.optimize import least_squares

    body = rs.Body.preset("kane_levinson")
    bounds = bounds_from(FREE)
    runner = _Runner(m, measured_features(m, 0.5), body, bounds, {}, True, None, 1.0)
    runs = [0]

    def residuals(u: np.ndarray) -> np.ndarray:
        runs[0] += 1
        _, r = runner.evaluate(u[None])  # one candidate, one lane
        return r[0]

    began = time.perf_counter()
    sol = least_squares(
        residuals, np.full(len(bounds), 0.5), bounds=(0.0, 1.0), diff_step=2e-3
    )
    seconds = time.perf_counter() - began
    values = {b.name: float(b.value(np.array(sol.x[k]))) for k, b in enumerate(bounds)}
    return values, runs[0], seconds


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
    args = ap.parse_args()
    if args.coverage:
        coverage(args.coverage, args.seconds)
        return
    m = data(args.seconds)
    rs.run_batch(rs.Body.preset("kane_levinson"), spin=[-3.0], mu=0.4, t_end=0.01)  # warm
    began = time.perf_counter()
    result = fit(m, "kane_levinson", FREE)
    batch_s = time.perf_counter() - began
    values, runs, single_s = one_at_a_time(m)
    print(f"4-input fit of {args.seconds:g} s of 100 Hz gyroscope data, kernels warm")
    head = ("input", "truth", "batch fit", "95 % interval", "one at a time")
    print("{:<10} {:>10} {:>12} {:>26} {:>14}".format(*head))
    for name, truth in TRUTH.items():
        f = result.fitted[name]
        interval = f"{f.low:.4g} .. {f.high:.4g}" + ("" if f.determined else " (n.d.)")
        row = (name, truth, f.value, interval, values[name])
        print("{:<10} {:>10.4g} {:>12.4g} {:>26} {:>14.4g}".format(*row))
    print(
        f"batch fit:      {batch_s:7.1f} s, {result.evaluations} model runs "
        f"({1e3 * batch_s / result.evaluations:.2f} ms each), with intervals"
    )
    print(
        f"one at a time:  {single_s:7.1f} s, {runs} model runs "
        f"({1e3 * single_s / runs:.1f} ms each), no intervals"
    )
    per_batch, per_single = batch_s / result.evaluations, single_s / runs
    print(
        f"per model run the batch is {per_single / per_batch:.0f} x faster; the "
        f"one-at-a-time route would need {per_single * result.evaluations:.0f} s for the "
        "batch fit's runs"
    )


if __name__ == "__main__":
    main()
