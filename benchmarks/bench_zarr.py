"""Benchmark of sweeps at scale into a zarr store: points per second, the peak memory of
the process that runs the sweep, and the store's size, against the grid size.

Run from the repository root (needs ``pip install -e '.[zarr]'``)::

    .venv/bin/python benchmarks/bench_zarr.py            # 1e5, 1e6, 1e7 points (minutes)
    .venv/bin/python benchmarks/bench_zarr.py --quick    # 1e5 and 1e6

The sweep is the toy rattleback over spin x misalignment x friction (mu = 0.3 and inf),
launched from a 0.5 degree roll, with a short ``t_end`` (0.05 s, 36 RK4 steps) so that
10^7 points take minutes on 2 cores; the memory does not depend on ``t_end``. Each size
runs in a fresh interpreter on local threads (every usable core), with the automatic
tile size. Printed per size and output: wall time, points per second, peak resident set
size (ru_maxrss) of that interpreter, and the output's size on disk. The netCDF output
(tiles merged into one file, whose merge holds every variable over the whole grid) runs
up to 10^6 points for comparison.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import math, resource, shutil, sys, tempfile, time
    from pathlib import Path
    from rattlesweep.sweep import Sweep, run_sweep
    n, output, t_end = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    side = max(2, math.ceil((n / 2) ** 0.5))  # at least n points
    sweep = Sweep(axes={"spin": {"start": -30.0, "stop": 30.0, "num": side},
                        "delta_deg": {"start": -8.0, "stop": 8.0, "num": side},
                        "mu": [0.3, float("inf")]},
                  fixed={"t_end": t_end, "roll_deg": 0.5}, output=output)
    base = Path(tempfile.mkdtemp(prefix="bench_zarr_"))
    out = base / ("run.zarr" if output == "zarr" else "run")
    t0 = time.perf_counter()
    ds = run_sweep(sweep, out, progress=False)
    wall = time.perf_counter() - t0
    files = [f for f in out.rglob("*") if f.is_file()]
    apparent = sum(f.stat().st_size for f in files)
    disk = sum(f.stat().st_blocks * 512 for f in files)
    reversed_ = int((ds.outcome == 1).sum())  # read back: the store holds the results
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(sweep.size, sweep.n_tiles, sweep.tile_size, wall, rss, apparent, disk, len(files),
          reversed_)
    shutil.rmtree(base)
""")


def run(n: int, output: str, t_end: float) -> list[float]:
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(n), output, str(t_end)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return [float(x) for x in out]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--t-end", type=float, default=0.05)
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0))
    print(
        f"bench_zarr: {cores} cores, load {os.getloadavg()[0]:.2f}, toy body, RK4, "
        f"t_end {args.t_end} s, automatic tile size, local threads"
    )
    run(10_000, "zarr", args.t_end)  # fills numba's cache outside the timed runs
    print(
        f"{'output':>6} {'points':>10} {'tiles':>5} {'tile':>6} {'wall s':>7} "
        f"{'points/s':>10} {'peak RSS MB':>11} {'B/point':>8} {'store MB':>8} "
        f"{'on disk MB':>10} {'files':>6}"
    )
    sizes = [100_000, 1_000_000] + ([] if args.quick else [10_000_000])
    for n in sizes:
        for output in ("zarr", "netcdf"):
            if output == "netcdf" and n > 1_000_000:
                continue
            size, tiles, tile, wall, rss, apparent, disk, files, _ = run(
                n, output, args.t_end
            )
            print(
                f"{output:>6} {size:>10.0f} {tiles:>5.0f} {tile:>6.0f} {wall:>7.1f} "
                f"{size / wall:>10,.0f} {rss / 2**20:>11.0f} {rss / size:>8.0f} "
                f"{apparent / 2**20:>8.1f} {disk / 2**20:>10.1f} {files:>6.0f}"
            )
    print(f"load at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
