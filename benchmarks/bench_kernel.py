"""Benchmark of the rattlesweep kernel: throughput, memory, baselines, first-call latency.

Run from the repository root::

    .venv/bin/python benchmarks/bench_kernel.py            # full, a few minutes on 2 cores
    .venv/bin/python benchmarks/bench_kernel.py --quick    # fewer sizes, shorter runs

Every figure is measured in this process (latency in subprocesses) on the
``kane_levinson`` body at its default time step ``dt`` (RK4). The sections:

1. Throughput. Trajectory-steps per second of ``rattlesweep.batch.execute`` (the packed
   kernel call; the Python packing in ``prepare`` is timed separately and shown as
   microseconds per trajectory) against batch size and thread count, for launches with
   spins ``linspace(-10, 10, n)`` rad/s and a 0.5 degree roll, rolling (mu = inf) and
   Coulomb (mu = 0.3). "threads 1" is the serial entry point (``parallel=False``);
   "threads 2" is ``parallel=True, threads=2``. ``t_end`` is chosen per batch so that each
   run takes about ``--target`` seconds on one core, but at least ``MIN_T_END`` = 1 s of
   simulated time (1 126 steps), so that large batches are not timed on runs much
   shorter than those that show a reversal; each configuration runs once untimed
   (compilation, caches) and then ``--repeats`` times; the best wall time is reported and
   "spread" is (slowest - best) / best, a noise indicator. "other" is how many cores
   other processes kept busy during the best run (from /proc/stat minus this process's
   CPU time). While it exceeds the idle cores (CPUs minus threads used) by 0.25 the
   configuration is timed again (up to 3 more times); a remaining "*" marks a figure
   that competed for a core. The kernel works on blocks of ``BLOCK`` lanes, so a batch
   smaller than a block still pays for a whole block: "lanes" is n / padded lanes.
   "slip" is the mean fraction of steps spent slipping; with short ``t_end`` the
   mu = 0.3 batches may never slip, and then time the rolling code path plus the
   friction-cone check.
   1b. The fixed cost per trajectory: ``execute`` with no steps to take, at the largest
   batch, and what it costs a run of L steps per trajectory.
2. Memory. Bytes per trajectory of the arrays the kernel call needs (``prep.P``,
   ``prep.Y``, ``prep.nsteps`` and the observables ``obs``), and the tracemalloc peak of
   everything NumPy allocates during ``prepare`` + ``execute`` (coordinates, temporaries).
   The marginal cost between the two largest batches shows the proportionality. Not
   included: numba's per-thread block workspace, a constant of N_WORK * BLOCK * 8 bytes
   per running thread, independent of the batch size.
3. Baselines, in this process:
   a. a plain NumPy implementation of the same rolling (stick, mu = inf) right-hand
      side, written from MODEL.md sections 3-4, vectorised over the batch and stepped by
      a Python RK4 loop at the same dt; first checked against the kernel (first reversal
      times and spin histories to t = 7 s), then timed at n = 4096 against the kernel on
      the same batch on one thread (NumPy uses one core here).
   b. ``scipy.integrate.solve_ivp(method="DOP853")`` on that right-hand side for the single
      fast launch (spin +5 rad/s, roll 0.5 degree, rolling) to t = 7 s, at matched accuracy
      of the first reversal time. The reference is the kernel at dt/8; e_k is the
      kernel's error at dt. The chosen tolerance is the loosest rtol (atol = 1e-3 rtol) for
      which it and every tighter rtol scanned have an error <= max(e_k, 1e-3 s) (one
      lucky loose tolerance does not count); ``--quick`` scans rtol 1e-4..1e-7 only.
      "us/fev" is the wall time per right-hand-side evaluation: at n = 1 it is almost
      all NumPy per-call overhead, so this ratio mostly measures that overhead, not the
      integration method.
      Speeds are compared in simulated trajectory-seconds per wall second (kernel:
      steps/s * dt, at batch 4096 on one thread from section 1).
4. First-call latency: a fresh interpreter imports rattlesweep and runs one tiny
   ``simulate`` (serial kernel) and then one tiny ``run_batch`` (parallel kernel), with
   NUMBA_CACHE_DIR pointing at an empty directory (cold: numba compiles) and then again at
   the now-populated directory (warm: machine code is loaded from the cache). Times are
   cumulative from before the import.

The 1-minute load average is printed at the start and end as a coarse check; the
"other" column is the precise one. Rerun if figures carry a "*" or a large spread.

The first reversal time everywhere (kernel and baselines) follows MODEL.md section 6: the
first time the spin n = omega . n_hat goes beyond -5 % of |n(0)| on the opposite side,
reported at the preceding zero crossing, linearly interpolated between steps (the
solve_ivp run refines that crossing on its dense output instead).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from dataclasses import dataclass

import numba
import numpy as np

import rattlesweep as rs
from rattlesweep.batch import execute, prepare
from rattlesweep.core import layout as L

BODY = rs.Body.preset("kane_levinson")
DT = BODY.default_dt()
ROLL = math.radians(0.5)
FAST_SPIN = 5.0  # rad/s; I_xy * n > 0, the fast-reversing sense (MODEL.md section 2)
BAND = 0.05  # spin-reversal hysteresis, fraction of |n(0)| (the kernel's default)
NOMINAL_RATE = 8e6  # lane-steps per second per core, only to size t_end for each run
# Shortest run in the throughput table, s of simulated time (1 126 steps at the default
# dt). The fast launch first reverses at about 5.8 s and the demo sweep runs 5 s: runs
# that show a reversal are longer. Without a floor, sizing runs by wall time alone gave
# the largest batch 0.16 s runs (184 steps), and its row measured the per-trajectory
# set-up (about 6 steps' worth, section 1b) as much as the batch size.
MIN_T_END = 1.0
RK4 = 0

FULL_SIZES = (1, 16, 256, 4096, 65536)
QUICK_SIZES = (1, 256, 4096)


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------

def padded_lanes(n: int) -> int:
    return -(-n // L.BLOCK) * L.BLOCK


def t_end_for(n: int, target_s: float) -> float:
    """t_end giving about target_s seconds on one core (the kernel steps whole blocks,
    so the cost follows the padded lane count, not n), and at least MIN_T_END."""
    return max(MIN_T_END, target_s * NOMINAL_RATE * DT / padded_lanes(n))


def sweep_prep(n: int, mu: float, t_end: float):
    return prepare(BODY, spin=np.linspace(-10.0, 10.0, n), roll=ROLL, mu=mu, t_end=t_end)


def run_kernel(prep, threads: int):
    """One kernel call: threads == 1 is the serial entry point, otherwise the parallel
    one capped at `threads` numba threads."""
    if threads == 1:
        return execute(prep, method=RK4, record_every=None, band=BAND, parallel=False)
    return execute(prep, method=RK4, record_every=None, band=BAND, parallel=True,
                   threads=threads)


OTHER_MAX = 0.25  # other processes' load beyond the idle cores that makes a timing retried
EXTRA_TRIES = 3


def system_busy_s() -> float | None:
    """CPU seconds all processes have used since boot (Linux /proc/stat), else None."""
    try:
        with open("/proc/stat") as f:
            ticks = [int(x) for x in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")  # minus idle, iowait


def timed(fn):
    """Wall time of fn() and the cores other processes kept busy meanwhile (NaN where
    unknown): on a 2-core machine any other work skews a timing, so measure it."""
    busy0, cpu0, t0 = system_busy_s(), time.process_time(), time.perf_counter()
    fn()
    wall = time.perf_counter() - t0
    cpu, busy1 = time.process_time() - cpu0, system_busy_s()
    other = math.nan if busy0 is None else max(0.0, (busy1 - busy0 - cpu) / wall)
    return wall, other


@dataclass
class Timing:
    best: float  # s, fastest run
    worst: float  # s, slowest run
    other: float  # cores used by other processes during the fastest run
    limit: float  # `other` above this means the timing competed for a core

    @property
    def spread(self) -> float:
        return (self.worst - self.best) / self.best

    @property
    def flag(self) -> str:
        return "*" if self.other > self.limit else " "


def best_of(fn, repeats: int, threads: int = 1) -> Timing:
    """Best of `repeats` timed calls of fn (which uses `threads` cores). While the best
    one competed with other work for a core (other processes busier than the idle cores
    plus OTHER_MAX), up to EXTRA_TRIES more calls. The caller warms up first."""
    limit = max(0, (os.cpu_count() or 1) - threads) + OTHER_MAX
    runs = [timed(fn) for _ in range(repeats)]
    for _ in range(EXTRA_TRIES):
        if not min(runs)[1] > limit:
            break
        runs.append(timed(fn))
    best = min(runs)
    return Timing(best[0], max(r[0] for r in runs), best[1], limit)


def time_kernel(prep, threads: int, repeats: int):
    """(Timing, observables): one untimed call first (compile, caches), then best_of."""
    obs = run_kernel(prep, threads)[0]
    return best_of(lambda: run_kernel(prep, threads), repeats, threads), obs


def steps_taken(obs: np.ndarray, prep) -> int:
    """Trajectory-steps actually integrated. Equal to prep.nsteps.sum() unless some
    trajectory stopped early (a non-ok status); that would be reported, not hidden."""
    taken = int(obs[L.O_STEPS].sum())
    if taken != int(prep.nsteps.sum()):
        bad = np.bincount(obs[L.O_STATUS].astype(int), minlength=len(L.STATUS_NAMES))
        print(f"  NOTE: {prep.nsteps.sum() - taken} steps not taken; statuses "
              f"{dict(zip(L.STATUS_NAMES, bad.tolist()))}")
    return taken


def first_reversal(t: np.ndarray, spin: np.ndarray, band: float = BAND) -> float:
    """First reversal time of one sampled spin history (MODEL.md section 6): the first
    sample beyond -band*|n0| on the side opposite n0, reported at the last zero crossing
    before it, linearly interpolated. NaN if none (or n0 == 0)."""
    i = reversal_bracket(spin, band)
    if i is None:
        return math.nan
    return t[i + 1] - (t[i + 1] - t[i]) * spin[i + 1] / (spin[i + 1] - spin[i])


def reversal_bracket(spin: np.ndarray, band: float = BAND) -> int | None:
    """Index i such that the first reversal's zero crossing lies in [i, i+1]."""
    s = np.sign(spin[0])
    if s == 0:
        return None
    beyond = np.flatnonzero(s * spin < -band * abs(spin[0]))
    if beyond.size == 0:
        return None
    before = np.flatnonzero(s * spin[:beyond[0]] > 0)
    return int(before[-1])


def rule(width: int = 103) -> str:
    return "-" * width


# --------------------------------------------------------------------------------------
# 1. throughput
# --------------------------------------------------------------------------------------

def bench_throughput(sizes, thread_counts, target_s, repeats):
    """Prints the throughput table; returns {(mu, n, threads): steps per second}."""
    print("\n1. THROUGHPUT  (kane_levinson, spins linspace(-10, 10, n) rad/s, roll 0.5 deg, "
          f"RK4, dt = {DT * 1e3:.4f} ms)")
    print(f"   t_end sized for ~{target_s:g} s per run on one core at a nominal "
          f"{NOMINAL_RATE:.0e} lane-steps/s, at least {MIN_T_END:g} s simulated; best of "
          f"{repeats} after 1 warm-up; "
          f"BLOCK = {L.BLOCK} lanes")
    print(rule())
    print(f"{'mu':>5} {'batch':>6} {'lanes':>5} {'t_end s':>8} {'steps/traj':>10} "
          f"{'pack us/traj':>12} {'thr':>3} {'wall s':>7} {'spread':>6} "
          f"{'Msteps/s':>9} {'/core':>7} {'slip':>5} {'other':>6}")
    print(rule())
    rates = {}
    for mu in (math.inf, 0.3):
        for n in sizes:
            t_end = t_end_for(n, target_s)
            t0 = time.perf_counter()
            prep = sweep_prep(n, mu, t_end)
            pack = time.perf_counter() - t0
            steps_per_traj = int(prep.nsteps.max())
            for threads in thread_counts:
                tm, obs = time_kernel(prep, threads, repeats)
                rate = steps_taken(obs, prep) / tm.best
                rates[(mu, n, threads)] = rate
                slip = float(np.nanmean(obs[L.O_SLIP_FRAC]))
                print(f"{mu:>5g} {n:>6d} {n / padded_lanes(n):>5.2f} {t_end:>8.4g} "
                      f"{steps_per_traj:>10d} {pack / n * 1e6:>12.2f} {threads:>3d} "
                      f"{tm.best:>7.3f} {tm.spread:>6.1%} {rate / 1e6:>9.2f} "
                      f"{rate / threads / 1e6:>7.2f} {slip:>5.3f} {tm.other:>5.2f}{tm.flag}")
    print(rule())
    print(f"other: cores kept busy by other processes during the best run; * = they needed "
          f"a core this run used, even after {EXTRA_TRIES} extra tries: rerun")
    return rates


def bench_fixed_cost(n: int, rate_1thread: float | None, repeats: int) -> float:
    """Prints and returns the cost per trajectory that does not depend on its length:
    ``execute`` on n launches with no steps to take (the block set-up, the write-out of
    the final state and observables, and execute's array copies), in seconds."""
    prep = sweep_prep(n, math.inf, DT)
    prep = dataclasses.replace(prep, nsteps=np.zeros_like(prep.nsteps))
    run_kernel(prep, 1)
    cost = best_of(lambda: run_kernel(prep, 1), max(repeats, 5)).best / n
    print(f"\n1b. FIXED COST PER TRAJECTORY  (execute on {n} launches with no steps, "
          f"one thread)")
    print(f"   {cost * 1e9:.0f} ns per trajectory: block set-up, write-out of the final "
          f"state and observables, execute's array copies")
    if rate_1thread:
        c_steps = cost * rate_1thread
        print(f"   = {c_steps:.1f} steps at the batch-{n} rate above "
              f"({rate_1thread / 1e6:.2f} M steps/s). A run of L steps per trajectory "
              f"gets L / (L + {c_steps:.1f}) of that rate:")
        print("   " + ", ".join(f"L = {steps}: {steps / (steps + c_steps):.1%}"
                               for steps in (184, 1126, 5630)))
    return cost


# --------------------------------------------------------------------------------------
# 2. memory
# --------------------------------------------------------------------------------------

def bench_memory(sizes):
    print("\n2. MEMORY  (bytes per trajectory; rolling batch, no time series recorded)")
    print(rule(80))
    print(f"{'batch':>6} {'kernel arrays B':>16} {'B/traj':>8} "
          f"{'tracemalloc peak B':>19} {'B/traj':>8}")
    print(rule(80))
    t_end = 10 * DT  # memory does not depend on the run length without recording
    peaks = {}
    for n in sizes:
        tracemalloc.start()
        prep = sweep_prep(n, math.inf, t_end)
        obs = run_kernel(prep, 1)[0]
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        arrays = prep.P.nbytes + prep.Y.nbytes + prep.nsteps.nbytes + obs.nbytes
        peaks[n] = peak
        print(f"{n:>6d} {arrays:>16d} {arrays / n:>8.1f} {peak:>19d} {peak / n:>8.1f}")
        del prep, obs
    print(rule(80))
    big = sorted(sizes)[-2:]
    if len(big) == 2:
        slope = (peaks[big[1]] - peaks[big[0]]) / (big[1] - big[0])
        print(f"marginal tracemalloc peak between n = {big[0]} and {big[1]}: "
              f"{slope:.1f} B per trajectory")
    lanes = (L.N_PARAM + L.N_STATE) * 8 + 8 + L.N_OBS * 8
    print(f"kernel arrays per padded lane: (N_PARAM + N_STATE) * 8 + 8 + N_OBS * 8 = "
          f"{lanes} B; per-thread block workspace (not per trajectory): "
          f"{L.N_WORK * L.BLOCK * 8} B")
    print(f"process peak RSS so far (ru_maxrss): "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


# --------------------------------------------------------------------------------------
# 3. baselines
# --------------------------------------------------------------------------------------

def cross(a, b):
    """a x b for stacks of vectors, shape (3, n)."""
    return np.array([a[1] * b[2] - a[2] * b[1],
                     a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def solve3(M, b):
    """Solve M x = b for a stack of 3x3 systems, M (3, 3, n), b (3, n). Adjugate formula:
    the inverse has columns (r1 x r2, r2 x r0, r0 x r1) / det for rows r_i; much faster
    than np.linalg.solve on small stacked systems."""
    c0, c1, c2 = cross(M[1], M[2]), cross(M[2], M[0]), cross(M[0], M[1])
    det = (M[0] * c0).sum(0)
    return (c0 * b[0] + c1 * b[1] + c2 * b[2]) / det


class NumpyRolling:
    """Rolling (stick, mu = inf) rattleback, vectorised over a batch with NumPy.

    State y (11, n): quaternion (w, x, y, z) body -> world, body-frame omega, horizontal
    position X, Y and velocity V_X, V_Y of G. Written from MODEL.md sections 3-4 (not from
    the kernel) so that agreement with the kernel is a real check.
    """

    def __init__(self, body: rs.Body, g: float = 9.81):
        self.m = body.mass
        self.g = g
        self.A = np.array([body.a ** 2, body.b ** 2, body.c ** 2])[:, None]
        self.G = np.asarray(body.com, dtype=float)[:, None]
        self.I = np.asarray(body.inertia, dtype=float)

    @staticmethod
    def frame(q):
        """First two rows of R(q) and n_hat (its third row), for any non-zero q."""
        q0, q1, q2, q3 = q
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        row0 = np.array([1 - s * (q2 * q2 + q3 * q3), s * (q1 * q2 - q0 * q3),
                         s * (q1 * q3 + q0 * q2)])
        row1 = np.array([s * (q1 * q2 + q0 * q3), 1 - s * (q1 * q1 + q3 * q3),
                         s * (q2 * q3 - q0 * q1)])
        up = np.array([s * (q1 * q3 - q0 * q2), s * (q2 * q3 + q0 * q1),
                       1 - s * (q1 * q1 + q2 * q2)])
        return row0, row1, up

    def contact(self, up):
        """rho (from G to the contact point) and the pieces of ds_P/dt."""
        an = self.A * up
        sigma = np.sqrt((up * an).sum(0))
        return -an / sigma - self.G, an, sigma

    def rhs(self, y):
        m, g = self.m, self.g
        q0, q1, q2, q3 = y[0:4]
        w = y[4:7]
        row0, row1, up = self.frame(y[0:4])
        rho, an, sigma = self.contact(up)
        dup = cross(up, w)  # d n_hat / dt in body components
        dsp = -self.A * dup / sigma + an * ((an * dup).sum(0) / sigma ** 3)
        wv = cross(w, cross(w, rho) + dsp)
        # stick: (I + m(|rho|^2 1 - rho rho^T)) wdot = -w x Iw + m rho x (g n_hat - wv)
        M = (self.I[:, :, None] + m * (rho * rho).sum(0) * np.eye(3)[:, :, None]
             - m * rho[:, None, :] * rho[None, :, :])
        wdot = solve3(M, -cross(w, self.I @ w) + m * cross(rho, g * up - wv))
        a_g = -(cross(wdot, rho) + wv)  # acceleration of G, body components
        dy = np.empty_like(y)
        dy[0] = -0.5 * (q1 * w[0] + q2 * w[1] + q3 * w[2])
        dy[1] = 0.5 * (q0 * w[0] + q2 * w[2] - q3 * w[1])
        dy[2] = 0.5 * (q0 * w[1] + q3 * w[0] - q1 * w[2])
        dy[3] = 0.5 * (q0 * w[2] + q1 * w[1] - q2 * w[0])
        dy[4:7] = wdot
        dy[7:9] = y[9:11]
        dy[9] = (row0 * a_g).sum(0)
        dy[10] = (row1 * a_g).sum(0)
        return dy

    def spin(self, y):
        """n = omega . n_hat (rad/s)."""
        return (y[4:7] * self.frame(y[0:4])[2]).sum(0)

    def initial(self, spin, roll):
        """Rolling launch: tilted by `roll` about body x, spinning at `spin` about the
        vertical, G moving so that the material contact point is at rest."""
        spin = np.atleast_1d(np.asarray(spin, dtype=float))
        y = np.zeros((11, spin.size))
        y[0] = math.cos(roll / 2)
        y[1] = math.sin(roll / 2)
        row0, row1, up = self.frame(y[0:4])
        y[4:7] = spin * up
        v_g = -cross(y[4:7], self.contact(up)[0])  # v_P = v_G + omega x rho = 0
        y[9] = (row0 * v_g).sum(0)
        y[10] = (row1 * v_g).sum(0)
        return y

    def rk4(self, y, dt, nsteps):
        """Classic RK4 with the quaternion renormalised after every step, as the kernel.
        Returns the final state and the spin at every step, (nsteps + 1, n)."""
        spins = np.empty((nsteps + 1, y.shape[1]))
        spins[0] = self.spin(y)
        for k in range(nsteps):
            k1 = self.rhs(y)
            k2 = self.rhs(y + 0.5 * dt * k1)
            k3 = self.rhs(y + 0.5 * dt * k2)
            k4 = self.rhs(y + dt * k3)
            y = y + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            y[0:4] /= np.sqrt((y[0:4] ** 2).sum(0))
            spins[k + 1] = self.spin(y)
        return y, spins


def kernel_spin_history(spins, t_end, record_every, dt=None):
    """Kernel run of rolling launches with recorded spin: (obs, times, spin (n, n_rec))."""
    prep = prepare(BODY, spin=spins, roll=ROLL, t_end=t_end, dt=dt)
    obs, rec, _ = execute(prep, method=RK4, record_every=record_every, band=BAND,
                          parallel=False)
    step = float(prep.coords["dt"][1][0]) * record_every
    return obs, np.arange(rec.shape[1]) * step, rec[..., L.R_SPIN]


def check_numpy_against_kernel(model, t_end):
    """Both integrators from the same launches to t_end: compare first reversal times and
    spin histories. Returns True when the fast launch agrees to 1e-6 s."""
    spins = np.array([FAST_SPIN, -FAST_SPIN, 2.0, 3.0, 8.0, 10.0, -8.0, -10.0])
    every = 1  # every step, so the rule below sees exactly what the kernel saw
    obs, t_rec, spin_k = kernel_spin_history(spins, t_end, every)
    nsteps = math.ceil(t_end / DT * (1.0 - 1e-12))  # as prepare() counts steps
    y0 = model.initial(spins, ROLL)
    prep = prepare(BODY, spin=spins, roll=ROLL, t_end=t_end)
    y0_kernel = prep.Y.transpose(1, 0, 2).reshape(L.N_STATE, -1)[:, :spins.size]
    t0 = time.perf_counter()
    _, spin_np = model.rk4(y0, DT, nsteps)
    wall = time.perf_counter() - t0
    t_np = np.arange(nsteps + 1) * DT

    print(f"   a) check: NumPy RK4 vs kernel, {spins.size} rolling launches to t = {t_end:g} s "
          f"at dt ({nsteps} steps, NumPy took {wall:.1f} s)")
    print(f"      launch state max |NumPy - kernel packing| = "
          f"{np.abs(y0 - y0_kernel).max():.2e}")
    print(f"      {'spin0':>7} {'t_rev kernel s':>15} {'t_rev NumPy s':>15} {'diff s':>10} "
          f"{'max |dspin| rad/s':>18}")
    fast_ok = False
    for j, n0 in enumerate(spins):
        tk = obs[L.O_FIRST_REV, j]
        tn = first_reversal(t_np, spin_np[:, j])
        diff = abs(tk - tn) if math.isfinite(tk) and math.isfinite(tn) else math.nan
        both_none = math.isnan(tk) and math.isnan(tn)
        dspin = np.abs(spin_np[::every, j][:spin_k.shape[1]] - spin_k[j]).max()
        shown = "both none" if both_none else f"{diff:10.2e}"
        print(f"      {n0:>7g} {tk:>15.9f} {tn:>15.9f} {shown:>10} {dspin:>18.2e}")
        if n0 == FAST_SPIN:
            fast_ok = math.isfinite(diff) and diff <= 1e-6
    # the kernel's on-the-fly observable must equal this script's rule on its record,
    # or the baselines below would not measure the same thing
    t_from_rec = first_reversal(t_rec, spin_k[0])
    print(f"      fast launch: |t_rev NumPy - t_rev kernel| <= 1e-6 s: "
          f"{'PASS' if fast_ok else 'FAIL'}; this script's rule on the kernel's recorded "
          f"spin: {t_from_rec:.9f} s")
    return fast_ok


def bench_numpy(model, n, t_end, repeats):
    """NumPy RK4 vs the kernel (one thread) on the same rolling batch. Returns rates."""
    spins = np.linspace(-10.0, 10.0, n)
    nsteps = math.ceil(t_end / DT * (1.0 - 1e-12))
    y0 = model.initial(spins, ROLL)
    model.rk4(y0, DT, 2)  # warm-up
    # slow: fewer repeats than the kernel
    np_tm = best_of(lambda: model.rk4(y0, DT, nsteps), max(1, repeats - 1))
    np_rate = n * nsteps / np_tm.best
    prep = sweep_prep(n, math.inf, t_end)
    tm, obs = time_kernel(prep, 1, repeats)
    k_rate = steps_taken(obs, prep) / tm.best
    print(f"\n   a) speed: rolling batch n = {n}, t_end = {t_end:g} s ({nsteps} steps), "
          f"one thread")
    for name, t, rate in (("NumPy RK4 loop", np_tm, np_rate), ("kernel", tm, k_rate)):
        print(f"      {name:<14}: {t.best:8.3f} s  {rate / 1e6:8.3f} Msteps/s   other load "
              f"{t.other:.2f}{t.flag}")
    print(f"      kernel / NumPy = {k_rate / np_rate:.1f}x")
    return np_rate, k_rate


def kernel_reversal(dt):
    prep = prepare(BODY, spin=FAST_SPIN, roll=ROLL, t_end=7.0, dt=dt)
    obs = run_kernel(prep, 1)[0]
    return float(obs[L.O_FIRST_REV, 0])


def ivp_reversal(model, sol, t_end):
    """First reversal of a solve_ivp dense solution: the rule on a 1 ms grid locates the
    crossing, then the zero of the dense spin in that interval gives the instant."""
    from scipy.optimize import brentq

    t = np.linspace(0.0, t_end, int(round(t_end / 1e-3)) + 1)
    spin = model.spin(sol(t))
    i = reversal_bracket(spin)
    if i is None:
        return math.nan
    return brentq(lambda s: model.spin(sol(s)[:, None])[0], t[i], t[i + 1], xtol=1e-12)


def bench_solve_ivp(model, kernel_rate_1thread, rate_label, rtols, kernel_rate_batch1=None):
    """DOP853 on one trajectory at matched reversal-time accuracy vs the kernel."""
    from scipy.integrate import solve_ivp

    t_end = 7.0
    t_ref = kernel_reversal(DT / 8)
    errs = {f"dt/{k}" if k > 1 else "dt": kernel_reversal(DT / k) - t_ref for k in (1, 2, 4)}
    e_k = abs(errs["dt"])
    tol = max(e_k, 1e-3)
    print(f"\n   b) scipy solve_ivp DOP853, fast launch (spin +{FAST_SPIN:g} rad/s, roll 0.5 "
          f"deg, rolling), one trajectory to t = {t_end:g} s")
    print(f"      reference: kernel at dt/8, first reversal {t_ref:.9f} s; kernel error "
          + ", ".join(f"{k}: {v:+.2e} s" for k, v in errs.items()))
    print(f"      accuracy to match: max(e_k, 1e-3 s) = {tol:.2e} s")

    y0 = model.initial(FAST_SPIN, ROLL)[:, 0]

    def fun(t, y):
        return model.rhs(y[:, None])[:, 0]

    print(f"      {'rtol':>7} {'atol':>7} {'steps':>6} {'nfev':>7} {'wall s':>7} "
          f"{'us/fev':>6} {'t_rev s':>12} {'error s':>10} {'ok':>3}")
    rows = []
    for rtol in rtols:
        atol = rtol * 1e-3
        t0 = time.perf_counter()
        sol = solve_ivp(fun, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=atol,
                        dense_output=True)
        wall = time.perf_counter() - t0
        t_rev = ivp_reversal(model, sol.sol, t_end) if sol.success else math.nan
        err = abs(t_rev - t_ref)
        ok = bool(err <= tol)  # NaN (no reversal found) is not ok
        rows.append((rtol, wall, err))
        print(f"      {rtol:>7.0e} {atol:>7.0e} {sol.t.size - 1:>6d} {sol.nfev:>7d} "
              f"{wall:>7.3f} {wall / sol.nfev * 1e6:>6.0f} {t_rev:>12.6f} {err:>10.2e} "
              f"{'yes' if ok else 'no':>3}")

    chosen = loosest_passing(rows, tol)
    if chosen is None:
        print("      no scanned tolerance reaches the accuracy; no ratio reported")
        return
    rtol, wall = chosen
    ivp_speed = t_end / wall
    k_speed = kernel_rate_1thread * DT
    print(f"      chosen rtol = {rtol:.0e}: {wall:.3f} s wall, {ivp_speed:.2f} simulated "
          f"trajectory-s per wall s")
    print(f"      kernel ({rate_label}, 1 thread): {kernel_rate_1thread / 1e6:.2f} Msteps/s "
          f"x dt = {k_speed:.0f} simulated trajectory-s per wall s")
    print(f"      kernel / solve_ivp = {k_speed / ivp_speed:.0f}x")
    if kernel_rate_batch1 is not None:
        k1 = kernel_rate_batch1 * DT
        print(f"      (kernel with a batch of 1, 1 thread: {k1:.0f} simulated trajectory-s per "
              f"wall s, {k1 / ivp_speed:.0f}x solve_ivp)")
    # the 1e-3 s floor is looser than the kernel's own error: show that comparison too
    strict = loosest_passing(rows, e_k) if e_k < tol else None
    if strict is not None:
        print(f"      at the kernel's own accuracy e_k = {e_k:.2e} s: rtol = {strict[0]:.0e}, "
              f"{strict[1]:.3f} s wall, kernel / solve_ivp = "
              f"{k_speed / (t_end / strict[1]):.0f}x")
    elif e_k < tol:
        print(f"      no scanned rtol reaches the kernel's own accuracy e_k = {e_k:.2e} s")


def loosest_passing(rows, tol):
    """(rtol, wall) of the loosest rtol such that it and every tighter one scanned have
    error <= tol, or None. rows: (rtol, wall, error)."""
    chosen = None
    for rtol, wall, err in sorted(rows, key=lambda r: r[0]):
        if not err <= tol:
            break
        chosen = (rtol, wall)
    return chosen


# --------------------------------------------------------------------------------------
# 4. first-call latency
# --------------------------------------------------------------------------------------

LATENCY_SNIPPET = """
import time
t0 = time.perf_counter()
import numpy as np
import rattlesweep as rs
t1 = time.perf_counter()
body = rs.Body.preset("kane_levinson")
rs.simulate(body, spin=5.0, roll=0.01, t_end=0.01)
t2 = time.perf_counter()
rs.run_batch(body, spin=np.array([5.0, 6.0]), roll=0.01, t_end=0.01)
t3 = time.perf_counter()
print(t1 - t0, t2 - t0, t3 - t0)
"""


WARM_CACHE_SNIPPET = """
import math
import bench_kernel as b
b.run_kernel(b.sweep_prep(2, math.inf, b.DT), 1)
b.run_kernel(b.sweep_prep(2, math.inf, b.DT), 2)
"""


def fresh_process_times(cache_dir):
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", LATENCY_SNIPPET], env=env, check=True,
                         capture_output=True, text=True).stdout
    return [float(x) for x in out.split()]


def bench_latency():
    print("\n4. FIRST-CALL LATENCY  (fresh interpreter; seconds from before "
          "`import rattlesweep`, cumulative)")
    print(rule(80))
    print(f"{'numba cache':<30} {'import':>8} {'+ simulate':>11} {'+ run_batch':>12}")
    print(rule(80))
    with tempfile.TemporaryDirectory(prefix="rattlesweep-numba-cache-") as cache:
        for label in ("cold (empty NUMBA_CACHE_DIR)", "warm (populated cache)"):
            imp, sim, batch = fresh_process_times(cache)
            print(f"{label:<30} {imp:>8.2f} {sim:>11.2f} {batch:>12.2f}")
    print(rule(80))
    print("simulate uses the serial kernel, run_batch the parallel one (compiled on top)")


# --------------------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="fewer batch sizes, shorter runs, fewer repeats")
    ap.add_argument("--max-batch", type=int, default=None,
                    help="largest batch size to measure")
    ap.add_argument("--target", type=float, default=None,
                    help="seconds per throughput run on one core (default 1.5, quick 0.25)")
    ap.add_argument("--repeats", type=int, default=None,
                    help="timed runs per configuration (default 3, quick 2)")
    ap.add_argument("--skip", default="",
                    help="comma-separated sections to skip: throughput,memory,numpy,ivp,latency")
    args = ap.parse_args(argv)

    sizes = QUICK_SIZES if args.quick else FULL_SIZES
    if args.max_batch is not None:
        sizes = tuple(n for n in sizes if n <= args.max_batch) or (1,)
    target = args.target or (0.25 if args.quick else 1.5)
    repeats = args.repeats or (2 if args.quick else 3)
    thread_counts = sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)})
    skip = set(filter(None, args.skip.split(",")))
    t_start = time.perf_counter()
    load0 = os.getloadavg()[0]  # other work on the machine skews every timing below

    print(f"rattlesweep {rs.__version__}, numba {numba.__version__}, numpy {np.__version__}, "
          f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, numba threads "
          f"{numba.config.NUMBA_NUM_THREADS}, mode {'quick' if args.quick else 'full'}")
    # The kernels are compiled into numba's cache by a child process first, so that this
    # one loads them: on the benchmark machine a process that compiles the kernels
    # itself runs them about 6 % slower than one that loads them from the cache
    # (see the README). The first call here, which loads them, is kept
    # out of every timing below.
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", WARM_CACHE_SNIPPET], check=True,
                   cwd=os.path.dirname(os.path.abspath(__file__)))
    print(f"kernels compiled into (or found in) numba's cache by a child process: "
          f"{time.perf_counter() - t0:.1f} s")
    run_kernel(sweep_prep(2, math.inf, DT), 1)
    run_kernel(sweep_prep(2, math.inf, DT), 2)

    rates = {}
    if "throughput" not in skip:
        rates = bench_throughput(sizes, thread_counts, target, repeats)
        bench_fixed_cost(max(sizes), rates.get((math.inf, max(sizes), 1)), repeats)
    if "memory" not in skip:
        bench_memory(sizes)

    model = NumpyRolling(BODY)
    if "numpy" not in skip or "ivp" not in skip:
        print("\n3. BASELINES  (same rolling equations in plain NumPy)")
    n_np = min(4096, max(sizes))
    if "numpy" not in skip:
        check_numpy_against_kernel(model, 7.0)
        bench_numpy(model, n_np, 0.1 if args.quick else 0.25, repeats)
    if "ivp" not in skip:
        key = (math.inf, n_np, 1)
        if key not in rates:  # throughput section skipped: measure the kernel here
            prep = sweep_prep(n_np, math.inf, t_end_for(n_np, target))
            tm, obs = time_kernel(prep, 1, repeats)
            rates[key] = steps_taken(obs, prep) / tm.best
        # the loose end is where the matched tolerance lies; quick mode stops early
        rtols = [10.0 ** -k for k in range(4, 8 if args.quick else 11)]
        bench_solve_ivp(model, rates[key], f"mu = inf, batch {n_np}", rtols,
                        rates.get((math.inf, 1, 1)))
    if "latency" not in skip:
        bench_latency()
    print(f"\ntotal benchmark time {time.perf_counter() - t_start:.0f} s; load average "
          f"(1 min) at start {load0:.2f}, at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
