"""Benchmark of linear-stability maps: time for an N x N grid of spin x misalignment.

    .venv/bin/python benchmarks/bench_stability.py [--n 500]

Times, in this process, ``stability_dataset`` on a toy-body sweep grid (spin from -30 to
30 rad/s, misalignment from -8 to 8 degrees): building the grid and the bodies (one per
misalignment, cached), the analytic 4x4 linearisation, the batched eigen-decomposition
and the Dataset. Best of 3 after a warm-up.
"""

import argparse
import time

from rattlesweep.stability import stability_dataset
from rattlesweep.sweep import Sweep


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=500)
    args = parser.parse_args()
    sweep = Sweep(
        axes={
            "spin": {"start": -30, "stop": 30, "num": args.n},
            "delta_deg": {"start": -8, "stop": 8, "num": args.n},
        }
    )
    stability_dataset(sweep)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        ds = stability_dataset(sweep)
        times.append(time.perf_counter() - t0)
    n = ds.growth_rate.size
    print(
        f"stability map {args.n} x {args.n} = {n} points: best {min(times):.2f} s "
        f"({n / min(times):,.0f} points/s); unstable fraction "
        f"{float((ds.growth_rate > 0).mean()):.3f}"
    )


if __name__ == "__main__":
    main()
