"""Accuracy per cost of Coulomb friction runs: the wall time to reach a first reversal
time within a tolerance of the event-driven reference.

    python benchmarks/bench_accuracy.py [--quick] [--compare OLD_CHECKOUT/src]

1. The fast launch (kane_levinson, +5 rad/s, pitch 0.5 deg, mu = 0.3), a batch of
   identical launches at dt_default / k: first reversal time against the stored
   event-driven solution of tests/data/event_reference.npz (case c), wall time per
   launch, and the cheapest k within --tolerance (2 ms).
2. The demo map's friction half (toy body, spin x misalignment, mu = 0.3, 5 s): first
   reversal times at the default dt against a run at dt / 16, the distribution of their
   differences where both reversed, and outcomes that differ; wall time of each.

--compare runs the same in a copy of another tree (as package rattlesweep_baseline, in
a child process) and prints both.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import import_module
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REFERENCE = ROOT / "tests" / "data" / "event_reference.npz"
PITCH = math.radians(0.5)


def fast_launch(rs, divisors, n):
    """[(k, dt, first reversal (s), wall per launch (s))] for the fast launch."""
    body = rs.Body.preset("kane_levinson")
    rows = []
    for k in divisors:
        dt = body.default_dt() / k
        kwargs = dict(spin=np.full(n, 5.0), pitch=PITCH, mu=0.3, t_end=3.0, dt=dt)
        rs.run_batch(body, **{**kwargs, "spin": np.full(2, 5.0)})  # compiled, untimed
        t0 = time.perf_counter()
        ds = rs.run_batch(body, **kwargs)
        wall = time.perf_counter() - t0
        rows.append((k, dt, float(ds.first_reversal_time.values[0]), wall / n))
    return rows


def demo_map(rs, num):
    """First reversal times of the demo's mu = 0.3 half at the default dt and at dt/16,
    and the wall time of each."""
    out = {}
    toy = rs.Body.preset("toy")

    def body(delta):
        return rs.Body.semi_ellipsoid(toy.a, toy.b, toy.c, toy.mass, delta=delta)

    for k in (1, 16):
        spin = np.linspace(-30, 30, num[0])[:, None]
        delta = np.radians(np.linspace(-8, 8, num[1]))
        bodies = np.empty((1, delta.size), dtype=object)
        bodies[0, :] = [body(float(d)) for d in delta]
        dt = None if k == 1 else body(0.0).default_dt() / k
        t0 = time.perf_counter()
        ds = rs.run_batch(
            bodies,
            spin=spin,
            roll=PITCH,
            mu=0.3,
            t_end=5.0,
            **({} if dt is None else {"dt": dt}),
        )
        out[str(k)] = {
            "wall": time.perf_counter() - t0,
            "reversal": ds.first_reversal_time.values.ravel().tolist(),
        }
    return out


def measure(package, quick):
    rs = import_module(package)
    divisors = (1, 2, 4) if quick else (1, 2, 4, 8, 16)
    return {
        "fast": fast_launch(rs, divisors, 64 if quick else 256),
        "demo": demo_map(rs, (21, 17) if quick else (41, 33)),
    }


def report(label, result, reference, tolerance):
    print(f"\n{label}")
    print(
        f"{'dt/k':>5} {'dt (ms)':>8} {'first reversal (s)':>19} {'error (ms)':>11} "
        f"{'wall/launch (ms)':>17}"
    )
    within = None
    for k, dt, rev, wall in result["fast"]:
        err = rev - reference
        print(
            f"{k:>5d} {dt * 1e3:>8.4f} {rev:>19.6f} {err * 1e3:>+11.3f} {wall * 1e3:>17.3f}"
        )
        if within is None and abs(err) <= tolerance:
            within = (k, wall)
    if within:
        print(
            f"within {tolerance * 1e3:g} ms from dt/{within[0]}: {within[1] * 1e3:.3f} ms "
            "per launch"
        )
    else:
        print(f"not within {tolerance * 1e3:g} ms at any dt tried")
    a = np.array(result["demo"]["1"]["reversal"])
    b = np.array(result["demo"]["16"]["reversal"])
    both = np.isfinite(a) & np.isfinite(b)
    d = np.abs(a[both] - b[both]) * 1e3
    print(
        f"demo map (mu = 0.3, {a.size} launches), default dt against dt/16: outcome "
        "(reverses or not) differs at "
        f"{np.count_nonzero(np.isfinite(a) != np.isfinite(b))};"
        f" |difference| of first reversal times where both reversed ({both.sum()}): "
        f"median {np.median(d):.3f} ms, 95th percentile {np.percentile(d, 95):.3f} ms, "
        f"max {d.max():.3f} ms; wall {result['demo']['1']['wall']:.2f} s (dt) and "
        f"{result['demo']['16']['wall']:.2f} s (dt/16)"
    )
    return within


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer step sizes, a coarser map")
    ap.add_argument("--compare", metavar="OLD_SRC", help="also run another tree's src")
    ap.add_argument("--tolerance", type=float, default=2e-3, help="s (default 2 ms)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(measure(args.child, args.quick)))
        return
    reference = float(np.load(REFERENCE)["c/first_reversal"])
    print(f"event-driven reference, first reversal of the fast launch: {reference:.6f} s")
    results = {}
    if args.compare:
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copytree(
                Path(args.compare) / "rattlesweep",
                Path(tmp) / "rattlesweep_baseline",
                ignore=shutil.ignore_patterns("__pycache__"),
            )
            env = {**os.environ, "PYTHONPATH": tmp}
            out = subprocess.run(
                [sys.executable, __file__, "--child", "rattlesweep_baseline"]
                + (["--quick"] if args.quick else []),
                env=env,
                check=True,
                text=True,
                stdout=subprocess.PIPE,
            ).stdout
            results["old"] = json.loads(out.splitlines()[-1])
    results["new"] = measure("rattlesweep", args.quick)
    within = {}
    for label, result in results.items():
        within[label] = report(
            f"{label}: {'this tree' if label == 'new' else args.compare}",
            result,
            reference,
            args.tolerance,
        )
    if within.get("old") and within.get("new"):
        print(
            f"\nwall time to {args.tolerance * 1e3:g} ms: old/new = "
            f"{within['old'][1] / within['new'][1]:.1f}"
        )


if __name__ == "__main__":
    main()
