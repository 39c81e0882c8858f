"""MuJoCo (the `peers` extra) starts from rattlesweep's launch and agrees with it where
both models are the same physics: the rolling kane_levinson launch spun the slow way.

The MuJoCo model and the launch conversion are those of benchmarks/bench_peers.py
(benchmarks/peers/mujoco_rattleback.py). Skipped when mujoco is not installed.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import rattlesweep as rs
from conftest import HALF_DEGREE
from numpy_oracle import first_reversal

pytest.importorskip("mujoco")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from peers import mujoco_rattleback as mj

SLOW = -5.0  # rad/s, I_xy n < 0: the slow, roll-driven reversal
T_END = 12.5  # s
# soft but stiff contact; implicitfast: the cheapest MuJoCo setting that follows this
# launch (about 1 s of MuJoCo for 12.5 s simulated)
CONTACT = mj.Contact(5e-4, 1e-4, "implicitfast")
MU = 5.0  # MuJoCo's friction is finite: this one never reaches the cone here


def launch(body, spin):
    return rs.run_batch(
        body, spin=spin, pitch=HALF_DEGREE, t_end=body.default_dt(), record_every=1
    ).isel(time=0, trajectory=0)


def mujoco_state(model, start):
    return mj.launch_states(model, start)[0]


def test_mujoco_starts_where_rattlesweep_does(kl):
    start = launch(kl, SLOW)
    model, _ = mj.build(kl, MU, CONTACT)
    state = mujoco_state(model, start)
    found = mj.check_same_start(model, kl, state, start.contact_point.values, SLOW)
    assert found["contacts"] == 1 and found["contact_distance"] < 1e-12
    # the check itself fails on a launch that differs: the other spin sense, a launch
    # 0.1 mm off the floor, a mirrored body
    with pytest.raises(AssertionError, match="spin"):
        mj.check_same_start(model, kl, state, start.contact_point.values, -SLOW)
    lifted = state.copy()
    lifted[3] += 1e-4  # qpos z of G follows the time entry of the state
    with pytest.raises(AssertionError, match="contact_distance"):
        mj.check_same_start(model, kl, lifted, start.contact_point.values, SLOW)
    mirrored = rs.Body(
        kl.a,
        kl.b,
        kl.c,
        kl.mass,
        kl.com,
        kl.inertia * np.array([[1, -1, 1], [-1, 1, 1], [1, 1, 1]]),
        full_ellipsoid=True,
    )
    with pytest.raises(AssertionError, match="inertia"):
        mj.check_same_start(
            mj.build(mirrored, MU, CONTACT)[0], kl, state, start.contact_point.values, SLOW
        )


def test_mujoco_and_rattlesweep_agree_on_the_slow_sense(kl):
    """Rolling, -5 rad/s, pitch 0.5 deg: rattlesweep's first reversal (11.62 s; it
    converges with dt to 1e-8 s, and tight solve_ivp agrees) and MuJoCo's agree within
    1 %. MuJoCo's contact is soft: this setting gives 11.55 s, and it tends to 11.62 s
    as the contact time constant shrinks (11.616 s at 1e-4 s, 11.621 s at 1e-5 s)."""
    model, _ = mj.build(kl, MU, CONTACT)
    state = mujoco_state(model, launch(kl, SLOW))
    nstep = int(round(T_END / CONTACT.dt))
    spin = mj.spin_histories(model, state, nstep)[0]
    t_mujoco = first_reversal(np.arange(nstep + 1) * CONTACT.dt, spin)
    t_rattlesweep = float(
        rs.run_batch(kl, spin=SLOW, pitch=HALF_DEGREE, t_end=T_END).first_reversal_time[0]
    )
    assert 11.5 < t_rattlesweep < 11.7
    assert math.isfinite(t_mujoco)
    assert abs(t_mujoco / t_rattlesweep - 1.0) < 0.01, (t_mujoco, t_rattlesweep)
