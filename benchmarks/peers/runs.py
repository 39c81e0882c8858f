"""The launches of benchmarks/bench_peers.py and their references: the shared constants,
a meter of wall and CPU time, rattlesweep's t = 0 states, one launch run by each engine,
the solve_ivp references (rolling, and the event-driven Coulomb solution of
tests/event_reference.py), and the check that every engine starts from the same state."""

from __future__ import annotations

import math
import os
import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

import rattlesweep as rs
from bench_kernel import BODY, DT, ROOT
from peers import jax_rolling
from peers import mujoco_rattleback as mj
from rattlesweep import CoarseStepWarning

sys.path.insert(0, str(ROOT / "tests"))
from event_reference import rattleback_events
from numpy_oracle import NumpyRolling, first_reversal

PITCH = math.radians(0.5)
FAST, SLOW = 5.0, -5.0  # rad/s
T_FAST, T_SLOW = 3.0, 12.5  # s, past each launch's first reversal (2.36-2.85 s; 11.6 s)
MU_MUJOCO_ROLLING = 5.0  # MuJoCo's stand-in for mu = inf: it never reaches the cone here
GRID = 1e-4  # s, sampling of dense outputs for their first reversal
STIFF = mj.Contact(5e-4, 1e-4)  # a stiff but usual MuJoCo contact
STIFF_IMPLICIT = mj.Contact(5e-4, 1e-4, "implicitfast")
FINE = mj.Contact(1e-5, 5e-6)


# --------------------------------------------------------------------------------------
# measuring
def _busy_seconds():
    """CPU seconds the whole machine has been busy (all cores), or None off Linux."""
    try:
        with open("/proc/stat") as f:
            ticks = [int(x) for x in f.readline().split()[1:]]
    except OSError:
        return None
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf(
        "SC_CLK_TCK"
    )  # less idle, iowait


@dataclass
class Meter:
    """Wall time of the timed blocks, the CPU this process used in them and the CPU the
    rest of the machine used meanwhile (in cores: CPU seconds per wall second)."""

    wall: float = 0.0
    own_cpu: float = 0.0
    other_cpu: float = 0.0
    loads: list = field(default_factory=list)

    def time(self, fn):
        busy, own, t0 = _busy_seconds(), time.process_time(), time.perf_counter()
        out = fn()
        wall, own = time.perf_counter() - t0, time.process_time() - own
        self.wall += wall
        self.own_cpu += own
        if busy is not None:
            self.other_cpu += max(0.0, _busy_seconds() - busy - own)
        self.loads.append(os.getloadavg()[0])
        return out, wall

    def cores(self) -> float:
        return self.own_cpu / self.wall if self.wall > 0 else math.nan

    def others(self) -> float:
        return self.other_cpu / self.wall if self.wall > 0 else math.nan


# --------------------------------------------------------------------------------------
# launches and references
def launch(spins, mu=math.inf):
    """rattlesweep's t = 0 state of the launches, over ``trajectory``."""
    return rs.run_batch(
        BODY, spin=np.atleast_1d(spins), pitch=PITCH, mu=mu, t_end=DT, record_every=1
    ).isel(time=0)


def oracle_state(start, i=0) -> np.ndarray:
    """(11,) state of launch i in the layout of tests/numpy_oracle.py."""
    return np.concatenate(
        [
            start.quaternion.values[i],
            start.omega.values[i],
            start.position.values[i, :2],
            start.velocity.values[i, :2],
        ]
    )


def jax_states(start) -> np.ndarray:
    return jax_rolling.initial_state(start.quaternion.values, start.omega.values)


@dataclass
class Run:
    """One launch in one engine: spin n (rad/s) at times t (s), first reversal (s), wall
    time (s) and the other processes' CPU meanwhile (cores)."""

    t: np.ndarray
    spin: np.ndarray
    first_reversal: float
    wall: float
    others: float


def metered(fn):
    meter = Meter()
    (t, spin, t_rev), wall = meter.time(fn)
    return Run(np.asarray(t), np.asarray(spin), float(t_rev), wall, meter.others())


def solve_rolling(spin, t_end, rtol):
    """solve_ivp DOP853 of the rolling equations: (Run, spin at any t). The timed part
    is the integration; the first reversal is read off the dense output every GRID s."""
    model, y0, meter = NumpyRolling(BODY), oracle_state(launch(spin)), Meter()
    sol, wall = meter.time(
        lambda: solve_ivp(
            lambda t, y: model.rhs(y[:, None])[:, 0],
            (0.0, t_end),
            y0,
            method="DOP853",
            rtol=rtol,
            atol=rtol * 1e-3,
            dense_output=True,
        )
    )
    grid = np.arange(0.0, t_end + GRID / 2, GRID)
    n = model.spin(sol.sol(grid))
    run = Run(grid, n, first_reversal(grid, n), wall, meter.others())
    return run, lambda t: model.spin(sol.sol(t))


def solve_coulomb(spin, mu, t_end, rtol, samples=601):
    """The event-driven solve_ivp solution of tests/event_reference.py: (Run, spin at
    any t). Its first reversal comes from located zeros of the spin; the timed part
    includes the evaluation of its (few) samples."""
    y0, meter = oracle_state(launch(spin, mu)), Meter()
    ev, wall = meter.time(
        lambda: rattleback_events(
            BODY, y0, mu=mu, t_end=t_end, rtol=rtol, atol=rtol * 1e-2, samples=samples
        )
    )
    return Run(ev.t, ev.spin, ev.first_reversal_time, wall, meter.others()), ev.spin_at


def run_rattlesweep(spin, mu, t_end, dt) -> Run:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CoarseStepWarning)

        def go():
            run = rs.simulate(BODY, spin=spin, pitch=PITCH, mu=mu, t_end=t_end, dt=dt)
            return run.time.values, run.spin.values, float(run.first_reversal_time)

        return metered(go)


def run_mujoco(spin, mu, t_end, contact) -> Run:
    model, _ = mj.build(BODY, mu, contact)
    start = launch(spin)
    state = mj.launch_states(model, start)
    nstep = int(round(t_end / contact.dt))

    def go():
        t = np.arange(nstep + 1) * contact.dt
        n = mj.spin_histories(model, state, nstep)[0]
        return t, n, first_reversal(t, n)

    return metered(go)


def same_start():
    """Section 1: MuJoCo's launch against rattlesweep's, for both spins and frictions."""
    print(
        "\n1. SAME START (MuJoCo against rattlesweep's t = 0 state; largest discrepancy "
        "over +-5 rad/s, mu = 0.3 and 5)"
    )
    worst = {}
    for spin in (FAST, SLOW):
        for mu in (0.3, MU_MUJOCO_ROLLING):
            start = launch(spin)
            model, _ = mj.build(BODY, mu, STIFF)
            state = mj.launch_states(model, start)[0]
            found = mj.check_same_start(
                model, BODY, state, start.contact_point.values[0], spin
            )
            for key, value in found.items():
                worst[key] = max(worst.get(key, 0), value)
    units = dict(
        mass="relative",
        com="m",
        inertia="relative",
        contacts="",
        contact_distance="m",
        contact_point="m",
        contact_velocity="m/s",
        spin="rad/s",
    )
    print(
        "  "
        + ", ".join(
            f"{k} {v:.1e} {units[k]}".strip() if k != "contacts" else f"contacts {v}"
            for k, v in worst.items()
        )
    )
    print("  JAX: the same quaternion and body omega, number for number")
