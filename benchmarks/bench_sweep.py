"""Benchmark of the sweep layer: overhead against the raw kernel, memory, worker scaling.

Run from the repository root::

    .venv/bin/python benchmarks/bench_sweep.py            # full: a few minutes on 2 cores
    .venv/bin/python benchmarks/bench_sweep.py --quick    # 2e4 and 1e5 points

The sweep is the toy rattleback over spin x misalignment x friction (mu = 0.3 and inf),
launched from a 0.5 degree roll, at its default dt (RK4). Sections:

1. Overhead. For the same N points, in this process:
   - "kernel": ``rattlesweep._run.execute`` on the points packed once by ``prepare``,
     on ``w`` threads (``parallel=False`` for w = 1; ``parallel=True, threads=w``
     otherwise). This is the raw numba time.
   - "prepare": packing the points (Python/NumPy), timed separately.
   - "sweep": ``run_sweep`` into a fresh directory with ``workers=w``: dask tasks,
     per-tile packing, the kernel, tile files, merge and the final netCDF write.
   overhead = sweep / kernel - 1. Each figure is the best of ``--repeats`` runs after an
   untimed warm-up. Also printed: trajectory-steps per second of both.
2. Scaling: sweep wall time with 1 and 2 workers on the same grid; ratio = t1 / t2.
3. Memory: peak resident set size (ru_maxrss) of a fresh interpreter that imports
   rattlesweep and runs a sweep of N points (t_end shortened so that 1e6 points take
   seconds; memory does not depend on t_end), for N = 1e4, 1e5, 1e6 (1e6 skipped with
   --quick). The sweep's merge holds one array per result variable over the whole grid
   (about 120 B per point); everything else is per tile.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time


from rattlesweep.rattleback.batch import prepare
from rattlesweep._run import execute
from rattlesweep.sweep import Sweep, run_sweep
from rattlesweep._core.workspace import RK4


def grid_sweep(n_target: int, t_end: float, tile_size: int | None = None) -> Sweep:
    """About n_target points: spin x delta x mu(2)."""
    side = max(2, int(round((n_target / 2) ** 0.5)))
    return Sweep(
        axes={
            "spin": {"start": -30.0, "stop": 30.0, "num": side},
            "delta_deg": {"start": -8.0, "stop": 8.0, "num": side},
            "mu": [0.3, float("inf")],
        },
        fixed={"t_end": t_end, "roll_deg": 0.5},
        tile_size=tile_size,
    )


def best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def overhead(n: int, t_end: float, workers: int, repeats: int) -> dict:
    sweep = grid_sweep(n, t_end)
    t0 = time.perf_counter()
    bodies, kwargs = sweep.points(0, sweep.size)
    prep = prepare(bodies, **kwargs)
    t_prepare = time.perf_counter() - t0
    steps = int(prep.nsteps.sum())

    def kernel():
        execute(
            prep,
            method=RK4,
            record_every=None,
            band=sweep.reversal_band,
            parallel=workers > 1,
            threads=workers if workers > 1 else None,
        )

    kernel()
    t_kernel = best_of(kernel, repeats)
    tmp = tempfile.mkdtemp(prefix="bench_sweep_")

    def sweep_once():
        shutil.rmtree(tmp, ignore_errors=True)
        run_sweep(sweep, tmp, workers=workers, progress=False)

    sweep_once()
    t_sweep = best_of(sweep_once, repeats)
    shutil.rmtree(tmp, ignore_errors=True)
    return {
        "n": sweep.size,
        "tiles": sweep.n_tiles,
        "steps": steps,
        "prepare": t_prepare,
        "kernel": t_kernel,
        "sweep": t_sweep,
    }


PEAK_SCRIPT = textwrap.dedent("""
    import resource, sys, tempfile, time
    sys.path.insert(0, {bench_dir!r})
    from bench_sweep import grid_sweep
    from rattlesweep.sweep import run_sweep
    sweep = grid_sweep({n}, {t_end})
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        ds = run_sweep(sweep, d, progress=False)
        size = sum(f.stat().st_size for f in __import__("pathlib").Path(d).rglob("*.nc"))
    print(sweep.size, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
          time.perf_counter() - t0, size)
""")


def peak_memory(n: int, t_end: float) -> tuple[int, int, float, int]:
    script = PEAK_SCRIPT.format(
        bench_dir=os.path.dirname(os.path.abspath(__file__)), n=n, t_end=t_end
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    ).stdout.split()
    return int(out[0]), int(out[1]), float(out[2]), int(out[3])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--t-end", type=float, default=2.0, help="s, for sections 1-2")
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0))
    print(
        f"bench_sweep: {cores} cores, load {os.getloadavg()[0]:.2f}, toy body, RK4, "
        f"t_end {args.t_end} s, automatic tile size"
    )

    print("\n1-2. overhead and scaling (best of %d)" % args.repeats)
    print(
        f"{'points':>8} {'tiles':>5} {'workers':>7} {'prepare s':>9} {'kernel s':>9} "
        f"{'sweep s':>8} {'overhead':>8} {'kernel Msteps/s':>15} {'sweep Msteps/s':>14}"
    )
    sizes = [20_000, 100_000] if args.quick else [100_000]
    for n in sizes:
        by_workers = {}
        for w in sorted({1, min(2, cores)}):
            r = overhead(n, args.t_end, w, args.repeats)
            by_workers[w] = r
            print(
                f"{r['n']:>8} {r['tiles']:>5} {w:>7} {r['prepare']:>9.2f} "
                f"{r['kernel']:>9.2f} {r['sweep']:>8.2f} "
                f"{r['sweep'] / r['kernel'] - 1:>8.1%} "
                f"{r['steps'] / r['kernel'] / 1e6:>15.2f} "
                f"{r['steps'] / r['sweep'] / 1e6:>14.2f}"
            )
        if 2 in by_workers:
            print(
                f"{'':>8} scaling 1 -> 2 workers: sweep "
                f"{by_workers[1]['sweep'] / by_workers[2]['sweep']:.2f}x, "
                f"kernel {by_workers[1]['kernel'] / by_workers[2]['kernel']:.2f}x"
            )

    print("\n3. peak resident memory of a fresh process running a sweep (t_end 0.05 s)")
    print(f"{'points':>9} {'peak RSS MB':>11} {'B/point':>8} {'wall s':>7} {'files MB':>8}")
    for n in [10_000, 100_000] if args.quick else [10_000, 100_000, 1_000_000]:
        size, rss, wall, files = peak_memory(n, 0.05)
        print(
            f"{size:>9} {rss / 2**20:>11.0f} {rss / size:>8.0f} {wall:>7.1f} "
            f"{files / 2**20:>8.1f}"
        )
    print(f"\nload at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
