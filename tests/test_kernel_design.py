"""Design rules of the kernels that no result shows: the right-hand side writes nothing
but its outputs, and the compiled variants are a counted, bounded set."""

import math
import re

import numba
import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.rattleback.batch import prepare
from rattlesweep._core import models, stepper
from rattlesweep._core.models import RATTLEBACK
from rattlesweep._core.rattleback import dynamics, layout, slip
from rattlesweep._core.workspace import (
    BLOCK,
    COUPLES,
    H_HALF_DT,
    H_STAGE_DT,
    OFF_H,
    OFF_S,
    OFF_X,
    ROLLING,
    S_DCX,
    S_DCY,
    S_DPX,
    S_DPY,
    S_MODE,
    S_UHX,
    S_UHY,
    SLIDING,
    STAGE_MID,
    STAGE_START,
    S_TURN,
    X_DCX,
    X_DCY,
)


@numba.njit(cache=True)
def _evaluate_sliding(W):
    models.evaluate(W, RATTLEBACK, SLIDING, STAGE_START, False, 0)


@numba.njit(cache=True)
def _evaluate_couples(W):
    models.evaluate(W, RATTLEBACK, COUPLES, STAGE_START, False, 0)


@numba.njit(cache=True)
def _evaluate_sliding_mid(W):
    models.evaluate(W, RATTLEBACK, SLIDING, STAGE_MID, False, 0)


def _slipping_block(all_slow=False):
    """A workspace holding one block of kane_levinson launches, every other lane
    slipping: slowly (steered, where the consistent direction is solved for) or fast,
    with a consistent direction from the step before; or (``all_slow``) every lane
    slipping slowly."""
    n = BLOCK
    prep = prepare(
        rs.Body.preset("kane_levinson"),
        spin=np.linspace(-8.0, 8.0, n),
        roll=math.radians(3.0),
        pitch=math.radians(2.0),
        mu=0.3,
        mu_spin=np.where(np.arange(n) % 3 == 0, 1e-3, 0.0),
        t_end=0.01,
    )
    Y = prep.Y[0].copy()
    offsets = np.where((np.arange(n) % 4 == 1) | all_slow, 1e-5, 1.0)  # m/s: slow, fast
    Y[layout.VEL_X] += offsets
    W = np.zeros(layout.N_WORK * BLOCK)
    for j in range(n):
        assert stepper.load_lane(W, RATTLEBACK, prep.P[0], Y, j)
    lanes = np.arange(BLOCK)
    slipping = (lanes % 2 == 1) | all_slow
    W[(OFF_S + S_MODE) * BLOCK + lanes] = slipping
    angle = 0.3 * lanes
    W[(OFF_S + S_UHX) * BLOCK + lanes] = np.cos(angle)
    W[(OFF_S + S_UHY) * BLOCK + lanes] = np.sin(angle)
    W[(OFF_S + S_DPX) * BLOCK + lanes] = np.cos(angle - 0.01)
    W[(OFF_S + S_DPY) * BLOCK + lanes] = np.sin(angle - 0.01)
    return W, slipping


def _rows(offset, n):
    return slice(offset * BLOCK, (offset + n) * BLOCK)


@pytest.mark.parametrize("all_slow", [False, True], ids=["mixed", "all_slow"])
@pytest.mark.parametrize(
    "evaluate", [_evaluate_sliding, _evaluate_couples], ids=["sliding", "couples"]
)
def test_the_right_hand_side_writes_only_its_outputs(evaluate, all_slow):
    """Evaluated twice at one state, a block gives identical derivatives and outputs, and
    leaves every row but its outputs as it found them: the switching state (modes, slip
    directions, the consistent direction's history) is written by the switching
    module, not by the right-hand side. With every lane slipping slowly, the consistent
    directions are solved for in the block's vector pass."""
    W, slipping = _slipping_block(all_slow)
    before = W.copy()
    evaluate(W)
    first = W.copy()
    evaluate(W)
    np.testing.assert_array_equal(W, first)  # NaN == NaN here
    # the block exercised both kinds of slip (or the vector pass), and put d* among its
    # outputs
    kinds = first[(layout.OFF_G + layout.SLIP_KIND) * BLOCK + np.arange(BLOCK)]
    if all_slow:
        assert set(kinds) == {slip.SLOW_SLIP}
        assert np.all(first[(layout.OFF_G + layout.DSTAR_SLOPE) * BLOCK + np.arange(BLOCK)])
    else:
        assert set(kinds[slipping]) == {slip.FAST_SLIP, slip.SLOW_SLIP}
    assert np.all(first[(OFF_X + X_DCX) * BLOCK + np.flatnonzero(slipping)] != 0.0)
    outputs = np.zeros(W.size, dtype=bool)
    for offset, n in [
        (layout.OFF_A, layout.N_STATE),
        (layout.OFF_T, layout.N_STATE),
        (OFF_X, OFF_S - OFF_X),
        (layout.OFF_G, layout.N_SCRATCH),
    ]:
        outputs[_rows(offset, n)] = True
    changed = np.flatnonzero(
        ~outputs & ~((first == before) | (np.isnan(first) & np.isnan(before)))
    )
    assert changed.size == 0, f"rows written outside the outputs: {set(changed // BLOCK)}"


@pytest.mark.parametrize(
    "evaluate", [_evaluate_sliding, _evaluate_sliding_mid], ids=["start", "mid"]
)
def test_a_slow_slip_solves_alike_in_the_block_pass_and_alone(evaluate):
    """Where enough lanes of a block slip slowly, their consistent directions are solved
    for in one vector pass over the block, else lane by lane: a lane's derivative and
    outputs are the same either way, at a step start (d* wanted) and at an inner stage
    (d* wanted only where it steers), whether the pass solved for the lane, found that
    it cannot steer, or left it to its own solve."""
    lanes = np.arange(BLOCK)
    whole, _ = _slipping_block(all_slow=True)
    # slip speeds up to where the solve is needless at an inner stage
    whole[(layout.OFF_Y + layout.VEL_X) * BLOCK + lanes] += np.linspace(0.0, 0.01, BLOCK)
    stage_state = _rows(layout.OFF_T, layout.N_STATE)
    whole[stage_state] = whole[_rows(layout.OFF_Y, layout.N_STATE)]  # T = Y, half a step on
    whole[(OFF_H + H_STAGE_DT) * BLOCK + lanes] = whole[(OFF_H + H_HALF_DT) * BLOCK + lanes]
    # guesses from a solve at this state: some lanes converge within the pass's steps,
    # the others (no attracting d* near the slip's direction) go on
    probe = whole.copy()
    _evaluate_sliding(probe)
    for x, y in ((S_DCX, S_DCY), (S_DPX, S_DPY)):
        whole[(OFF_S + x) * BLOCK + lanes] = probe[(OFF_X + X_DCX) * BLOCK + lanes]
        whole[(OFF_S + y) * BLOCK + lanes] = probe[(OFF_X + X_DCY) * BLOCK + lanes]
    whole[(OFF_S + S_TURN) * BLOCK + lanes] = 10.0 * np.cos(lanes)  # rad/s: guesses turn
    alone = whole.copy()
    evaluate(whole)
    kinds = whole[(layout.OFF_G + layout.SLIP_KIND) * BLOCK + lanes]
    assert np.all(kinds == slip.SLOW_SLIP)
    dstar = (layout.OFF_G + layout.DSTAR_SLOPE) * BLOCK + lanes
    found = whole[dstar] > 0.0
    cannot = whole[dstar] == -1.0
    left = np.isnan(whole[dstar])
    assert np.all(found | cannot | left)  # the pass ran for every lane
    assert found.any() and left.any()
    if evaluate is _evaluate_sliding_mid:
        assert cannot.any()
    for j in range(BLOCK):
        one = alone.copy()
        one[(OFF_S + S_MODE) * BLOCK + lanes] = lanes == j  # the others stick
        evaluate(one)
        assert np.all(one[dstar] == 0.0)  # solved lane by lane
        for offset, n in [(layout.OFF_A, layout.N_STATE), (OFF_X, OFF_S - OFF_X)]:
            rows = np.arange(offset, offset + n) * BLOCK + j
            np.testing.assert_array_equal(one[rows], whole[rows], err_msg=f"lane {j}")


# --- the compile budget ------------------------------------------------------------------
# Every specialisation is a design decision, declared in _core/specialisations.py: a
# batch at any level compiles nothing beyond it, and `rattlesweep compile` builds it.
USED = """
import json
import rattlesweep as rs
from rattlesweep.planar import PlanarBody, run_planar_batch
from rattlesweep._core import stepper

for friction in ({}, {"mu": 0.3}, {"mu": 0.3, "mu_roll": 1e-4}):
    for parallel in (False, True):
        rs.run_batch(rs.Body.preset("toy"), spin=[-5.0, 5.0], roll_deg=1.0, t_end=0.02,
                     parallel=parallel, **friction)
        run_planar_batch(PlanarBody(a=0.1, b=0.05, mass=0.1), theta=[0.1, 0.3],
                         t_end=0.02, parallel=parallel, **friction)
rs.simulate(rs.Body.preset("toy"), spin=5.0, t_end=0.01, mu=0.3, record_every=1)
print(json.dumps({
    name: [[str(t) for t in sig] for sig in kernel.signatures]
    for name, kernel in [("entry", stepper.integrate_serial),
                         ("launch", stepper.contact_slip_velocity)]
}))
"""


def _on_disk(dispatcher):
    """The signatures numba's on-disk cache holds for a kernel, from the current sources."""
    return [key[0] for key in dispatcher._cache._cache_file._load_index()]


def test_batches_use_only_the_declared_specialisations():
    """In a fresh process, batches of both models at every friction level, serial and
    parallel, and a recorded run call exactly the entries of specialisations.JOBS; and
    the cache holds no right-hand side variant beyond RHS_VARIANTS (one a batch compiled
    outside them would be there: `rattlesweep compile` would not have built it)."""
    import json
    import subprocess
    import sys

    from rattlesweep._core import specialisations
    from rattlesweep._core.planar import dynamics as planar

    out = subprocess.run(
        [sys.executable, "-c", USED], capture_output=True, text=True, check=True
    )
    used = json.loads(out.stdout.splitlines()[-1])
    declared = {
        tuple(str(t) for t in job.signature)
        for job in specialisations.JOBS
        if not job.name.startswith("rhs:")
    }
    called = {tuple(sig) for sig in used["entry"] + used["launch"]}
    assert called == declared  # 2 models x 3 levels, and the launch velocity
    designed = set().union(*specialisations.RHS_VARIANTS.values())
    for kernel in (dynamics.eval_block, planar.eval_block):
        cached = {tuple(t.literal_value for t in sig[1:4]) for sig in _on_disk(kernel)}
        assert cached <= designed, cached - designed


PROBE = """
import rattlesweep as rs
from rattlesweep._core import events, stepper
from rattlesweep._core.rattleback import dynamics, slip
rs.simulate(rs.Body.preset("toy"), spin=5.0, t_end=0.01)
index = lambda d: [key[0] for key in d._cache._cache_file._load_index()]
print(sorted({sig[1].literal_value for sig in index(dynamics.eval_block)}),
      len(index(slip.slip_direction)), len(index(events.locate_lane)),
      sorted({sig[1].literal_value for sig in index(stepper.integrate_serial)}))
"""


def test_a_rolling_run_compiles_no_slip_work(tmp_path):
    """From an empty cache, a rolling run compiles only rolling variants of the
    right-hand side, no slip direction and no located switching."""
    import os
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", PROBE],
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)},
        check=True,
    )
    assert out.stdout.split("\n")[0] == f"[{ROLLING}] 0 0 [{ROLLING}]"
    # a cold call is not silent: it says what compiles, for how long, and what does it
    # ahead, once (the launch velocity's compile after the stepper's says nothing more)
    told = [line for line in out.stderr.splitlines() if "compiling" in line]
    assert len(told) == 1, out.stderr
    assert re.fullmatch(
        r"compiling the simulation kernels for rattleback launches with rolling contact "
        r"\(first use after installing: about \d+ s on one core; later processes load "
        r"them in about a second\)\. `rattlesweep compile` builds every kernel ahead, in "
        r"parallel\.",
        told[0],
    ), told
