"""Benchmark and acceptance check of adaptive refinement and stopping at the answer.

Run from the repository root::

    .venv/bin/python benchmarks/bench_refine.py                  # both: ~15 min, 2 cores
    .venv/bin/python benchmarks/bench_refine.py --problem demo   # the demo map only
    .venv/bin/python benchmarks/bench_refine.py --keep runs/bench   # keep the outputs

For each problem, in this process and in this order, on ``--workers`` local threads
(default: every core), each into a fresh directory, timed end to end (``run_sweep``:
tasks, tile files, the result file):

1. "full": the map simulated at every point of the finest grid;
2. "adaptive": the declared grid refined ``levels`` times
   (:mod:`rattlesweep.sweep._refinement.plan`);
3. "adaptive+stop": the same with ``stop = "first_reversal"``;
4. "full+stop": every point of the finest grid with the stop (skipped with --no-full-stop).

Printed: wall times and speed-ups against "full"; the fraction of points simulated;
the outcome mismatch of each adaptive map against the full map (the stop run against the
full map's outcomes at the first reversal), with the missed points by (full, adaptive)
outcome; the distribution of |first_reversal_time| differences where both reversed
(every point, and filled points only); whether "full+stop" has exactly the full map's
first reversal times and stopped outcomes (it must); and the block efficiency of the
stop runs (lane-steps used over lane-steps paid, blocks of 32 consecutive points of a
task: a block runs until its last lane stops).

First, how a block of the kernel (BLOCK = 32 lanes) costs when only some of its lanes
still run: 64 blocks of the toy launched at 20 rad/s for 2 s, all but k lanes of each
block ending at once (a non-finite launch), on one thread, best of 3.

Problems:

- ``demo``: ``rattlesweep demo``'s map without its own refinement, declared 41 x 33 x
  mu (0.3, inf), refined 3 levels to 321 x 257 x 2;
- ``thin``: spin x friction (log) at 6 degrees misalignment, 31 x 25 refined 3 levels to
  241 x 193. A band of launches that stop spinning, 3 to 5 points of the finest grid
  wide (less than one declared cell), runs along the boundary between reversing and
  not; capsize slivers of one or two points fringe the capsize region.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

from rattlesweep import Body, run_batch
from rattlesweep.sweep import (
    DEMO_TOML,
    Sweep,
    at_first_reversal,
    compare_with_full,
    run_sweep,
)
from rattlesweep._core.workspace import BLOCK

THIN_TOML = """\
name = "thin: spin x friction at 6 degrees misalignment"
[axes]
spin = { start = -30, stop = 0, num = 31 }
mu = { start = 0.03, stop = 1.0, num = 25, scale = "log" }
[fixed]
t_end = 5.0
roll_deg = 0.5
delta_deg = 6.0
[refine]
levels = 3
"""

PROBLEMS = {"demo": DEMO_TOML, "thin": THIN_TOML}


def variants(toml: str) -> dict[str, Sweep]:
    base = Sweep.from_toml(toml).to_dict()
    base.pop("stop", None)
    refine = base.pop("refine", None) or {"levels": 3}
    adaptive = Sweep(**base, refine=refine)
    # the full grid with its own automatic tile size, as a user would run it
    full = {**adaptive.finest().to_dict(), "tile_size": None}
    return {
        "full": Sweep(**full),
        "adaptive": adaptive,
        "adaptive+stop": Sweep(**base, refine=refine, stop="first_reversal"),
        "full+stop": Sweep(**full, stop="first_reversal"),
    }


def block_efficiency(steps_in_task_order: list[np.ndarray]) -> float:
    used = paid = 0
    for steps in steps_in_task_order:
        for a in range(0, len(steps), BLOCK):
            block = steps[a : a + BLOCK]
            used += int(block.sum())
            paid += BLOCK * int(block.max())
    return used / paid


def task_steps(out: Path) -> list[np.ndarray]:
    """The steps of every task's points in the order the task ran them."""
    files = sorted(out.glob("levels/level-*/tile-*.nc")) or sorted(
        out.glob("tiles/tile-*.nc")
    )
    steps = []
    for path in files:
        with xr.open_dataset(path) as ds:
            steps.append(ds.steps.values)
    return steps


def distribution(d: np.ndarray) -> str:
    if d.size == 0:
        return "none"
    q = np.quantile(d, [0.5, 0.9, 0.99])
    return (
        f"n={d.size}, exact {np.mean(d == 0):.1%}, median {q[0]:.2g} s, 90% {q[1]:.2g} s, "
        f"99% {q[2]:.2g} s, max {d.max():.2g} s"
    )


def stopped_lanes() -> None:
    toy = Body.preset("toy")
    n_blocks = 64

    def seconds(live: int) -> float:
        spin = np.full((n_blocks, BLOCK), 20.0)
        spin[:, live:] = np.nan  # a non-finite launch ends at step 0
        best = math.inf
        for _ in range(3):
            t0 = time.perf_counter()
            run_batch(
                toy, spin=spin.ravel(), mu=0.3, roll=math.radians(0.5), t_end=2.0, threads=1
            )
            best = min(best, time.perf_counter() - t0)
        return best

    seconds(BLOCK)
    print("lanes running per block of 32: time per block")
    for live in (32, 16, 8, 1, 32):
        print(f"  {live:2d}: {seconds(live) / n_blocks * 1e3:.2f} ms", flush=True)


def run_problem(name: str, root: Path, workers: int, full_stop: bool) -> None:
    print(f"\n=== {name} ===")
    sweeps = variants(PROBLEMS[name])
    fine = sweeps["full"]
    print(
        f"declared {sweeps['adaptive'].shape}, finest {fine.shape} = {fine.size:,} points, "
        f"{workers} workers"
    )
    results, times = {}, {}
    for label, sweep in sweeps.items():
        if label == "full+stop" and not full_stop:
            continue
        out = root / f"{name}-{label}"
        shutil.rmtree(out, ignore_errors=True)
        t0 = time.perf_counter()
        results[label] = run_sweep(sweep, out, workers=workers, progress=False)
        times[label] = time.perf_counter() - t0
        eff = block_efficiency(task_steps(out)) if "stop" in label else None
        print(
            f"{label:>14}: {times[label]:7.1f} s  x{times['full'] / times[label]:5.2f}"
            + (
                f"  simulated {results[label].attrs['points_simulated'] / fine.size:.1%}"
                if "points_simulated" in results[label].attrs
                else ""
            )
            + (f"  block efficiency {eff:.3f}" if eff is not None else ""),
            flush=True,
        )
    full = results["full"]
    for label in ("adaptive", "adaptive+stop"):
        c = compare_with_full(results[label], full)
        print(
            f"{label}: outcome mismatch {c['mismatch']:.3%} "
            f"({round(c['mismatch'] * c['points'])}"
            f" points, {c['mismatch_filled']} of them filled), simulated "
            f"{c['simulated']:.1%}"
        )
        for (a, b), n in c["misses"].items():
            print(f"    full {a} -> adaptive {b}: {n}")
        print(
            f"  |first_reversal_time difference| where both reversed: "
            f"{distribution(c['time_difference'])}"
        )
        print(f"    filled points only: {distribution(c['time_difference_filled'])}")
    if "full+stop" in results:
        fs = results["full+stop"]
        same_t = np.array_equal(
            fs.first_reversal_time.values, full.first_reversal_time.values, equal_nan=True
        )
        same_o = np.array_equal(
            fs.outcome.values,
            at_first_reversal(full.outcome.values, full.n_reversals.values),
        )
        steps = float(fs.steps.sum() / full.steps.sum())
        print(
            f"full+stop against full: first_reversal_time identical {same_t}, outcome at "
            f"the first reversal identical {same_o}; lane-steps {steps:.1%} of full"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", choices=[*PROBLEMS, "all"], default="all")
    parser.add_argument("--workers", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--keep", default=None, help="directory for the outputs (kept)")
    parser.add_argument(
        "--no-full-stop", action="store_true", help="skip the full grid with the stop rule"
    )
    args = parser.parse_args()
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench_refine_"))
    root.mkdir(parents=True, exist_ok=True)
    # compile (or load) the kernels outside the timings
    warm = Sweep(axes={"spin": [5.0, -5.0]}, fixed={"t_end": 0.1})
    run_sweep(warm, root / "warm-up", workers=1, progress=False)
    try:
        stopped_lanes()
        for name in PROBLEMS if args.problem == "all" else [args.problem]:
            run_problem(name, root, args.workers, not args.no_full_stop)
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
