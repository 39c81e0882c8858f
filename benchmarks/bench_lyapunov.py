"""Cost of the largest Lyapunov exponent: a batch with ``lyapunov=True`` against the
same batch without, run in the same process with the kernels warm.

    python benchmarks/bench_lyapunov.py [--rounds 3] [--t-end 2.0]

Batches of 256 and 4096 rolling launches of the toy and the kane_levinson bodies (spins
from -20 to 20 rad/s, rolls from -3 to 3 degrees), on 1 and 2 threads. For each it prints
the median wall time of both runs over the rounds, trajectories per second, and the
ratio (the issue's bound: 3). A Lyapunov batch steps each launch and its shadow, so
the ratio's floor is about 2.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import rattlesweep as rs


def timed(body: rs.Body, n: int, t_end: float, threads: int, lyapunov: bool) -> float:
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    rs.run_batch(
        body,
        spin=rng.uniform(-20.0, 20.0, n),
        roll_deg=rng.uniform(-3.0, 3.0, n),
        t_end=t_end,
        threads=threads,
        lyapunov=lyapunov,
    )
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=2.0)
    args = parser.parse_args()
    bodies = {name: rs.Body.preset(name) for name in ("toy", "kane_levinson")}
    for body in bodies.values():  # compile or load, outside the timings
        timed(body, 64, 0.01, 1, True)
        timed(body, 64, 0.01, 1, False)
    print(f"t_end = {args.t_end} s, median of {args.rounds} rounds")
    print(
        f"{'body':15s} {'n':>5s} {'thr':>3s} {'plain s':>8s} {'lyap s':>8s} "
        f"{'plain traj/s':>13s} {'lyap traj/s':>12s} {'ratio':>6s}"
    )
    for name, body in bodies.items():
        for n in (256, 4096):
            for threads in (1, 2):
                plain, lyap = [], []
                for _ in range(args.rounds):
                    plain.append(timed(body, n, args.t_end, threads, False))
                    lyap.append(timed(body, n, args.t_end, threads, True))
                p, q = statistics.median(plain), statistics.median(lyap)
                print(
                    f"{name:15s} {n:5d} {threads:3d} {p:8.3f} {q:8.3f} "
                    f"{n / p:13.0f} {n / q:12.0f} {q / p:6.2f}"
                )


if __name__ == "__main__":
    main()
