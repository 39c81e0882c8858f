"""Fixed-step integration of blocks of trajectories with Coulomb stick/slip switching:
the one time loop of every model.

The time loop of :func:`advance_block` works on one block of ``BLOCK`` lanes. Each pass:

1. evaluates the right-hand side at the state the last step reached (the first RK stage
   of the next step) with every lane's current mode;
2. finds the lanes whose contact mode changed (:mod:`.switching`). With RK4, for a model
   that locates switches, each such lane's last step is redone with the switch located
   inside it (:mod:`.events`); otherwise (the launch, the Euler method, a model that
   does not locate) the mode changes now, at the step start, and forces are evaluated
   again;
3. observes the last step (reversals, slip tally), records, writes out the lanes whose
   run ends, and takes an RK4 (or semi-implicit Euler) step with the modes held; it
   commits each lane unless its new state is non-finite or capsized, or its normal force
   at the start of the step was negative (lift-off: the lane ends with its state there).

Every step-wide task is a vector pass over the lanes that marks the few lanes needing
scalar work, each pass in a row of its own. A lane that stops (status other than ok, at
the end of its own number of steps, or, under the stop rule STOP_AT_REVERSAL of its
parameter row ``stop_rule``, once it has both a first reversal time and a heading
reversal) is written out with its last valid
state at once and then frozen: its time step is set to zero and its state to a harmless
one, so the passes may go on updating it without masks; nothing reads it again. A frozen
lane costs as much as a running one, so a block ends as soon as every lane is written
out (unless it records). All work arrays are made once per block, none in the loop.

The model (:data:`.models.RATTLEBACK` or :data:`.models.PLANAR`) is a literal argument of
every kernel here: each model gets its own compiled copy of this source, with the
model's right-hand side, checks and records from :mod:`.models`. So is the friction
level of the entry points (:data:`.workspace.ROLLING`, ``SLIDING`` or ``COUPLES``): a copy
holds the right-hand side variants up to its level only, and a rolling copy no
switching at all. The levels' dispatch is :mod:`.levels`, the observation of reversals
:mod:`.reversals`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from . import models
from .events import LOCATE_ROWS, located
from .jit import allocating_kernel, kernel
from .levels import evaluate_state, rk4_step, switch_modes
from .lyapunov import HALF, exponent, renormalise, tracked
from .reversals import note_reversals, observe
from .stages import set_step_fractions
from .switching import any_slipping, note_slip, pass_step
from .workspace import (
    at,
    BLOCK,
    CAPSIZED,
    COUPLES,
    DT,
    ENDS_AS_IS,
    EPS_U,
    H_HALF_DT,
    H_SIXTH_DT,
    K_BAND,
    K_FIRST_REV,
    K_HEAD_EXT_X,
    K_HEAD_EXT_Y,
    K_HEAD_SENSE,
    K_MARK_END,
    K_N_REV,
    K_OPEN,
    K_PENDING,
    K_RUN,
    K_SIDE,
    K_SLIP_STEPS,
    K_SPIN_PREV,
    K_STOP,
    K_T_CROSS,
    K_WATCH_LOW,
    K_WIN0,
    K_WIN_CNT,
    K_WIN_SUM,
    LIFTED_OFF,
    LYAP_STEPS,
    MU_ROLL,
    MU_S,
    MU_SPIN,
    NON_FINITE,
    NOT_MARKED,
    OFF_H,
    OFF_K,
    OFF_P,
    OFF_S,
    OFF_X,
    OK,
    O_E0,
    O_E_END,
    O_FINAL_SPIN,
    O_FIRST_REV,
    O_LYAPUNOV,
    O_MEAN_FINAL_SPIN,
    O_N_REV,
    O_SLIP_FRAC,
    O_SPIN0,
    O_STATUS,
    O_STEPS,
    O_T_END,
    RK4,
    ROLLING,
    SLIDING,
    S_JX,
    S_JY,
    S_MODE,
    S_ROLL,
    S_ROLL_SENSE,
    S_SPIN,
    S_SPIN_SENSE,
    S_TSTOP,
    S_UHX,
    X_N,
    X_ROLL_EVENT,
    X_SPIN_EVENT,
    X_UX,
    X_UY,
)

__all__ = [
    "advance_block",
    "contact_slip_velocity",
    "integrate_serial",
    "rolling_derivative",
]


@kernel
def load_lane(W, model, P, Y, j):
    """Copy lane j's parameters P and launch state Y into the workspace and derive what
    the model derives from them; True when the launch state is finite."""
    numba.literally(model)
    off_y = models.state_regions(model)[0]
    for k in range(P.shape[0]):
        W[at(OFF_P, k, j)] = P[k, j]
    finite = True
    for k in range(Y.shape[0]):
        W[at(off_y, k, j)] = Y[k, j]
        finite = finite and math.isfinite(Y[k, j])
    set_step_fractions(W, j)
    models.derive(W, model, j)
    return finite


@kernel
def next_stop(W):
    """The earliest last step of the lanes not yet written out (inf when none)."""
    stop = math.inf
    for j in range(BLOCK):
        if W[at(OFF_K, K_OPEN, j)] > 0.5:
            stop = min(stop, W[at(OFF_K, K_STOP, j)])
    return stop


@kernel
def flag_end(W, step):
    """Mark the lanes whose run ends at this step with how it ends: LIFTED_OFF, as
    :func:`flag_bad_step` finds it, for a stepped lane whose normal force is negative;
    ENDS_AS_IS for a lane at its last step. Scalar: it runs only
    at the steps where some lane's run ends (:func:`next_stop`); at the others a
    lift-off is found by :func:`flag_bad_step`, after the step."""
    for j in range(BLOCK):
        lift = W[at(OFF_K, K_RUN, j)] > 0.5 and W[at(OFF_X, X_N, j)] < 0.0
        last = W[at(OFF_K, K_OPEN, j)] > 0.5 and step >= W[at(OFF_K, K_STOP, j)]
        W[at(OFF_K, K_MARK_END, j)] = (
            float(LIFTED_OFF) if lift else (ENDS_AS_IS if last else NOT_MARKED)
        )


@kernel
def flag_bad_step(W, model):
    """Check every lane's new state (region Y; the model renormalises it where it needs
    to) and mark, with the status it ends with, each stepped lane whose new state is
    not finite or capsized, or whose state at the start of the step had a negative
    normal force: it lifted off there, and the step is undone. (Finding the lift-off
    here rather than before the step saves a pass over the lanes; the lane's result is
    the same.) Returns how many."""
    numba.literally(model)
    n = 0
    for j in range(BLOCK):
        bad_value, capsized = models.check_step(W, model, j)
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        lift = run & (W[at(OFF_X, X_N, j)] < 0.0)  # from the first stage
        bad_value = run & bad_value
        capsized = run & capsized
        W[at(OFF_K, K_MARK_END, j)] = (
            float(LIFTED_OFF)
            if lift
            else (
                float(NON_FINITE)
                if bad_value
                else (float(CAPSIZED) if capsized else NOT_MARKED)
            )
        )
        n += 1 if lift | bad_value | capsized else 0
    return n


@kernel
def finish_lane(W, model, j, P, status, Y, O):
    """Write out lane j's final state Y and observables O: its run has ended."""
    numba.literally(model)
    off_y, _, _, _, n_state, _ = models.state_regions(model)
    for k in range(n_state):
        Y[k, j] = W[at(off_y, k, j)]
    stop = W[at(OFF_K, K_STOP, j)]
    launched = not (status == NON_FINITE and stop == 0)
    O[O_FIRST_REV, j] = W[at(OFF_K, K_FIRST_REV, j)]
    # a first reversal still under way at the end (the spin beyond its band the other
    # way and on that side since, the heading not yet turned back by the band) counts
    O[O_N_REV, j] = W[at(OFF_K, K_N_REV, j)] + W[at(OFF_K, K_PENDING, j)]
    O[O_STATUS, j] = status
    O[O_STEPS, j] = stop
    O[O_T_END, j] = stop * P[DT, j]
    O[O_SLIP_FRAC, j] = W[at(OFF_K, K_SLIP_STEPS, j)] / stop if stop > 0 else np.nan
    win_cnt = W[at(OFF_K, K_WIN_CNT, j)]
    O[O_MEAN_FINAL_SPIN, j] = (
        W[at(OFF_K, K_WIN_SUM, j)] / win_cnt if win_cnt > 0 else np.nan
    )
    O[O_LYAPUNOV, j] = exponent(W, model, j, stop) if launched else np.nan
    if launched:
        O[O_FINAL_SPIN, j] = models.spin_and_watch(W, model, j)[0]
        O[O_E_END, j] = models.energy(W, model, j)
        if status == OK and not math.isfinite(O[O_E_END, j]):
            O[O_STATUS, j] = NON_FINITE  # a finite state whose energy overflowed
    else:
        O[O_E0, j] = np.nan
        O[O_FINAL_SPIN, j] = np.nan
        O[O_E_END, j] = np.nan
    models.finish(W, model, j, O, launched)


@kernel
def freeze_lane(W, model, j):
    """Stop stepping lane j: zero time step, a harmless state, sticking. The passes keep
    running over it (RK4 with dt = 0 leaves it where it is) but nothing reads it."""
    numba.literally(model)
    W[at(OFF_K, K_RUN, j)] = 0.0
    W[at(OFF_K, K_OPEN, j)] = 0.0
    W[at(OFF_P, DT, j)] = 0.0
    W[at(OFF_H, H_HALF_DT, j)] = 0.0
    W[at(OFF_H, H_SIXTH_DT, j)] = 0.0
    models.park(W, model, j)
    W[at(OFF_S, S_MODE, j)] = 0.0


@kernel
def end_marked(W, model, P, status, Y, O, step, undo):
    """Write out and freeze every lane marked by :func:`flag_end` or
    :func:`flag_bad_step`, ending it with its marked status (or its own, ENDS_AS_IS);
    ``undo`` restores the state from before this step first."""
    numba.literally(model)
    off_y, _, _, off_b, n_state, _ = models.state_regions(model)
    for j in range(BLOCK):
        mark = W[at(OFF_K, K_MARK_END, j)]
        if mark != NOT_MARKED:
            if mark != ENDS_AS_IS:
                status[j] = int(mark)
                W[at(OFF_K, K_STOP, j)] = step
            if undo:
                for k in range(n_state):  # the last valid state, which the step kept
                    W[at(off_y, k, j)] = W[at(off_b, k, j)]
            finish_lane(W, model, j, P, status[j], Y, O)
            freeze_lane(W, model, j)
            # a shadow (lyapunov.py) is stepped no longer than its lane
            if j < HALF and W[at(OFF_P, LYAP_STEPS, j)] > 0.0:
                if W[at(OFF_K, K_OPEN, j + HALF)] > 0.5:
                    freeze_lane(W, model, j + HALF)


@kernel
def record_block(W, model, step, REC, i_rec, rec):
    """Write every lane's sample of this step into REC[i_rec] (NaN for a lane past its
    last step), and restart the recorded lanes' impulse tallies."""
    numba.literally(model)
    for j in range(BLOCK):
        if step <= W[at(OFF_K, K_STOP, j)]:
            models.record(W, model, j, rec)
            W[at(OFF_S, S_JX, j)] = 0.0  # the next sample gets the impulses after this one
            W[at(OFF_S, S_JY, j)] = 0.0
            for k in range(rec.shape[0]):
                REC[i_rec, k, j] = rec[k]
        else:
            for k in range(rec.shape[0]):
                REC[i_rec, k, j] = np.nan


@allocating_kernel
def advance_block(model, level, P, Y, nsteps, method, record_every, band, O, REC):
    """Integrate one block from t = 0 for nsteps[j] steps of P[DT, j] per lane.

    ``model`` a literal model number; ``level`` a literal friction level, at least the
    one the block's parameters need (:func:`.workspace.friction_level`): the work of
    higher levels is not compiled into its copy; P (n_param, BLOCK) parameters; Y (n_state,
    BLOCK) initial state, overwritten with the final state; nsteps (BLOCK,) int64; method
    RK4 or EULER; REC (n_rec, n_record, BLOCK) receives every ``record_every``-th step (NaN
    after a lane stopped); ``band`` is the spin-reversal hysteresis as a fraction of
    |spin(0)|; O (n_obs, BLOCK) receives the observables.
    """
    numba.literally(model)
    numba.literally(level)
    W = np.zeros(models.state_regions(model)[5] * BLOCK)
    buf = np.empty((LOCATE_ROWS, models.state_regions(model)[4]))
    status = np.zeros(BLOCK, dtype=np.int64)
    rec = np.empty(REC.shape[1])
    n_rec = REC.shape[0]

    # --- initial state: statuses, mode, reference values --------------------------
    max_steps = 0
    couples = False  # some lane has spin or rolling friction
    for j in range(BLOCK):
        if not load_lane(W, model, P, Y, j):
            status[j] = NON_FINITE
        max_steps = max(max_steps, nsteps[j])
        W[at(OFF_S, S_MODE, j)] = 1.0  # any mode: the slip velocity is mode-independent
        W[at(OFF_S, S_UHX, j)] = 1.0
        if status[j] == OK and models.start_lane(W, model, j):
            status[j] = CAPSIZED
        W[at(OFF_K, K_RUN, j)] = 1.0 if status[j] == OK else 0.0
        # a couple slips in the sense of the rate it opposes; at rest it starts stuck
        # (and slips at once where the couple needed exceeds its bound)
        spin_rate, roll_rate = models.couple_rates(W, model, j)
        W[at(OFF_S, S_SPIN, j)] = (
            0.0 if spin_rate == 0.0 and W[at(OFF_P, MU_SPIN, j)] > 0.0 else 1.0
        )
        W[at(OFF_S, S_SPIN_SENSE, j)] = -1.0 if spin_rate < 0.0 else 1.0
        W[at(OFF_S, S_ROLL, j)] = (
            0.0 if roll_rate == 0.0 and W[at(OFF_P, MU_ROLL, j)] > 0.0 else 1.0
        )
        W[at(OFF_S, S_ROLL_SENSE, j)] = -1.0 if roll_rate < 0.0 else 1.0
        couples = couples or (
            W[at(OFF_K, K_RUN, j)] > 0.5
            and (W[at(OFF_P, MU_SPIN, j)] > 0.0 or W[at(OFF_P, MU_ROLL, j)] > 0.0)
        )
        W[at(OFF_K, K_OPEN, j)] = 1.0
        W[at(OFF_K, K_STOP, j)] = nsteps[j] if status[j] == OK else 0
        # the last 10 % of the steps, and at least the last step
        W[at(OFF_K, K_WIN0, j)] = nsteps[j] - max(nsteps[j] // 10, 1)
        W[at(OFF_K, K_T_CROSS, j)] = np.nan
        W[at(OFF_K, K_FIRST_REV, j)] = np.nan
        # no couple switches: only evaluations at the level COUPLES write these
        W[at(OFF_X, X_SPIN_EVENT, j)] = math.inf
        W[at(OFF_X, X_ROLL_EVENT, j)] = math.inf
    evaluate_state(W, model, level, COUPLES if couples else SLIDING, True)
    can_slip = couples  # some lane may slip now or later: its static friction is finite,
    # or it has a couple
    for j in range(BLOCK):
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        if (
            W[at(OFF_P, MU_S, j)] > 0.0
            and math.sqrt(ux * ux + uy * uy) <= W[at(OFF_P, EPS_U, j)]
        ):
            W[at(OFF_S, S_MODE, j)] = 0.0
            models.roll_start(W, model, j)  # a rolling launch: exactly
        else:
            note_slip(W, j)
            W[at(OFF_S, S_TSTOP, j)] = math.inf  # no step before the launch to redo
        O[O_E0, j] = models.energy(W, model, j)
        if status[j] == OK and not math.isfinite(O[O_E0, j]):
            # a finite launch state whose energy overflows (a speed near 1e154 m/s or
            # more): no step of it could be trusted
            status[j] = NON_FINITE
            W[at(OFF_K, K_RUN, j)] = 0.0
            W[at(OFF_K, K_STOP, j)] = 0
        n0, watched = models.spin_and_watch(W, model, j)
        O[O_SPIN0, j] = n0
        W[at(OFF_K, K_BAND, j)] = band * abs(n0)
        W[at(OFF_K, K_SPIN_PREV, j)] = n0
        W[at(OFF_K, K_SIDE, j)] = 1.0 if n0 > 0.0 else (-1.0 if n0 < 0.0 else 0.0)
        # the heading is followed from the launch in the sense of the launch spin
        hx, hy = models.heading(W, model, j)
        W[at(OFF_K, K_HEAD_EXT_X, j)] = hx
        W[at(OFF_K, K_HEAD_EXT_Y, j)] = hy
        W[at(OFF_K, K_HEAD_SENSE, j)] = W[at(OFF_K, K_SIDE, j)]
        W[at(OFF_K, K_WATCH_LOW, j)] = watched
        can_slip = can_slip or (
            W[at(OFF_K, K_RUN, j)] > 0.5
            and (W[at(OFF_P, MU_S, j)] < math.inf or W[at(OFF_S, S_MODE, j)] > 0.5)
        )

    shadowed = tracked(W)  # some lane has a shadow (lyapunov.py)
    if shadowed:
        renormalise(W, model, 0, True)

    # --- time loop ------------------------------------------------------------------
    # Each pass evaluates the state the last step reached (the first stage of the next
    # step), corrects the lanes whose contact mode changed inside the last step, observes
    # the last step, then takes the next one.
    stop = next_stop(W)  # kept up to date whenever a lane is written out
    locating = method == RK4 and located(model)
    for step in range(max_steps + 1):
        slipping = (
            COUPLES if couples else (SLIDING if can_slip and any_slipping(W) else ROLLING)
        )
        recording = n_rec > 0 and step % record_every == 0 and step // record_every < n_rec
        # the friction force and slip velocity are read only by the stick/slip decisions
        # and the record
        evaluate_state(W, model, level, slipping, can_slip or recording)
        slipping = switch_modes(
            W, model, level, buf, couples, can_slip, locating and step > 0, slipping
        )
        if step > 0 and observe(W, model, step - 1) > 0:
            if note_reversals(W, model, step) > 0:
                stop = next_stop(W)
        ending = step >= stop
        if ending:
            flag_end(W, step)
            for j in range(BLOCK):
                if W[at(OFF_K, K_MARK_END, j)] != NOT_MARKED:
                    W[at(OFF_K, K_RUN, j)] = 0.0
        if recording:
            record_block(W, model, step, REC, step // record_every, rec)
        if ending:  # written out only now, so that the record above still shows them
            end_marked(W, model, P, status, Y, O, step, False)
            stop = next_stop(W)
        if step == max_steps or (stop == math.inf and n_rec == 0):
            break  # (a record goes on to max_steps: its later samples are NaN)

        if method == RK4:
            rk4_step(W, model, level, slipping)
        else:
            models.euler_step(W, model)
        if can_slip:
            pass_step(W)
        if flag_bad_step(W, model) > 0:
            end_marked(W, model, P, status, Y, O, step, True)
            stop = next_stop(W)
        if shadowed:
            renormalise(W, model, step + 1, False)
    # every lane ends at or before max_steps and is written out there; this is a guard
    for j in range(BLOCK):
        if W[at(OFF_K, K_OPEN, j)] > 0.5:
            finish_lane(W, model, j, P, status[j], Y, O)


@kernel
def integrate_serial(model, level, P, Y, nsteps, method, record_every, band, O, REC):
    """Integrate all blocks in turn, on the calling thread (the GIL released, so that
    callers spread the blocks of a batch over threads of their own).

    Arrays carry a leading block axis: P (n_blocks, n_param, BLOCK), Y (n_blocks,
    n_state, BLOCK), nsteps (n_blocks, BLOCK), O (n_blocks, n_obs, BLOCK), REC
    (n_blocks, n_rec, n_record, BLOCK).
    """
    numba.literally(model)
    numba.literally(level)
    for b in range(P.shape[0]):
        advance_block(
            model, level, P[b], Y[b], nsteps[b], method, record_every, band, O[b], REC[b]
        )


@allocating_kernel
def contact_slip_velocity(model, P, Y, U):
    """Horizontal velocity (world, m/s) of the material contact point of every lane,
    U (n_blocks, 2, BLOCK).

    The launch code sets G's velocity to −U for rolling: computed with the stepper's own
    arithmetic, a rolling launch starts with u = 0 exactly.
    """
    numba.literally(model)
    W = np.zeros(models.state_regions(model)[5] * BLOCK)
    for b in range(P.shape[0]):
        for j in range(BLOCK):
            load_lane(W, model, P[b], Y[b], j)
        evaluate_state(W, model, ROLLING, ROLLING, True)  # u: the same in every variant
        for j in range(BLOCK):
            U[b, 0, j] = W[at(OFF_X, X_UX, j)]
            U[b, 1, j] = W[at(OFF_X, X_UY, j)]


@allocating_kernel
def rolling_derivative(model, P, Y, D):
    """Time derivative D (n_blocks, n_state, BLOCK) of every lane's state Y in rolling
    contact (every lane sticking), from the kernel's own right-hand side. For checks
    such as the linear-stability Jacobian; the launch velocity must satisfy rolling."""
    numba.literally(model)
    _, _, off_a, _, n_state, n_work = models.state_regions(model)
    W = np.zeros(n_work * BLOCK)  # switching state zero: every lane sticks
    for b in range(P.shape[0]):
        for j in range(BLOCK):
            load_lane(W, model, P[b], Y[b], j)
        evaluate_state(W, model, ROLLING, ROLLING, True)
        for k in range(n_state):
            for j in range(BLOCK):
                D[b, k, j] = W[at(off_a, k, j)]  # the first RK stage leaves d in A
