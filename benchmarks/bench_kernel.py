"""Benchmark of the rattlesweep kernel: throughput, memory, baselines, first-call latency.

    python benchmarks/bench_kernel.py [--quick]
    python benchmarks/bench_kernel.py --compare OLD_CHECKOUT/src [--quick] [--rounds 6]
    python benchmarks/bench_kernel.py --latency

kane_levinson body, default dt, RK4, 0.5 degree roll, spins linspace(-10, 10, n) rad/s.
Timings are the best of --repeats calls after an untimed one (spread: (slowest - best) /
best); the baselines run the same rolling equations (tests/numpy_oracle.py) in this
process; latency is measured in fresh interpreters. --compare is an A/B of the
throughput table with both trees in one process: OLD_SRC/rattlesweep is copied as the
package rattlesweep_baseline, and each of --rounds fresh processes times the two trees'
calls in alternating pairs; the figure to quote is the median over processes of new/old
of a process's best times. Pairs in one process, because the speed of a process on this
kind of machine varies from process to process by up to 30 %.
"""

from __future__ import annotations

import argparse
import functools
import itertools
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from importlib import import_module
from pathlib import Path

import numba
import numpy as np

import rattlesweep as rs
from rattlesweep.rattleback.batch import prepare
from rattlesweep._run import execute

ROOT = Path(__file__).resolve().parent.parent
BODY = rs.Body.preset("kane_levinson")
DT = BODY.default_dt()
ROLL = math.radians(0.5)
FAST_SPIN = 5.0  # rad/s, the fast-reversing sense (I_xy * n > 0); reverses at about 5.8 s
MIN_T_END = 1.0  # s of simulated time, the shortest run timed
NOMINAL_RATE = 5e7  # steps/s on one core, only to size runs to about --target seconds


def steps_taken(result, prep) -> int:
    """Trajectory-steps a call of execute integrated: the one place that would read its
    result; the step count is fixed by prepare (padding lanes take none)."""
    return int(prep.nsteps.sum())


def sweep_prep(n, mu, t_end):
    return prepare(BODY, spin=np.linspace(-10.0, 10.0, n), roll=ROLL, mu=mu, t_end=t_end)


def run_kernel(prep, threads, execute=execute):  # RK4; threads 1: the serial entry point
    return execute(
        prep,
        method=0,
        record_every=None,
        band=0.05,
        parallel=threads > 1,
        threads=threads if threads > 1 else None,
    )


def configs(sizes, target):
    """(mu, batch, threads, t_end) of the throughput table; t_end gives runs of about
    `target` s on one core and at least MIN_T_END s simulated."""
    return [
        (mu, n, threads, max(MIN_T_END, target * NOMINAL_RATE * DT / n))
        for mu, n, threads in itertools.product((math.inf, 0.3), sizes, (1, 2))
    ]


def best_of(fn, repeats):
    """fn's result from an untimed call; then, of `repeats` timed calls, the best wall
    time, the spread and the cores the best one kept busy (process CPU / wall time)."""
    result, runs = fn(), []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        runs.append((time.perf_counter() - t0, time.process_time() - c0))
    (wall, cpu), slowest = min(runs), max(runs)[0]
    return result, wall, slowest / wall - 1.0, cpu / wall


def throughput(sizes, target, repeats):
    """Prints the table; returns {(mu, batch, threads): steps per second}."""
    print(
        f"\n1. THROUGHPUT of execute, dt = {DT * 1e3:.4f} ms (threads 1: serial entry, "
        "2: parallel; cores: CPU time / wall time of the best run)"
    )
    print(
        f"{'mu':>5} {'batch':>6} {'t_end s':>8} {'threads':>7} {'M steps/s':>10} "
        f"{'per thread':>10} {'spread':>7} {'cores':>6}"
    )
    rates = {}
    for mu, n, threads, t_end in configs(sizes, target):
        prep = sweep_prep(n, mu, t_end)
        result, best, spread, cores = best_of(lambda: run_kernel(prep, threads), repeats)
        rate = rates[mu, n, threads] = steps_taken(result, prep) / best
        print(
            f"{mu:>5g} {n:>6d} {t_end:>8.3g} {threads:>7d} {rate / 1e6:>10.2f} "
            f"{rate / threads / 1e6:>10.2f} {spread:>7.1%} {cores:>6.2f}"
        )
    return rates


def memory(largest):
    print("\n2. MEMORY (bytes per trajectory, rolling, no time series recorded)")
    print(f"{'batch':>6} {'packed inputs':>14} {'tracemalloc peak':>17}")
    lo, hi, peaks = max(1, largest // 16), largest, {}
    for n in (lo, hi):
        tracemalloc.start()
        prep = sweep_prep(n, math.inf, 10 * DT)
        run_kernel(prep, 1)
        peaks[n] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        packed = (prep.P.nbytes + prep.Y.nbytes + prep.nsteps.nbytes) / n
        print(f"{n:>6d} {packed:>14.0f} {peaks[n] / n:>17.0f}")
    print(
        f"marginal peak between {lo} and {hi}: {(peaks[hi] - peaks[lo]) / (hi - lo):.0f} "
        f"B per trajectory (plus numba's per-thread workspace, independent of n)"
    )


def baselines(n, k_rate, quick):
    sys.path.insert(0, str(ROOT / "tests"))
    from numpy_oracle import NumpyRolling, first_reversal
    from scipy.integrate import solve_ivp

    model = NumpyRolling(BODY)
    print(
        f"\n3. BASELINES (rolling, one thread; the kernel at batch {n} in 1.: "
        f"{k_rate / 1e6:.2f} M steps/s = {k_rate * DT:.0f} trajectory-s per s)"
    )
    y0, nsteps = model.initial(np.linspace(-10.0, 10.0, n), ROLL), 40 if quick else 200
    np_rate = n * nsteps / best_of(lambda: model.rk4(y0, DT, nsteps), 1)[1]
    print(
        f"NumPy oracle, batch {n}, {nsteps} steps: {np_rate / 1e6:.3f} M steps/s; "
        f"kernel / NumPy = {k_rate / np_rate:.0f}x"
    )

    t_ref, t_k = (
        float(
            rs.run_batch(
                BODY, spin=FAST_SPIN, roll=ROLL, t_end=7.0, dt=dt
            ).first_reversal_time[0]
        )
        for dt in (DT / 8, DT)
    )
    e_k = abs(t_k - t_ref)
    print(
        f"solve_ivp DOP853, spin {FAST_SPIN:g} rad/s to 7 s; first reversal (kernel at "
        f"dt/8) {t_ref:.6f} s, kernel error at dt {e_k:.1e} s"
    )
    grid, chosen = np.linspace(0.0, 7.0, 70001), None  # dense output every 0.1 ms
    for rtol in [10.0**-k for k in (range(8, 4, -1) if quick else range(10, 3, -1))]:
        t0 = time.perf_counter()
        sol = solve_ivp(
            lambda t, y: model.rhs(y[:, None])[:, 0],
            (0.0, 7.0),
            model.initial(FAST_SPIN, ROLL)[:, 0],
            method="DOP853",
            rtol=rtol,
            atol=rtol * 1e-3,
            dense_output=True,
        )
        wall = time.perf_counter() - t0
        err = abs(first_reversal(grid, model.spin(sol.sol(grid))) - t_ref)
        print(
            f"  rtol {rtol:.0e}: {sol.nfev:6d} evaluations, {wall:6.2f} s "
            f"({7.0 / wall:.2f} trajectory-s per s), error {err:.1e} s"
        )
        if not err <= e_k:  # from tight to loose: the first rtol less accurate ends it
            break
        chosen = (rtol, wall)
    if chosen is None:
        return print("  no rtol scanned reaches the kernel's accuracy")
    print(
        f"  loosest rtol as accurate as the kernel (and every tighter one): "
        f"{chosen[0]:.0e}; kernel / solve_ivp = {k_rate * DT / (7.0 / chosen[1]):.0f}x"
    )


LATENCY = """
import sys, time; t0 = time.perf_counter()
import rattlesweep as rs; t1 = time.perf_counter()
body = rs.Body.preset("kane_levinson")
mu = float(sys.argv[1])
rs.simulate(body, spin=5.0, roll=0.01, t_end=0.01, mu=mu); t2 = time.perf_counter()
rs.run_batch(body, spin=[5.0, 6.0], roll=0.01, t_end=0.01, mu=mu); t3 = time.perf_counter()
print(t1 - t0, t2 - t0, t3 - t0)
"""


def latency():
    print(
        "\n4. FIRST-CALL LATENCY (fresh interpreter, s from before import, cumulative; "
        "cold: an empty numba cache for each friction level)"
    )
    print(
        f"{'mu':>5} {'numba cache':<12} {'import':>7} {'+ simulate':>11} "
        f"{'+ run_batch':>12}"
    )
    for mu in (math.inf, 0.3):
        with tempfile.TemporaryDirectory() as cache:
            for label in ("cold", "warm"):
                env = {**os.environ, "NUMBA_CACHE_DIR": cache}
                imp, sim, batch = map(
                    float,
                    subprocess.run(
                        [sys.executable, "-c", LATENCY, repr(mu)],
                        env=env,
                        check=True,
                        text=True,
                        capture_output=True,
                    ).stdout.split(),
                )
                print(f"{mu:>5g} {label:<12} {imp:>7.2f} {sim:>11.2f} {batch:>12.2f}")


def tree(name):
    """(Body, prepare, execute) of package `name`: this tree's rattlesweep, or under
    --compare the other tree's copy, in its own layout (the 3-D model's batch module in
    rattleback/ or at the top; execute in _run, engine or that batch module)."""
    pkg = import_module(name)
    for batch_name, run_name in (
        (".rattleback.batch", "._run"),
        (".batch", ".engine"),
        (".batch", ".batch"),
    ):
        try:
            batch, run = import_module(name + batch_name), import_module(name + run_name)
        except ModuleNotFoundError:
            continue
        return pkg.Body, batch.prepare, run.execute
    raise ModuleNotFoundError(f"no batch module with prepare and execute in {name}")


def pairs(sizes, args):
    """--pairs, one --compare process: per configuration, the best rate of the old tree
    (package rattlesweep_baseline) and of this one over --repeats pairs of calls."""
    assert Path(rs.__file__).resolve().is_relative_to(ROOT / "src"), rs.__file__
    trees, rates = [tree("rattlesweep_baseline"), tree("rattlesweep")], []
    for mu, n, threads, t_end in configs(sizes, args.target):
        preps = [
            prep(
                body.preset("kane_levinson"),
                spin=np.linspace(-10.0, 10.0, n),
                roll=ROLL,
                mu=mu,
                t_end=t_end,
            )
            for body, prep, _ in trees
        ]
        steps = [int(prep.nsteps.sum()) for prep in preps]
        assert steps[0] == steps[1], f"the trees take different step counts: {steps}"
        calls = [
            functools.partial(run_kernel, prep, threads, ex)
            for prep, (_, _, ex) in zip(preps, trees)
        ]
        for call in calls:  # untimed
            call()
        best = [math.inf, math.inf]
        for i in range(args.repeats):
            for k in (0, 1) if i % 2 == 0 else (1, 0):  # who goes first alternates
                t0 = time.perf_counter()
                calls[k]()
                best[k] = min(best[k], time.perf_counter() - t0)
        rates.append([steps[0] / b for b in best])
    print(json.dumps(rates))


def compare(old_src, sizes, args):
    """--compare: the A/B of the module docstring; prints the table."""
    table = configs(sizes, args.target)
    with tempfile.TemporaryDirectory() as tmp:  # the copy and its numba cache
        shutil.copytree(
            Path(old_src) / "rattlesweep",
            Path(tmp) / "rattlesweep_baseline",
            ignore=shutil.ignore_patterns("__pycache__"),
        )
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), tmp])}
        run = lambda sizes, repeats, target: (
            subprocess.run(
                [
                    sys.executable,
                    __file__,
                    "--pairs",
                    "--sizes",
                    ",".join(map(str, sizes)),
                    "--repeats",
                    str(repeats),
                    "--target",
                    repr(target),
                ],
                env=env,
                check=True,
                text=True,
                stdout=subprocess.PIPE,
            ).stdout
        )
        run([2], 0, 1e-9)  # compiles both trees' kernels once, untimed (runs of MIN_T_END)
        rates = np.array(
            [json.loads(run(sizes, args.repeats, args.target)) for _ in range(args.rounds)]
        )  # (process, configuration, tree)
    ratio = rates[:, :, 1] / rates[:, :, 0]
    print(
        f"\nIN-PROCESS A/B, {args.rounds} processes of {args.repeats} alternating pairs "
        f"of calls: best M steps/s\nof old ({Path(old_src).resolve()}) and new "
        f"({ROOT / 'src'}) over all processes;\nnew/old: median and range over processes "
        "of the ratio of a process's best times"
    )
    print(
        f"{'mu':>5} {'batch':>6} {'threads':>7} {'old':>8} {'new':>8} "
        f"{'median':>7} {'range':>12}"
    )
    for j, (mu, n, threads, _) in enumerate(table):
        print(
            f"{mu:>5g} {n:>6d} {threads:>7d} {rates[:, j, 0].max() / 1e6:>8.2f} "
            f"{rates[:, j, 1].max() / 1e6:>8.2f} {np.median(ratio[:, j]):>7.3f} "
            f"{ratio[:, j].min():>5.3f}-{ratio[:, j].max():.3f}"
        )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer sizes, shorter runs")
    ap.add_argument("--sizes", help="comma-separated batch sizes")
    ap.add_argument("--target", type=float, help="about this many s per timed run")
    ap.add_argument(
        "--repeats",
        type=int,
        help="timed runs per configuration (default 3; "
        "--compare: pairs per process, default 10)",
    )
    ap.add_argument(
        "--latency",
        action="store_true",
        help="only the first-call latency (cold and warm numba cache)",
    )
    ap.add_argument("--compare", metavar="OLD_SRC", help="A/B against another tree's src")
    ap.add_argument(
        "--rounds", type=int, default=6, help="A/B processes, one after another"
    )
    ap.add_argument("--pairs", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--warm", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    sizes = (
        [int(s) for s in args.sizes.split(",")]
        if args.sizes
        else ([256, 4096] if args.quick else [256, 4096, 65536])
    )
    args.target = args.target or (0.2 if args.quick else 1.0)
    args.repeats = args.repeats if args.repeats is not None else 10 if args.compare else 3
    if args.warm:
        return [run_kernel(sweep_prep(2, math.inf, DT), threads) for threads in (1, 2)]
    if args.compare:
        return compare(args.compare, sizes, args)
    if args.pairs:
        return pairs(sizes, args)
    if args.latency:
        return latency()
    # A process that compiled the kernels runs them measurably slower than one that loaded
    # them from numba's cache, so a child process fills the cache before anything is timed.
    subprocess.run([sys.executable, __file__, "--warm"], check=True)
    main(["--warm"])  # loads them into this process, untimed
    print(
        f"rattlesweep {rs.__version__} ({Path(rs.__file__).parent}), numba "
        f"{numba.__version__}, numpy {np.__version__}, {os.cpu_count()} CPUs, "
        f"{'quick' if args.quick else 'full'}"
    )
    rates = throughput(sizes, args.target, args.repeats)
    memory(max(sizes))
    n = min(sizes, key=lambda size: abs(size - 4096))
    baselines(n, rates[math.inf, n, 1], args.quick)
    latency()


if __name__ == "__main__":
    main()
