"""Benchmark of the cold start: what a new user waits for, from an empty numba cache.

    python benchmarks/bench_cold_start.py [--jobs N] [--skip-cold-demo]

Each figure is measured in fresh processes pointed at a new, empty numba cache
(``NUMBA_CACHE_DIR``), as on a first install:

1. ``rattlesweep compile``: wall time, and the longest time between two lines it prints;
   then a second call, which finds everything compiled;
2. after it, in a new process each (seconds from before ``import rattlesweep``): the
   first ``simulate`` at mu = 0.3, the first rolling ``run_batch``, the first planar
   run, and ``rattlesweep demo``;
3. without it (another empty cache): ``rattlesweep demo`` end to end, and the longest
   time it printed nothing.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

FIRST_CALLS = {
    "simulate, mu = 0.3": (
        "import rattlesweep as rs\n"
        "rs.simulate(rs.Body.preset('kane_levinson'), spin=5.0, roll_deg=0.5, mu=0.3, "
        "t_end=1.0)\n"
    ),
    "run_batch, rolling": (
        "import numpy as np, rattlesweep as rs\n"
        "rs.run_batch(rs.Body.preset('kane_levinson'), spin=np.linspace(-5, 5, 64), "
        "roll_deg=0.5, t_end=1.0)\n"
    ),
    "planar run": (
        "from rattlesweep.planar import PlanarBody, run_planar_batch\n"
        "run_planar_batch(PlanarBody(a=0.1, b=0.05, mass=0.1), theta=[0.1, 0.2], "
        "mu=0.3, t_end=1.0)\n"
    ),
}


def timed_lines(command: list[str], env: dict[str, str]) -> tuple[float, float, list[str]]:
    """Run ``command``; (wall seconds, longest gap in seconds between two lines of its
    output, counted from the start and to the end, the lines)."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    assert proc.stdout is not None
    last, gap, lines = start, 0.0, []
    for line in proc.stdout:
        now = time.perf_counter()
        gap, last = max(gap, now - last), now
        lines.append(line.rstrip("\n"))
    proc.wait()
    end = time.perf_counter()
    if proc.returncode != 0:
        raise RuntimeError("\n".join(lines[-20:]))
    return end - start, max(gap, end - last), lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=None, help="rattlesweep compile --jobs")
    parser.add_argument(
        "--skip-cold-demo", action="store_true", help="leave out part 3 (about 3 minutes)"
    )
    args = parser.parse_args()
    exe = [sys.executable, "-m", "rattlesweep"]
    print(f"cores: {len(os.sched_getaffinity(0))}")
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as work:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        jobs = [] if args.jobs is None else ["--jobs", str(args.jobs)]
        wall, gap, lines = timed_lines([*exe, "compile", *jobs], env)
        print(f"\n1. rattlesweep compile {' '.join(jobs)}".rstrip())
        print(f"   {wall:6.1f} s wall, longest silence {gap:.1f} s; {lines[-1]}")
        wall, gap, lines = timed_lines([*exe, "compile", *jobs], env)
        print(f"   {wall:6.1f} s again: {lines[-1]}")

        print("\n2. first calls after it, each in a new process (s, import included)")
        for name, code in FIRST_CALLS.items():
            wall, _, _ = timed_lines([sys.executable, "-c", code], env)
            print(f"   {name:<22} {wall:6.2f}")
        out = os.path.join(work, "demo")
        wall, gap, _ = timed_lines([*exe, "demo", "--out", out], env)
        print(f"   {'rattlesweep demo':<22} {wall:6.2f}")

    if args.skip_cold_demo:
        return
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as work:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        wall, gap, lines = timed_lines([*exe, "demo", "--out", work + "/demo"], env)
        print("\n3. rattlesweep demo without it (empty cache)")
        print(f"   {wall:6.1f} s wall, longest silence {gap:.1f} s")
        for line in lines[:3]:
            print(f"   | {line}")


if __name__ == "__main__":
    main()
