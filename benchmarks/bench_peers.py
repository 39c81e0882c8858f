"""rattlesweep against its peers: MuJoCo, JAX (jax.vmap + jit, diffrax) and scipy's
solve_ivp.

    pip install -e '.[peers]'
    python benchmarks/bench_peers.py [--quick] [--plot docs/peers/spin_history.png]

The same launches in every engine: the kane_levinson body pitched by 0.5 degree and spun
at +5 rad/s (the fast sense, I_xy n > 0) or -5 rad/s (the slow one), rolling (mu = inf;
MuJoCo, whose friction is finite, gets mu = 5) or with mu = 0.3 (rattlesweep, MuJoCo and
the event-driven solve_ivp; the JAX programs roll only). Every peer starts from
rattlesweep's own t = 0 state (run_batch records it), checked before anything is timed.

1. SAME START: MuJoCo's launch against rattlesweep's (mass, G, inertia, contact point and
   distance, contact point at rest, spin); the JAX states are rattlesweep's numbers.
2. REFERENCES: rolling, solve_ivp DOP853 at rtol 1e-12 of the rolling equations of
   tests/numpy_oracle.py; mu = 0.3, the event-driven Coulomb solution of
   tests/event_reference.py (LSODA, rtol 1e-10, a terminal event per stick/slip switch).
3. ACCURACY of each engine at each setting, coarse to fine: the first reversal time of a
   launch, its error against the reference, the largest spin error over the run (at the
   engine's own samples, against the reference's dense output), the wall time of that
   one launch alone and the CPU the rest of the machine used meanwhile.
4. THROUGHPUT: trajectory-steps per second and launch-seconds simulated per wall second,
   batches on two threads (JAX: two host devices), rounds interleaved (each engine timed
   once per round; the best round counts), with the CPU the rest of the machine used
   while each row was timed ("others", in cores: /proc/stat's busy time less this
   process's CPU time, per wall second) and the 1-minute load average.
5. TO A STATED ACCURACY: for each tolerance on the relative error of the +5 rad/s
   launch's first reversal, each engine's cheapest setting in 3. that meets it, and its
   wall time per launch simulated to T_FAST s at its throughput in 4. (rattlesweep and
   JAX: steps per second at the default dt times the chosen dt; solve_ivp integrates one
   launch at a time, so its figure is the launch's own wall time).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from dataclasses import dataclass, field
from importlib.metadata import version
from pathlib import Path

THREADS = 2  # the machine's cores; JAX gets as many host devices (set before it loads)
os.environ["XLA_FLAGS"] = (
    os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={THREADS}"
).strip()

import numpy as np  # noqa: E402

import rattlesweep as rs  # noqa: E402
from bench_kernel import BODY, DT, run_kernel, steps_taken  # noqa: E402
from peers import jax_rolling  # noqa: E402
from peers import mujoco_rattleback as mj  # noqa: E402
from rattlesweep.rattleback.batch import prepare  # noqa: E402

from peers.runs import (  # noqa: E402
    PITCH,
    FAST,
    SLOW,
    T_FAST,
    T_SLOW,
    MU_MUJOCO_ROLLING,
    STIFF,
    STIFF_IMPLICIT,
    FINE,
    Meter,
    launch,
    jax_states,
    Run,
    solve_rolling,
    solve_coulomb,
    run_rattlesweep,
    run_mujoco,
    same_start,
)


# --------------------------------------------------------------------------------------
# 3. accuracy
@dataclass
class Row:
    engine: str
    setting: str
    mu: float
    spin: float
    run: Run
    error: float  # relative error of the first reversal time (inf when none)
    spin_error: float  # rad/s, largest over the run
    key: object = None  # the setting: dt (s), a MuJoCo Contact or an rtol


def score(engine, setting, mu, spin, run, ref, key) -> Row:
    t_ref = ref[0].first_reversal
    error = (
        abs(run.first_reversal / t_ref - 1.0)
        if math.isfinite(run.first_reversal)
        else math.inf
    )
    spin_error = float(np.max(np.abs(run.spin - ref[1](run.t))))
    return Row(engine, setting, mu, spin, run, error, spin_error, key)


def accuracy(quick, refs):
    """Section 3; returns the rows."""
    print(
        "\n3. ACCURACY (first reversal of the launch against the reference; spin error: "
        "largest |n - n_ref| over the run;\n   wall: that one launch alone, one thread; "
        "others: CPU cores the rest of the machine used meanwhile)"
    )
    print(
        f"{'engine':<12} {'setting':<38} {'mu':>4} {'spin':>5} {'reversal s':>11} "
        f"{'error':>9} {'spin err':>9} {'wall s':>8} {'others':>6}"
    )
    rows = []

    def add(row):
        rows.append(row)
        r = row.run
        print(
            f"{row.engine:<12} {row.setting:<38} {row.mu:>4g} {row.spin:>+5g} "
            f"{r.first_reversal:>11.6f} {row.error:>9.2e} {row.spin_error:>9.2e} "
            f"{r.wall:>8.2f} {r.others:>6.2f}",
            flush=True,
        )

    # from 2 x the default dt: rattlesweep warns of coarse steps above 4 x
    factors = [2, 1, 1 / 2, 1 / 4, 1 / 8, 1 / 16] + ([] if quick else [1 / 32])
    rtols = [1e-4, 1e-6, 1e-8] + ([] if quick else [1e-10])
    contacts = [
        mj.DEFAULT,
        STIFF_IMPLICIT,
        STIFF,
        mj.Contact(1e-4, 2e-5),
        mj.Contact(2e-5, 1e-5),
        FINE,
    ] + ([] if quick else [mj.Contact(5e-6, 2.5e-6)])
    for mu in (math.inf, 0.3):
        ref = refs[mu, FAST]
        for f in factors:
            add(
                score(
                    "rattlesweep",
                    f"RK4, dt default x {f:g}",
                    mu,
                    FAST,
                    run_rattlesweep(FAST, mu, T_FAST, DT * f),
                    ref,
                    DT * f,
                )
            )
        mu_mj = MU_MUJOCO_ROLLING if mu == math.inf else mu
        for c in contacts:
            run = run_mujoco(FAST, mu_mj, T_FAST, c)
            add(score("MuJoCo", c.label(), mu_mj, FAST, run, ref, c))
        if mu == math.inf:
            for rtol in rtols:
                add(
                    score(
                        "solve_ivp",
                        f"DOP853, rtol {rtol:g}",
                        mu,
                        FAST,
                        solve_rolling(FAST, T_FAST, rtol)[0],
                        ref,
                        rtol,
                    )
                )
        else:
            for rtol in [1e-8] + ([] if quick else [1e-9]):
                add(
                    score(
                        "solve_ivp",
                        f"events, LSODA, rtol {rtol:g}",
                        mu,
                        FAST,
                        solve_coulomb(FAST, mu, T_FAST, rtol)[0],
                        ref,
                        rtol,
                    )
                )
    ref = refs[math.inf, SLOW]
    add(
        score(
            "rattlesweep",
            "RK4, dt default x 1",
            math.inf,
            SLOW,
            run_rattlesweep(SLOW, math.inf, T_SLOW, DT),
            ref,
            DT,
        )
    )
    slow = [STIFF, STIFF_IMPLICIT, mj.Contact(5e-4, 1e-4, noslip=10)] + (
        [] if quick else [mj.Contact(1e-4, 2e-5), mj.Contact(2e-5, 1e-5)]
    )
    for c in slow:
        add(
            score(
                "MuJoCo",
                c.label(),
                MU_MUJOCO_ROLLING,
                SLOW,
                run_mujoco(SLOW, MU_MUJOCO_ROLLING, T_SLOW, c),
                ref,
                c,
            )
        )
    return rows


# --------------------------------------------------------------------------------------
# 4. throughput
@dataclass
class Engine:
    """A batch to time: call() integrates it; steps per call; dt (s) of a step."""

    name: str
    setting: str
    mu: float
    batch: int
    call: object
    steps: int
    dt: float
    meter: Meter = field(default_factory=Meter)
    best: float = math.inf
    compile_s: float = math.nan
    agreement: str = ""
    key: object = None  # the MuJoCo Contact

    @property
    def rate(self):
        return self.steps / self.best


def spins_of(n):
    return np.linspace(-10.0, 10.0, n)


def rattlesweep_engine(n, mu, target):
    nsteps = max(100, int(target * 5e7 / n))
    prep = prepare(BODY, spin=spins_of(n), pitch=PITCH, mu=mu, t_end=nsteps * DT)
    e = Engine(
        "rattlesweep",
        f"RK4, dt {DT * 1e3:.3f} ms",
        mu,
        n,
        lambda: run_kernel(prep, THREADS),
        0,
        DT,
    )
    e.steps = steps_taken(None, prep)
    return e


def jax_engines(n, target):
    """The three JAX programs on the same rolling batch, each checked against
    rattlesweep's final spins and first reversal times on that batch."""
    spins, start = spins_of(n), launch(spins_of(n))
    y0 = jax_states(start)
    out = []
    for name, make, nominal in (
        ("JAX SoA", jax_rolling.soa_runner, 1e7),
        ("JAX vmap", jax_rolling.vmap_runner, 1e6),
        ("diffrax", jax_rolling.diffrax_runner, 1e6),
    ):
        nsteps = max(100, int(target * nominal / n))
        fn = make(BODY, DT, nsteps)

        def call(fn=fn):
            res = fn(y0)
            res = res if isinstance(res, tuple) else (res, None)
            return [None if r is None else np.asarray(r) for r in res]

        t0 = time.perf_counter()
        final, t_rev = call()
        e = Engine(
            name, f"RK4, dt {DT * 1e3:.3f} ms, float64", math.inf, n, call, n * nsteps, DT
        )
        e.compile_s = time.perf_counter() - t0
        ref = rs.run_batch(BODY, spin=spins, pitch=PITCH, t_end=nsteps * DT)
        assert int(ref.steps.max()) == nsteps, (int(ref.steps.max()), nsteps)
        dn = np.max(np.abs(jax_rolling.final_spin(final) - ref.final_spin.values))
        e.agreement = f"final spins within {dn:.1e} rad/s"
        if t_rev is not None:
            both = np.isfinite(t_rev) & np.isfinite(ref.first_reversal_time.values)
            same = np.array_equal(np.isfinite(t_rev), np.isfinite(ref.first_reversal_time))
            dt_rev = np.max(
                np.abs(t_rev - ref.first_reversal_time.values)[both], initial=0.0
            )
            e.agreement += f", first reversals within {dt_rev:.1e} s" + (
                "" if same else " (NOT the same launches reverse)"
            )
        out.append(e)
    return out


def mujoco_engine(n, mu, contact, target):
    model, _ = mj.build(BODY, mu, contact)
    states = mj.launch_states(model, launch(spins_of(n)))
    nominal = 1e5 if contact.integrator == "RK4" else 3e5
    nsteps = max(100, int(target * nominal / n))
    return Engine(
        "MuJoCo",
        contact.label(),
        mu,
        n,
        lambda: mj.spin_histories(model, states, nsteps, threads=THREADS, chunk=nsteps),
        n * nsteps,
        contact.dt,
        key=contact,
    )


def throughput(engines, rounds, solve_rows):
    """Section 4: times the engines in interleaved rounds and prints the table."""
    for e in engines:  # untimed first calls (JAX has compiled already)
        e.call()
    for _ in range(rounds):
        for e in engines:
            e.best = min(e.best, e.meter.time(e.call)[1])
    print(
        f"\n4. THROUGHPUT ({rounds} interleaved rounds, best round; {THREADS} threads or "
        "host devices; launch-s/s: simulated seconds x launches per wall second;\n"
        "   cores: CPU this process used per wall second; others: CPU cores the rest of "
        "the machine used meanwhile;\n   load: 1-minute load average, this process "
        "included)"
    )
    print(
        f"{'engine':<12} {'setting':<38} {'mu':>4} {'batch':>6} {'M steps/s':>10} "
        f"{'launch-s/s':>11} {'cores':>5} {'others':>6} {'load':>5}  notes"
    )
    for e in engines:
        note = e.agreement + (
            f"; first call (compile + run) {e.compile_s:.1f} s"
            if math.isfinite(e.compile_s)
            else ""
        )
        print(
            f"{e.name:<12} {e.setting:<38} {e.mu:>4g} {e.batch:>6d} {e.rate / 1e6:>10.3f} "
            f"{e.rate * e.dt:>11.4g} {e.meter.cores():>5.2f} {e.meter.others():>6.2f} "
            f"{np.mean(e.meter.loads):>5.2f}  {note}"
        )
    for row in solve_rows:  # adaptive steps: no steps per second to compare
        print(
            f"{'solve_ivp':<12} {row.setting:<38} {row.mu:>4g} {1:>6d} {'-':>10} "
            f"{row.run.t[-1] / row.run.wall:>11.4g} {'':>5} {row.run.others:>6.2f} "
            f"{'':>5}  one launch at a time (its run in 3.)"
        )


# --------------------------------------------------------------------------------------
# 5. to a stated accuracy
def scan(rows, engine, mu):
    """An engine's rows of the +5 rad/s launch at friction mu, coarse to fine."""
    return [
        r
        for r in rows
        if r.engine == engine
        and r.spin == FAST
        and (r.mu == mu or (mu == math.inf and r.mu == MU_MUJOCO_ROLLING))
    ]


def cheapest(rows, engine, mu, tol):
    """The coarsest setting of the scan that meets `tol` with every finer one (a coarse
    setting that meets it by luck, between finer ones that do not, does not count)."""
    mine, found = scan(rows, engine, mu), None
    for row in reversed(mine):
        if row.error > tol:
            break
        found = row
    return found


def stated_accuracy(rows, tolerances, rates):
    """Section 5. `rates[engine, mu, key]`: trajectory-steps per second of the batch
    engines in 4. (key: the MuJoCo Contact, None for the others)."""
    print(
        f"\n5. TO A STATED ACCURACY (first reversal of the +{FAST:g} rad/s launch within "
        f"the tolerance; wall: per launch simulated to {T_FAST:g} s,\n   batches at their "
        "throughput in 4.; x: against rattlesweep)"
    )
    print(
        f"{'tolerance':>9} {'mu':>4} {'engine':<12} {'setting':<38} {'error':>9} "
        f"{'wall s/launch':>14} {'x':>9}"
    )
    for tol in tolerances:
        for mu in (math.inf, 0.3):
            base = None
            for engine in ("rattlesweep", "JAX SoA", "MuJoCo", "solve_ivp"):
                if engine == "JAX SoA" and mu != math.inf:
                    continue
                row = cheapest(
                    rows, "rattlesweep" if engine == "JAX SoA" else engine, mu, tol
                )
                if row is None:
                    best = min(scan(rows, engine, mu), key=lambda r: r.error)
                    print(
                        f"{tol:>9.1%} {mu:>4g} {engine:<12} not reached; best "
                        f"{best.error:.2%} ({best.setting})"
                    )
                    continue
                if engine in ("rattlesweep", "JAX SoA"):
                    wall = T_FAST / (rates[engine, mu, None] * row.key)  # steps/s x dt
                elif engine == "MuJoCo":
                    wall = T_FAST / (rates[engine, row.mu, row.key] * row.key.dt)
                else:
                    wall = row.run.wall * T_FAST / row.run.t[-1]
                base = wall if engine == "rattlesweep" else base
                setting = (
                    row.setting
                    if engine != "JAX SoA"
                    else row.setting + " (as rattlesweep)"
                )
                print(
                    f"{tol:>9.1%} {mu:>4g} {engine:<12} {setting:<38} {row.error:>9.2e} "
                    f"{wall:>14.3g} {wall / base:>9.3g}"
                )


# --------------------------------------------------------------------------------------
# picture
def plot(path, refs, rows, jax_spin):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 4.0), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    pick = [
        ("rattlesweep", "RK4, dt default x 1", "rattlesweep (RK4, default dt)", "C0", "-"),
        ("MuJoCo", mj.DEFAULT.label(), "MuJoCo, default contact", "C3", ":"),
        ("MuJoCo", STIFF.label(), "MuJoCo, solref 5e-4, dt 1e-4", "C1", "-"),
        ("MuJoCo", FINE.label(), "MuJoCo, solref 1e-5, dt 5e-6", "C2", "--"),
    ]
    for ax, mu, title in zip(
        axes, (math.inf, 0.3), ("rolling (MuJoCo: mu = 5)", "Coulomb friction, mu = 0.3")
    ):
        ref = refs[mu, FAST][0]
        ax.plot(
            ref.t,
            ref.spin,
            color="k",
            lw=3,
            alpha=0.3,
            label="reference (solve_ivp, tight)",
        )
        if mu == math.inf and jax_spin is not None:
            ax.plot(*jax_spin, color="C4", lw=1, ls="--", label="JAX (RK4, default dt)")
        for engine, setting, label, color, ls in pick:
            for r in rows:
                if (
                    r.engine == engine
                    and r.setting == setting
                    and r.spin == FAST
                    and (r.mu == mu or (mu == math.inf and r.mu == MU_MUJOCO_ROLLING))
                ):
                    ax.plot(r.run.t, r.run.spin, color=color, ls=ls, lw=1, label=label)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("time (s)")
        ax.set_xlim(0.0, T_FAST)
    axes[0].set_ylabel("spin n = ω·Z (rad/s)")
    fig.legend(
        *axes[0].get_legend_handles_labels(),
        loc="outside lower center",
        ncols=3,
        fontsize=8,
        frameon=False,
    )
    fig.suptitle(
        f"kane_levinson, +{FAST:g} rad/s, pitch 0.5°: the same launch in each engine",
        fontsize=10,
    )
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    print(f"\nwrote {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer settings, shorter runs")
    ap.add_argument("--rounds", type=int, help="interleaved timing rounds (3; quick 2)")
    ap.add_argument("--target", type=float, help="about this many s per timed call")
    ap.add_argument(
        "--tolerances",
        default="0.02,0.01,0.001",
        help="relative errors of the first reversal for section 5",
    )
    ap.add_argument("--plot", metavar="PNG", help="write the spin-history picture here")
    args = ap.parse_args(argv)
    rounds = args.rounds or (2 if args.quick else 3)
    target = args.target or (0.5 if args.quick else 1.5)
    tolerances = [float(x) for x in args.tolerances.split(",")]
    print(
        f"rattlesweep {rs.__version__}, numba {version('numba')}, numpy {np.__version__}, "
        f"scipy {version('scipy')}, mujoco {version('mujoco')}, jax {version('jax')}, "
        f"jaxlib {version('jaxlib')}, diffrax {version('diffrax')}; {os.cpu_count()} CPUs; "
        f"load {os.getloadavg()[0]:.2f}; {'quick' if args.quick else 'full'}"
    )
    print(f"kane_levinson, pitch 0.5 deg, spin +-5 rad/s; default dt {DT * 1e3:.4f} ms")
    same_start()

    print("\n2. REFERENCES")
    refs = {
        (math.inf, FAST): solve_rolling(FAST, T_FAST, 1e-12),
        (math.inf, SLOW): solve_rolling(SLOW, T_SLOW, 1e-10 if args.quick else 1e-12),
        (0.3, FAST): solve_coulomb(FAST, 0.3, T_FAST, 1e-10, samples=3001),
    }
    for (mu, spin), (run, _) in refs.items():
        print(
            f"  mu {mu:g}, spin {spin:+g} rad/s: first reversal {run.first_reversal:.6f} s "
            f"({run.wall:.1f} s wall)"
        )

    rows = accuracy(args.quick, refs)

    n_batch, n_mujoco = 4096, 128 if args.quick else 256
    engines = [rattlesweep_engine(n_batch, mu, target) for mu in (math.inf, 0.3)]
    engines += jax_engines(n_batch, target)
    chosen = {STIFF, STIFF_IMPLICIT}
    for tol in tolerances:
        for mu in (math.inf, 0.3):
            row = cheapest(rows, "MuJoCo", mu, tol)
            if row is not None:
                chosen.add(row.key)
    for c in sorted(chosen, key=lambda c: (c.integrator, -c.dt)):
        for mu in (MU_MUJOCO_ROLLING, 0.3):
            engines.append(mujoco_engine(n_mujoco, mu, c, target))
    solve_rows = [
        r
        for r in rows
        if r.engine == "solve_ivp" and r.spin == FAST and r.error <= max(tolerances)
    ]
    throughput(engines, rounds, solve_rows)

    rates = {(e.name, e.mu, e.key): e.rate for e in engines}
    stated_accuracy(rows, tolerances, rates)

    if args.plot:
        nsteps = int(round(T_FAST / DT))
        state = jax_states(launch(FAST))[0]
        jax_spin = (
            np.arange(nsteps + 1) * DT,
            jax_rolling.spin_history(BODY, DT, nsteps, state),
        )
        plot(args.plot, refs, rows, jax_spin)


if __name__ == "__main__":
    main()
