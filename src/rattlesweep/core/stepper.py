"""Fixed-step integration of blocks of trajectories, with Coulomb stick/slip switching.

The time loop of :func:`advance_block` works on one block of ``BLOCK`` lanes:

1. evaluate the right-hand side at the start of the step with every lane's current mode;
2. decide switches, once per step and per lane (MODEL.md section 4):
   slip → stick when the slip velocity reversed over the last step or a decaying slip is
   about to die (|u| < μ_k g dt and smaller than a step earlier), setting u = 0 exactly;
   stick → slip when |F_t| > μ_s N, starting with û = −F_t/|F_t|; forces are evaluated
   again only when some lane switched;
3. flag lift-off (N < 0), record, take an RK4 (or semi-implicit Euler) step with the
   modes held, and commit each lane unless its new state is non-finite or past the rim.

A lane that stops (status other than ok, or at the end of its own number of steps)
keeps its last valid state. All work arrays are made once per block, none in the loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .dynamics import eval_block
from .geometry import energy_terms, plastic_contact_impulse
from .jit import kernel, parallel_kernel
from .layout import (
    BLOCK, CAPSIZED, DT, EPS_U, FULL, GRAV, LIFTED_OFF, MU_K, MU_S, N_STATE,
    N_WORK, NON_FINITE, O_E0, O_E_END, O_FINAL_SPIN, O_FIRST_REV, O_MAX_TILT,
    O_MEAN_FINAL_SPIN, O_N_REV, O_SLIP_FRAC, O_SPIN0, O_STATUS, O_STEPS, O_T_END, OFF_A,
    OFF_D, OFF_P, OFF_S, OFF_T, OFF_X, OFF_Y, OK, PX, PY, Q0, Q1, Q2, Q3, R_ENERGY, R_FX,
    R_FY, R_JX, R_JY, R_N, R_PX, R_PY, R_PZ, R_Q0, R_SLIP, R_SPIN, R_TILT, R_UX, R_UY, R_VX,
    R_VY, R_VZ, R_W0, S_JX, S_JY, S_MODE, S_UHX, S_UHY, S_UPREV, S_USX, S_USY, VX, VY, W0, W1,
    W2, X_FX, X_FY, X_N, X_UX, X_UY,
)

RK4 = 0
EULER = 1


@kernel
def at(region, row, j):
    """Index of lane j of a row of a workspace region."""
    return (region + row) * BLOCK + j


@kernel
def load_lane(W, P, Y, j, off_p, off_y):
    """Copy lane j's parameters P (n_param, BLOCK) and state Y (n_state, BLOCK) into the
    workspace regions starting at rows off_p and off_y; True when the state is finite.
    Shared by every kernel's block set-up (the region offsets differ by layout)."""
    for k in range(P.shape[0]):
        W[at(off_p, k, j)] = P[k, j]
    finite = True
    for k in range(Y.shape[0]):
        W[at(off_y, k, j)] = Y[k, j]
        finite = finite and math.isfinite(Y[k, j])
    return finite


@kernel
def up_vector(W, off, j):
    """World up-vector in body components (third row of R) for a unit quaternion."""
    q0 = W[at(off, Q0, j)]
    q1 = W[at(off, Q1, j)]
    q2 = W[at(off, Q2, j)]
    q3 = W[at(off, Q3, j)]
    return (
        2.0 * (q1 * q3 - q0 * q2),
        2.0 * (q2 * q3 + q0 * q1),
        1.0 - 2.0 * (q1 * q1 + q2 * q2),
    )


@kernel
def spin_of(W, off, j):
    """Vertical component of the angular velocity, rad/s."""
    n0, n1, n2 = up_vector(W, off, j)
    return W[at(off, W0, j)] * n0 + W[at(off, W1, j)] * n1 + W[at(off, W2, j)] * n2


@kernel
def normalise_quaternion(W, off, j):
    qn = 1.0 / math.sqrt(W[at(off, Q0, j)] ** 2 + W[at(off, Q1, j)] ** 2
                         + W[at(off, Q2, j)] ** 2 + W[at(off, Q3, j)] ** 2)
    for k in range(4):
        W[at(off, Q0 + k, j)] *= qn


@kernel
def param(W, row, j):
    return W[at(OFF_P, row, j)]


@kernel
def record_lane(W, j, out):
    """Write the recorded quantities of lane j (state region Y) into out (N_REC,), and
    restart lane j's impulse tally."""
    for k in range(4):
        out[R_Q0 + k] = W[at(OFF_Y, Q0 + k, j)]
    for k in range(3):
        out[R_W0 + k] = W[at(OFF_Y, W0 + k, j)]
    e, zg, vz = energy_terms(W, OFF_Y, j)
    out[R_PX] = W[at(OFF_Y, PX, j)]
    out[R_PY] = W[at(OFF_Y, PY, j)]
    out[R_PZ] = zg
    out[R_VX] = W[at(OFF_Y, VX, j)]
    out[R_VY] = W[at(OFF_Y, VY, j)]
    out[R_VZ] = vz
    out[R_SPIN] = spin_of(W, OFF_Y, j)
    n0, n1, n2 = up_vector(W, OFF_Y, j)
    # atan2 keeps full precision at tiny tilts, where 1 - cos(tilt) underflows float64
    out[R_TILT] = math.atan2(math.sqrt(n0 * n0 + n1 * n1), n2)
    out[R_ENERGY] = e
    out[R_N] = W[at(OFF_X, X_N, j)]
    out[R_FX] = W[at(OFF_X, X_FX, j)]
    out[R_FY] = W[at(OFF_X, X_FY, j)]
    out[R_UX] = W[at(OFF_X, X_UX, j)]
    out[R_UY] = W[at(OFF_X, X_UY, j)]
    out[R_SLIP] = W[at(OFF_S, S_MODE, j)]
    out[R_JX] = W[at(OFF_S, S_JX, j)]
    out[R_JY] = W[at(OFF_S, S_JY, j)]
    W[at(OFF_S, S_JX, j)] = 0.0  # the next sample gets the impulses after this one
    W[at(OFF_S, S_JY, j)] = 0.0


@kernel
def evaluate_state(W):
    """Evaluate the right-hand side, with every output, at the step-start state Y
    (copied into region T)."""
    for k in range(N_STATE):
        for j in range(BLOCK):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)]
    eval_block(W, True)


@kernel
def eval_stage(W, slip_possible):
    """eval_block with the run-time flag turned into the literal its variants need."""
    if slip_possible:
        eval_block(W, True)
    else:
        eval_block(W, False)


@kernel
def rk4_step(W, slip_possible):
    """Classic RK4 from region Y (derivative at Y already in D) into region T.
    ``slip_possible=False`` (every lane sticks) lets the stages skip slip-only work."""
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] = dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + 0.5 * W[at(OFF_P, DT, j)] * dk
    eval_stage(W, slip_possible)
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] += 2.0 * dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + 0.5 * W[at(OFF_P, DT, j)] * dk
    eval_stage(W, slip_possible)
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] += 2.0 * dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + W[at(OFF_P, DT, j)] * dk
    eval_stage(W, slip_possible)
    for k in range(N_STATE):
        for j in range(BLOCK):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + W[at(OFF_P, DT, j)] / 6.0 * (
                W[at(OFF_A, k, j)] + W[at(OFF_D, k, j)])


@kernel
def euler_step(W):
    """Semi-implicit Euler from region Y (derivative in D) into region T: velocities
    first, then positions and orientation with the new velocities."""
    for j in range(BLOCK):
        dt = W[at(OFF_P, DT, j)]
        for k in (W0, W1, W2, VX, VY):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + dt * W[at(OFF_D, k, j)]
        h = 0.5 * dt
        q0 = W[at(OFF_Y, Q0, j)]
        q1 = W[at(OFF_Y, Q1, j)]
        q2 = W[at(OFF_Y, Q2, j)]
        q3 = W[at(OFF_Y, Q3, j)]
        w0 = W[at(OFF_T, W0, j)]
        w1 = W[at(OFF_T, W1, j)]
        w2 = W[at(OFF_T, W2, j)]
        W[at(OFF_T, Q0, j)] = q0 - h * (q1 * w0 + q2 * w1 + q3 * w2)
        W[at(OFF_T, Q1, j)] = q1 + h * (q0 * w0 + q2 * w2 - q3 * w1)
        W[at(OFF_T, Q2, j)] = q2 + h * (q0 * w1 + q3 * w0 - q1 * w2)
        W[at(OFF_T, Q3, j)] = q3 + h * (q0 * w2 + q1 * w1 - q2 * w0)
        W[at(OFF_T, PX, j)] = W[at(OFF_Y, PX, j)] + dt * W[at(OFF_T, VX, j)]
        W[at(OFF_T, PY, j)] = W[at(OFF_Y, PY, j)] + dt * W[at(OFF_T, VY, j)]


@kernel
def start_slip(W, j, fx, fy, ft):
    """Stick → slip from rest, sliding opposite the friction sticking would need."""
    ux = -fx / ft
    uy = -fy / ft
    W[at(OFF_S, S_MODE, j)] = 1.0
    W[at(OFF_S, S_UHX, j)] = ux
    W[at(OFF_S, S_UHY, j)] = uy
    W[at(OFF_S, S_USX, j)] = ux  # the slip starts from rest in this direction
    W[at(OFF_S, S_USY, j)] = uy
    W[at(OFF_S, S_UPREV, j)] = 0.0


@kernel
def note_slip(W, j):
    """Remember the slip velocity at the start of this step (and its direction)."""
    ux = W[at(OFF_X, X_UX, j)]
    uy = W[at(OFF_X, X_UY, j)]
    uu = math.sqrt(ux * ux + uy * uy)
    W[at(OFF_S, S_USX, j)] = ux
    W[at(OFF_S, S_USY, j)] = uy
    W[at(OFF_S, S_UPREV, j)] = uu
    if uu > param(W, EPS_U, j):
        W[at(OFF_S, S_UHX, j)] = ux / uu
        W[at(OFF_S, S_UHY, j)] = uy / uu


@kernel
def roll_now(W, j):
    """Start lane j rolling: set G's velocity so the material contact point is at rest
    (a launch condition, not a collision)."""
    W[at(OFF_S, S_MODE, j)] = 0.0
    W[at(OFF_Y, VX, j)] -= W[at(OFF_X, X_UX, j)]
    W[at(OFF_Y, VY, j)] -= W[at(OFF_X, X_UY, j)]


@kernel
def stick_now(W, j):
    """Slip → stick: a plastic contact impulse brings the contact point to rest."""
    W[at(OFF_S, S_MODE, j)] = 0.0
    jx, jy = plastic_contact_impulse(W, OFF_Y, j, W[at(OFF_X, X_UX, j)],
                                     W[at(OFF_X, X_UY, j)])
    # kept for the record: the impulse is friction too, and belongs in momentum balances
    W[at(OFF_S, S_JX, j)] += jx
    W[at(OFF_S, S_JY, j)] += jy


@kernel
def advance_block(P, Y, nsteps, method, record_every, band, O, REC):
    """Integrate one block from t = 0 for nsteps[j] steps of P[DT, j] per lane.

    P (N_PARAM, BLOCK) parameters; Y (N_STATE, BLOCK) initial state, overwritten with
    the final state; nsteps (BLOCK,) int64; method RK4 or EULER; REC (n_rec, N_REC,
    BLOCK) receives every ``record_every``-th step (NaN after a lane stopped); ``band``
    is the spin-reversal hysteresis as a fraction of |n(0)|; O (N_OBS, BLOCK) receives
    the observables.
    """
    W = np.zeros(N_WORK * BLOCK)
    status = np.zeros(BLOCK, dtype=np.int64)
    stop = np.empty(BLOCK, dtype=np.int64)  # last step index with a valid state
    side = np.zeros(BLOCK)  # sign of the spin's current side (0: no reversal tracking)
    t_cross = np.full(BLOCK, np.nan)
    spin_prev = np.empty(BLOCK)
    n_rev = np.zeros(BLOCK)
    first_rev = np.full(BLOCK, np.nan)
    win_sum = np.zeros(BLOCK)
    win_cnt = np.zeros(BLOCK)
    min_up = np.empty(BLOCK)
    slip_steps = np.zeros(BLOCK)
    rec = np.empty(REC.shape[1])
    n_rec = REC.shape[0]

    # --- initial state: statuses, mode, reference values --------------------------
    max_steps = 0
    for j in range(BLOCK):
        if not load_lane(W, P, Y, j, OFF_P, OFF_Y):
            status[j] = NON_FINITE
        stop[j] = nsteps[j]
        max_steps = max(max_steps, nsteps[j])
        W[at(OFF_S, S_MODE, j)] = 1.0  # any mode: the slip velocity is mode-independent
        W[at(OFF_S, S_UHX, j)] = 1.0
        if status[j] == OK:
            normalise_quaternion(W, OFF_Y, j)
            if param(W, FULL, j) < 0.5 and up_vector(W, OFF_Y, j)[2] <= 0.0:
                status[j] = CAPSIZED
        if status[j] != OK:
            stop[j] = 0
    evaluate_state(W)
    for j in range(BLOCK):
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        if param(W, MU_S, j) > 0.0 and math.sqrt(ux * ux + uy * uy) <= param(W, EPS_U, j):
            roll_now(W, j)  # a rolling launch: exactly
        else:
            note_slip(W, j)
        O[O_E0, j] = energy_terms(W, OFF_Y, j)[0]
        n0 = spin_of(W, OFF_Y, j)
        O[O_SPIN0, j] = n0
        spin_prev[j] = n0
        side[j] = 1.0 if n0 > 0.0 else (-1.0 if n0 < 0.0 else 0.0)
        min_up[j] = up_vector(W, OFF_Y, j)[2]

    # --- time loop ------------------------------------------------------------------
    for step in range(max_steps + 1):
        evaluate_state(W)
        changed = False
        for j in range(BLOCK):
            if status[j] != OK or step > stop[j]:
                continue
            if W[at(OFF_S, S_MODE, j)] > 0.5 and param(W, MU_S, j) > 0.0:
                ux = W[at(OFF_X, X_UX, j)]
                uy = W[at(OFF_X, X_UY, j)]
                uu = math.sqrt(ux * ux + uy * uy)
                reversed_ = ux * W[at(OFF_S, S_USX, j)] + uy * W[at(OFF_S, S_USY, j)] < 0.0
                dying = (uu < param(W, MU_K, j) * param(W, GRAV, j) * param(W, DT, j)
                         and uu < W[at(OFF_S, S_UPREV, j)])
                if reversed_ or dying:
                    stick_now(W, j)
                    changed = True
        if changed:
            evaluate_state(W)
        changed = False
        for j in range(BLOCK):
            if status[j] != OK or step > stop[j]:
                continue
            normal = W[at(OFF_X, X_N, j)]
            if W[at(OFF_S, S_MODE, j)] < 0.5:
                mu_s = param(W, MU_S, j)
                if mu_s < math.inf and normal >= 0.0:
                    fx = W[at(OFF_X, X_FX, j)]
                    fy = W[at(OFF_X, X_FY, j)]
                    ft = math.sqrt(fx * fx + fy * fy)
                    if ft > mu_s * normal:
                        start_slip(W, j, fx, fy, ft)
                        changed = True
            else:
                note_slip(W, j)
        if changed:
            evaluate_state(W)
        for j in range(BLOCK):
            if status[j] == OK and step <= stop[j] and W[at(OFF_X, X_N, j)] < 0.0:
                status[j] = LIFTED_OFF
                stop[j] = step

        if n_rec > 0 and step % record_every == 0 and step // record_every < n_rec:
            i_rec = step // record_every
            for j in range(BLOCK):
                if step <= stop[j]:
                    record_lane(W, j, rec)
                    for k in range(rec.shape[0]):
                        REC[i_rec, k, j] = rec[k]
                else:
                    for k in range(rec.shape[0]):
                        REC[i_rec, k, j] = np.nan
        if step == max_steps:
            break

        if method == RK4:
            any_slip = False
            for j in range(BLOCK):
                any_slip = any_slip or W[at(OFF_S, S_MODE, j)] > 0.5
            rk4_step(W, any_slip)
        else:
            euler_step(W)

        # --- commit the new state (region T) lane by lane ---------------------------
        for j in range(BLOCK):
            if status[j] != OK or step >= stop[j]:
                continue
            finite = True
            for k in range(N_STATE):
                if not math.isfinite(W[at(OFF_T, k, j)]):
                    finite = False
            if not finite:
                status[j] = NON_FINITE
                stop[j] = step
                continue
            normalise_quaternion(W, OFF_T, j)
            up_z = up_vector(W, OFF_T, j)[2]
            if param(W, FULL, j) < 0.5 and up_z <= 0.0:
                status[j] = CAPSIZED
                stop[j] = step
                continue
            for k in range(N_STATE):
                W[at(OFF_Y, k, j)] = W[at(OFF_T, k, j)]
            slip_steps[j] += W[at(OFF_S, S_MODE, j)]
            min_up[j] = min(min_up[j], up_z)
            dt = param(W, DT, j)
            t_new = (step + 1) * dt
            spin = spin_of(W, OFF_Y, j)
            if step + 1 > nsteps[j] - nsteps[j] // 10:
                win_sum[j] += spin
                win_cnt[j] += 1.0
            s = side[j]
            if s != 0.0:
                # a reversal: the spin crossed zero and went beyond the band on the other
                # side; it is reported at the (linearly interpolated) crossing instant
                if s * spin_prev[j] > 0.0 and s * spin <= 0.0:
                    t_cross[j] = t_new - dt * spin / (spin - spin_prev[j])
                if s * spin < -band * abs(O[O_SPIN0, j]):
                    n_rev[j] += 1.0
                    if n_rev[j] == 1.0:
                        first_rev[j] = t_cross[j]
                    side[j] = -s
            spin_prev[j] = spin

    # --- observables and final state -------------------------------------------------
    for j in range(BLOCK):
        for k in range(N_STATE):
            Y[k, j] = W[at(OFF_Y, k, j)]
        O[O_FIRST_REV, j] = first_rev[j]
        O[O_N_REV, j] = n_rev[j]
        O[O_STATUS, j] = status[j]
        O[O_STEPS, j] = stop[j]
        O[O_T_END, j] = stop[j] * param(W, DT, j)
        O[O_SLIP_FRAC, j] = slip_steps[j] / stop[j] if stop[j] > 0 else np.nan
        O[O_MEAN_FINAL_SPIN, j] = win_sum[j] / win_cnt[j] if win_cnt[j] > 0 else np.nan
        if status[j] == NON_FINITE and stop[j] == 0:
            O[O_FINAL_SPIN, j] = np.nan
            O[O_MAX_TILT, j] = np.nan
            O[O_E_END, j] = np.nan
        else:
            O[O_FINAL_SPIN, j] = spin_of(W, OFF_Y, j)
            O[O_MAX_TILT, j] = math.acos(min(1.0, max(-1.0, min_up[j])))
            O[O_E_END, j] = energy_terms(W, OFF_Y, j)[0]


@parallel_kernel
def integrate_parallel(P, Y, nsteps, method, record_every, band, O, REC):
    """Integrate all blocks, spread over numba's threads (one block per task).

    Arrays carry a leading block axis: P (n_blocks, N_PARAM, BLOCK), Y (n_blocks,
    N_STATE, BLOCK), nsteps (n_blocks, BLOCK), O (n_blocks, N_OBS, BLOCK), REC
    (n_blocks, n_rec, N_REC, BLOCK).
    """
    for b in prange(P.shape[0]):
        advance_block(P[b], Y[b], nsteps[b], method, record_every, band, O[b], REC[b])


@kernel
def integrate_serial(P, Y, nsteps, method, record_every, band, O, REC):
    """As :func:`integrate_parallel`, on the calling thread only (the GIL released)."""
    for b in range(P.shape[0]):
        advance_block(P[b], Y[b], nsteps[b], method, record_every, band, O[b], REC[b])


@kernel
def contact_slip_velocity(P, Y, U):
    """Horizontal velocity (world, m/s) of the material contact point of every lane,
    U (n_blocks, 2, BLOCK).

    The launch code sets G's velocity to −U for rolling: computed with the stepper's own
    arithmetic, a rolling launch starts with u = 0 exactly.
    """
    W = np.zeros(N_WORK * BLOCK)
    for b in range(P.shape[0]):
        for j in range(BLOCK):
            load_lane(W, P[b], Y[b], j, OFF_P, OFF_Y)
        evaluate_state(W)
        for j in range(BLOCK):
            U[b, 0, j] = W[at(OFF_X, X_UX, j)]
            U[b, 1, j] = W[at(OFF_X, X_UY, j)]


@kernel
def rolling_derivative(P, Y, D):
    """Time derivative D (n_blocks, N_STATE, BLOCK) of every lane's state Y in rolling
    contact (every lane sticking), from the kernel's own right-hand side. For checks
    such as the linear-stability Jacobian; the launch velocity must satisfy rolling."""
    W = np.zeros(N_WORK * BLOCK)  # switching state zero: every lane sticks
    for b in range(P.shape[0]):
        for j in range(BLOCK):
            load_lane(W, P[b], Y[b], j, OFF_P, OFF_T)
        eval_block(W, False)
        for k in range(N_STATE):
            for j in range(BLOCK):
                D[b, k, j] = W[at(OFF_D, k, j)]
