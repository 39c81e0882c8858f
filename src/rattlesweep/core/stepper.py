"""Fixed-step integration of blocks of trajectories, with Coulomb stick/slip switching.

The time loop of :func:`advance_block` works on one block of ``BLOCK`` lanes:

1. evaluate the right-hand side at the start of the step with every lane's current mode;
2. decide switches, once per step and per lane (MODEL.md section 4):
   slip → stick when the slip velocity reversed over the last step or a decaying slip is
   about to die (|u| < μ_k g dt and smaller than a step earlier), setting u = 0 exactly;
   stick → slip when |F_t| > μ_s N, starting with û = −F_t/|F_t|; forces are evaluated
   again only when some lane switched;
3. record, take an RK4 (or semi-implicit Euler) step with the modes held, and commit
   each lane unless its new state is non-finite or past the rim, or its normal force at
   the start of the step was negative (lift-off: the lane ends with its state there).

Every step-wide task is a vector pass over the lanes that flags the few lanes needing
scalar work (see the passes below). A lane that stops (status other than ok, or at the
end of its own number of steps) is written out with its last valid state at once and
then frozen. All work arrays are made once per block, none in the loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .dynamics import (
    STAGE_2, STAGE_3, STAGE_4, STAGE_FIRST, STAGE_START, derive_parameters, eval_block,
)
from .geometry import energy_terms, plastic_contact_impulse
from .jit import allocating_kernel, kernel, parallel_kernel
from .layout import (
    BLOCK, CAPSIZED, DT, EPS_U, E_HALF_DT, E_SIXTH_DT, FULL, GRAV, K_BAND, K_FIRST_REV, K_FLAG,
    K_MIN_UP, K_N_REV, K_OPEN, K_RUN, K_SIDE, K_SLIP_STEPS, K_SPIN_PREV, K_STOP, K_T_CAND,
    K_T_CROSS, K_WIN0, K_WIN_CNT, K_WIN_SUM, LIFTED_OFF, MU_K, MU_S, NON_FINITE, N_STATE, N_WORK,
    OFF_A, OFF_E, OFF_K, OFF_P, OFF_S, OFF_T, OFF_X, OFF_Y, OK, O_E0, O_E_END, O_FINAL_SPIN,
    O_FIRST_REV, O_MAX_TILT, O_MEAN_FINAL_SPIN, O_N_REV, O_SLIP_FRAC, O_SPIN0, O_STATUS, O_STEPS,
    O_T_END, PX, PY, Q0, Q1, Q2, Q3, R_ENERGY, R_FX, R_FY, R_JX, R_JY, R_N, R_PX, R_PY, R_PZ, R_Q0,
    R_SLIP, R_SPIN, R_TILT, R_UX, R_UY, R_VX, R_VY, R_VZ, R_W0, S_JX, S_JY, S_MODE, S_UHX, S_UHY,
    S_UPREV, S_USX, S_USY, VX, VY, W0, W1, W2, X_FX, X_FY, X_N, X_UX, X_UY,
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
def evaluate_state(W, slip_possible, forces):
    """First RK stage at the step-start state (region Y), with the normal force in
    region X and, when ``forces`` or ``slip_possible``, the friction force and slip
    velocity too. ``slip_possible`` as in :func:`.eval_block`, at run time: False only
    when no lane that is still stepped slips."""
    if slip_possible:
        eval_block(W, True, STAGE_START)
    elif forces:
        eval_block(W, False, STAGE_START)
    else:
        eval_block(W, False, STAGE_FIRST)


@kernel
def reevaluate_state(W, slip_possible):
    """:func:`evaluate_state` with every output, again after the decisions changed a
    mode or a state."""
    evaluate_state(W, slip_possible, True)


@kernel
def rk4_step(W, slip_possible):
    """The three inner stages of classic RK4 (the first ran in :func:`evaluate_state`),
    leaving the new state in region Y and the old one in region A.
    ``slip_possible=False`` (every lane sticks) lets the stages skip slip-only work."""
    if slip_possible:
        eval_block(W, True, STAGE_2)
        eval_block(W, True, STAGE_3)
        eval_block(W, True, STAGE_4)
    else:
        eval_block(W, False, STAGE_2)
        eval_block(W, False, STAGE_3)
        eval_block(W, False, STAGE_4)


@kernel
def euler_step(W):
    """Semi-implicit Euler on region Y, in place, with the derivative in A from the first
    RK stage: velocities first, then positions and orientation with the new velocities.
    Leaves the old state in A, as :func:`rk4_step` does."""
    for j in range(BLOCK):
        dt = W[at(OFF_P, DT, j)]
        h = 0.5 * dt
        q0 = W[at(OFF_Y, Q0, j)]
        q1 = W[at(OFF_Y, Q1, j)]
        q2 = W[at(OFF_Y, Q2, j)]
        q3 = W[at(OFF_Y, Q3, j)]
        w0 = W[at(OFF_Y, W0, j)] + dt * W[at(OFF_A, W0, j)]
        w1 = W[at(OFF_Y, W1, j)] + dt * W[at(OFF_A, W1, j)]
        w2 = W[at(OFF_Y, W2, j)] + dt * W[at(OFF_A, W2, j)]
        vx = W[at(OFF_Y, VX, j)] + dt * W[at(OFF_A, VX, j)]
        vy = W[at(OFF_Y, VY, j)] + dt * W[at(OFF_A, VY, j)]
        px = W[at(OFF_Y, PX, j)] + dt * vx
        py = W[at(OFF_Y, PY, j)] + dt * vy
        for k in range(N_STATE):
            W[at(OFF_A, k, j)] = W[at(OFF_Y, k, j)]
        W[at(OFF_Y, Q0, j)] = q0 - h * (q1 * w0 + q2 * w1 + q3 * w2)
        W[at(OFF_Y, Q1, j)] = q1 + h * (q0 * w0 + q2 * w2 - q3 * w1)
        W[at(OFF_Y, Q2, j)] = q2 + h * (q0 * w1 + q3 * w0 - q1 * w2)
        W[at(OFF_Y, Q3, j)] = q3 + h * (q0 * w2 + q1 * w1 - q2 * w0)
        W[at(OFF_Y, W0, j)] = w0
        W[at(OFF_Y, W1, j)] = w1
        W[at(OFF_Y, W2, j)] = w2
        W[at(OFF_Y, PX, j)] = px
        W[at(OFF_Y, PY, j)] = py
        W[at(OFF_Y, VX, j)] = vx
        W[at(OFF_Y, VY, j)] = vy


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
def flag_end(W, step):
    """Flag the lanes whose run ends at this step: LIFTED_OFF, as :func:`flag_bad_step`
    flags it, for a stepped lane whose normal force is negative; -1.0 for a lane at its
    last step, whose status stays. Scalar: it runs only at the steps where some lane's
    run ends (:func:`next_stop`); at the others a lift-off is found by
    :func:`flag_bad_step`, after the step."""
    for j in range(BLOCK):
        lift = W[at(OFF_K, K_RUN, j)] > 0.5 and W[at(OFF_X, X_N, j)] < 0.0
        last = W[at(OFF_K, K_OPEN, j)] > 0.5 and step >= W[at(OFF_K, K_STOP, j)]
        W[at(OFF_K, K_FLAG, j)] = float(LIFTED_OFF) if lift else (-1.0 if last else 0.0)


@kernel
def next_stop(W):
    """The earliest last step of the lanes not yet written out (inf when none)."""
    stop = math.inf
    for j in range(BLOCK):
        if W[at(OFF_K, K_OPEN, j)] > 0.5:
            stop = min(stop, W[at(OFF_K, K_STOP, j)])
    return stop


# --- once-per-step passes over a block ------------------------------------------------
# Each is one straight loop over the lanes that writes every lane (no stores on only
# some lanes), so it vectorises like the right-hand side. Lanes that need scalar work (a
# mode switch, a status change, a spin reversal) are flagged in row K_FLAG and handled
# afterwards, only when the pass's count of flagged lanes (its return value, an integer
# sum that vectorises with the pass) is not zero. A lane whose run has ended is
# written out at once by :func:`finish_lane` and then frozen (:func:`freeze_lane`): its
# time step is set to zero and its state to a harmless one, so the passes may go on
# updating it without masks; nothing reads it again.


@kernel
def any_slipping(W):
    """True when some lane still being stepped is in slip mode."""
    for j in range(BLOCK):
        if W[at(OFF_K, K_RUN, j)] > 0.5 and W[at(OFF_S, S_MODE, j)] > 0.5:
            return True
    return False


@kernel
def flag_restick(W):
    """Flag the slipping lanes that stick again (MODEL.md section 4): their slip velocity
    reversed over the last step, or a decaying slip would die within the next one
    (|u| < μ_k g dt and smaller than a step earlier). Returns how many."""
    n = 0
    for j in range(BLOCK):
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        reversed_ = ux * W[at(OFF_S, S_USX, j)] + uy * W[at(OFF_S, S_USY, j)] < 0.0
        dying = ((uu < param(W, MU_K, j) * param(W, GRAV, j) * param(W, DT, j))
                 & (uu < W[at(OFF_S, S_UPREV, j)]))
        flag = ((W[at(OFF_K, K_RUN, j)] > 0.5) & (W[at(OFF_S, S_MODE, j)] > 0.5)
                & (param(W, MU_S, j) > 0.0) & (reversed_ | dying))
        W[at(OFF_K, K_FLAG, j)] = 1.0 if flag else 0.0
        n += 1 if flag else 0
    return n


@kernel
def flag_slip_start(W):
    """Flag the sticking lanes whose friction leaves the cone, |F_t| > μ_s N (μ_s
    finite, N ≥ 0); in the same pass the slipping lanes remember this step's slip
    velocity (as :func:`note_slip`). Returns how many lanes it flagged."""
    n = 0
    for j in range(BLOCK):
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        normal = W[at(OFF_X, X_N, j)]
        fx = W[at(OFF_X, X_FX, j)]
        fy = W[at(OFF_X, X_FY, j)]
        mu_s = param(W, MU_S, j)
        flag = (run & (not slipping) & (mu_s < math.inf) & (normal >= 0.0)
                & (math.sqrt(fx * fx + fy * fy) > mu_s * normal))
        W[at(OFF_K, K_FLAG, j)] = 1.0 if flag else 0.0
        n += 1 if flag else 0

        note = run & slipping
        ux = W[at(OFF_X, X_UX, j)]
        uy = W[at(OFF_X, X_UY, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        W[at(OFF_S, S_USX, j)] = ux if note else W[at(OFF_S, S_USX, j)]
        W[at(OFF_S, S_USY, j)] = uy if note else W[at(OFF_S, S_USY, j)]
        W[at(OFF_S, S_UPREV, j)] = uu if note else W[at(OFF_S, S_UPREV, j)]
        turn = note & (uu > param(W, EPS_U, j))
        W[at(OFF_S, S_UHX, j)] = ux / uu if turn else W[at(OFF_S, S_UHX, j)]
        W[at(OFF_S, S_UHY, j)] = uy / uu if turn else W[at(OFF_S, S_UHY, j)]
    return n


@kernel
def flag_bad_step(W):
    """Renormalise the quaternion of the new state (region Y) of every lane and flag,
    with the status it ends with, each stepped lane whose new state is not finite or
    past the rim, or whose state at the start of the step (region A now) had a
    negative normal force: it lifted off there, and the step is undone. (Finding the
    lift-off here rather than before the step saves a pass over the lanes; the lane's
    result is the same.) Returns how many."""
    n = 0
    for j in range(BLOCK):
        q0 = W[at(OFF_Y, Q0, j)]
        q1 = W[at(OFF_Y, Q1, j)]
        q2 = W[at(OFF_Y, Q2, j)]
        q3 = W[at(OFF_Y, Q3, j)]
        # a sum of the state is non-finite when a component is (or, harmlessly, when
        # the finite ones overflow together), and s − s is NaN exactly then: fewer
        # operations than a test per component, in a tree of short dependency chains
        total = (((q0 + q1) + (q2 + q3))
                 + ((W[at(OFF_Y, W0, j)] + W[at(OFF_Y, W1, j)])
                    + (W[at(OFF_Y, W2, j)] + W[at(OFF_Y, PX, j)]))
                 + ((W[at(OFF_Y, PY, j)] + W[at(OFF_Y, VX, j)]) + W[at(OFF_Y, VY, j)]))
        nan_or_inf = total - total
        qn = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q1 *= qn
        q2 *= qn
        W[at(OFF_Y, Q0, j)] = q0 * qn
        W[at(OFF_Y, Q1, j)] = q1
        W[at(OFF_Y, Q2, j)] = q2
        W[at(OFF_Y, Q3, j)] = q3 * qn
        up_z = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
        run = W[at(OFF_K, K_RUN, j)] > 0.5
        lift = run & (W[at(OFF_X, X_N, j)] < 0.0)  # from the first stage, at region A
        bad_value = run & (nan_or_inf != 0.0)
        capsized = run & (param(W, FULL, j) < 0.5) & (up_z <= 0.0)
        W[at(OFF_K, K_FLAG, j)] = (float(LIFTED_OFF) if lift else (
            float(NON_FINITE) if bad_value else (float(CAPSIZED) if capsized else 0.0)))
        n += 1 if lift | bad_value | capsized else 0
    return n


@kernel
def observe(W, step):
    """Update the run observables from the new state Y, and flag the lanes whose spin
    crossed zero (bit 1) or went beyond the reversal band on the other side (bit 2);
    returns how many it flagged. Frozen lanes are updated too: harmless, nothing reads
    them."""
    n = 0
    for j in range(BLOCK):
        # up_vector and spin_of, written out: with the calls LLVM unrolls this loop
        # differently, and the step takes about 2 % longer
        q0 = W[at(OFF_Y, Q0, j)]
        q1 = W[at(OFF_Y, Q1, j)]
        q2 = W[at(OFF_Y, Q2, j)]
        q3 = W[at(OFF_Y, Q3, j)]
        up_z = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
        spin = (W[at(OFF_Y, W0, j)] * (2.0 * (q1 * q3 - q0 * q2))
                + W[at(OFF_Y, W1, j)] * (2.0 * (q2 * q3 + q0 * q1))
                + W[at(OFF_Y, W2, j)] * up_z)
        W[at(OFF_K, K_SLIP_STEPS, j)] += W[at(OFF_S, S_MODE, j)]
        W[at(OFF_K, K_MIN_UP, j)] = min(W[at(OFF_K, K_MIN_UP, j)], up_z)
        window = 1.0 if step >= W[at(OFF_K, K_WIN0, j)] else 0.0
        W[at(OFF_K, K_WIN_SUM, j)] += window * spin
        W[at(OFF_K, K_WIN_CNT, j)] += window
        # a reversal: the spin crossed zero and went beyond the band on the other side;
        # it is reported at the (linearly interpolated) crossing instant
        dt = param(W, DT, j)
        side = W[at(OFF_K, K_SIDE, j)]
        spin_prev = W[at(OFF_K, K_SPIN_PREV, j)]
        W[at(OFF_K, K_T_CAND, j)] = (step + 1) * dt - dt * spin / (spin - spin_prev)
        crossed = (side * spin_prev > 0.0) & (side * spin <= 0.0)
        beyond = side * spin < -W[at(OFF_K, K_BAND, j)]
        W[at(OFF_K, K_FLAG, j)] = (1.0 if crossed else 0.0) + (2.0 if beyond else 0.0)
        n += 1 if crossed | beyond else 0
        W[at(OFF_K, K_SPIN_PREV, j)] = spin
    return n


@kernel
def note_reversal(W, j):
    """Lane j's spin crossed zero and/or went beyond the band (flags from observe)."""
    flag = W[at(OFF_K, K_FLAG, j)]
    if flag == 1.0 or flag == 3.0:
        W[at(OFF_K, K_T_CROSS, j)] = W[at(OFF_K, K_T_CAND, j)]
    if flag >= 2.0:
        W[at(OFF_K, K_N_REV, j)] += 1.0
        if W[at(OFF_K, K_N_REV, j)] == 1.0:
            W[at(OFF_K, K_FIRST_REV, j)] = W[at(OFF_K, K_T_CROSS, j)]
        W[at(OFF_K, K_SIDE, j)] = -W[at(OFF_K, K_SIDE, j)]


@kernel
def finish_lane(W, j, P, status, Y, O):
    """Write out lane j's final state Y and observables O: its run has ended."""
    for k in range(N_STATE):
        Y[k, j] = W[at(OFF_Y, k, j)]
    stop = W[at(OFF_K, K_STOP, j)]
    O[O_FIRST_REV, j] = W[at(OFF_K, K_FIRST_REV, j)]
    O[O_N_REV, j] = W[at(OFF_K, K_N_REV, j)]
    O[O_STATUS, j] = status
    O[O_STEPS, j] = stop
    O[O_T_END, j] = stop * P[DT, j]
    O[O_SLIP_FRAC, j] = W[at(OFF_K, K_SLIP_STEPS, j)] / stop if stop > 0 else np.nan
    win_cnt = W[at(OFF_K, K_WIN_CNT, j)]
    O[O_MEAN_FINAL_SPIN, j] = W[at(OFF_K, K_WIN_SUM, j)] / win_cnt if win_cnt > 0 else np.nan
    if status == NON_FINITE and stop == 0:
        O[O_FINAL_SPIN, j] = np.nan
        O[O_MAX_TILT, j] = np.nan
        O[O_E_END, j] = np.nan
    else:
        O[O_FINAL_SPIN, j] = spin_of(W, OFF_Y, j)
        O[O_MAX_TILT, j] = math.acos(min(1.0, max(-1.0, W[at(OFF_K, K_MIN_UP, j)])))
        O[O_E_END, j] = energy_terms(W, OFF_Y, j)[0]


@kernel
def freeze_lane(W, j):
    """Stop stepping lane j: zero time step, upright at rest, sticking. The passes keep
    running over it (RK4 with dt = 0 leaves it where it is) but nothing reads it."""
    W[at(OFF_K, K_RUN, j)] = 0.0
    W[at(OFF_K, K_OPEN, j)] = 0.0
    W[at(OFF_P, DT, j)] = 0.0
    W[at(OFF_E, E_HALF_DT, j)] = 0.0
    W[at(OFF_E, E_SIXTH_DT, j)] = 0.0
    for k in range(N_STATE):
        W[at(OFF_Y, k, j)] = 0.0
        W[at(OFF_T, k, j)] = 0.0
    W[at(OFF_Y, Q0, j)] = 1.0
    W[at(OFF_T, Q0, j)] = 1.0
    W[at(OFF_S, S_MODE, j)] = 0.0


@allocating_kernel
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
    rec = np.empty(REC.shape[1])
    n_rec = REC.shape[0]

    # --- initial state: statuses, mode, reference values --------------------------
    max_steps = 0
    for j in range(BLOCK):
        if not load_lane(W, P, Y, j, OFF_P, OFF_Y):
            status[j] = NON_FINITE
        derive_parameters(W, j)
        max_steps = max(max_steps, nsteps[j])
        W[at(OFF_S, S_MODE, j)] = 1.0  # any mode: the slip velocity is mode-independent
        W[at(OFF_S, S_UHX, j)] = 1.0
        if status[j] == OK:
            normalise_quaternion(W, OFF_Y, j)
            if param(W, FULL, j) < 0.5 and up_vector(W, OFF_Y, j)[2] <= 0.0:
                status[j] = CAPSIZED
        W[at(OFF_K, K_RUN, j)] = 1.0 if status[j] == OK else 0.0
        W[at(OFF_K, K_OPEN, j)] = 1.0
        W[at(OFF_K, K_STOP, j)] = nsteps[j] if status[j] == OK else 0
        W[at(OFF_K, K_WIN0, j)] = nsteps[j] - nsteps[j] // 10
        W[at(OFF_K, K_T_CROSS, j)] = np.nan
        W[at(OFF_K, K_FIRST_REV, j)] = np.nan
    reevaluate_state(W, True)
    can_slip = False  # some lane may slip now or later: its static friction is finite
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
        W[at(OFF_K, K_BAND, j)] = band * abs(n0)
        W[at(OFF_K, K_SPIN_PREV, j)] = n0
        W[at(OFF_K, K_SIDE, j)] = 1.0 if n0 > 0.0 else (-1.0 if n0 < 0.0 else 0.0)
        W[at(OFF_K, K_MIN_UP, j)] = up_vector(W, OFF_Y, j)[2]
        can_slip = can_slip or (W[at(OFF_K, K_RUN, j)] > 0.5 and (
            param(W, MU_S, j) < math.inf or W[at(OFF_S, S_MODE, j)] > 0.5))

    # --- time loop ------------------------------------------------------------------
    stop = next_stop(W)  # kept up to date whenever a lane is written out
    for step in range(max_steps + 1):
        slipping = can_slip and any_slipping(W)
        recording = n_rec > 0 and step % record_every == 0 and step // record_every < n_rec
        # the friction force and slip velocity are read only by the stick/slip decisions
        # and the record
        evaluate_state(W, slipping, can_slip or recording)
        if slipping:
            if flag_restick(W) > 0:
                for j in range(BLOCK):
                    if W[at(OFF_K, K_FLAG, j)] != 0.0:
                        stick_now(W, j)
                slipping = any_slipping(W)
                reevaluate_state(W, slipping)
        if can_slip:
            if flag_slip_start(W) > 0:
                for j in range(BLOCK):
                    if W[at(OFF_K, K_FLAG, j)] != 0.0:
                        fx = W[at(OFF_X, X_FX, j)]
                        fy = W[at(OFF_X, X_FY, j)]
                        start_slip(W, j, fx, fy, math.sqrt(fx * fx + fy * fy))
                slipping = True
                reevaluate_state(W, True)
        ending = step >= stop
        if ending:
            flag_end(W, step)
            for j in range(BLOCK):
                flag = W[at(OFF_K, K_FLAG, j)]
                if flag == LIFTED_OFF:
                    status[j] = LIFTED_OFF
                    W[at(OFF_K, K_STOP, j)] = step
                if flag != 0.0:
                    W[at(OFF_K, K_RUN, j)] = 0.0

        if recording:
            i_rec = step // record_every
            for j in range(BLOCK):
                if step <= W[at(OFF_K, K_STOP, j)]:
                    record_lane(W, j, rec)
                    for k in range(rec.shape[0]):
                        REC[i_rec, k, j] = rec[k]
                else:
                    for k in range(rec.shape[0]):
                        REC[i_rec, k, j] = np.nan
        if ending:  # written out only now, so that the record above still shows them
            for j in range(BLOCK):
                if W[at(OFF_K, K_FLAG, j)] != 0.0:
                    finish_lane(W, j, P, status[j], Y, O)
                    freeze_lane(W, j)
            stop = next_stop(W)
        if step == max_steps:
            break

        if method == RK4:
            rk4_step(W, slipping)
        else:
            euler_step(W)
        if flag_bad_step(W) > 0:
            for j in range(BLOCK):
                flag = W[at(OFF_K, K_FLAG, j)]
                if flag != 0.0:
                    status[j] = int(flag)
                    W[at(OFF_K, K_STOP, j)] = step
                    for k in range(N_STATE):  # the last valid state, which the step kept
                        W[at(OFF_Y, k, j)] = W[at(OFF_A, k, j)]
                    finish_lane(W, j, P, status[j], Y, O)
                    freeze_lane(W, j)
            stop = next_stop(W)
        if observe(W, step) > 0:
            for j in range(BLOCK):
                if W[at(OFF_K, K_FLAG, j)] != 0.0:
                    note_reversal(W, j)
    # every lane ends at or before max_steps and is written out there; this is a guard
    for j in range(BLOCK):
        if W[at(OFF_K, K_OPEN, j)] > 0.5:
            finish_lane(W, j, P, status[j], Y, O)


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


@allocating_kernel
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
            derive_parameters(W, j)
        reevaluate_state(W, True)
        for j in range(BLOCK):
            U[b, 0, j] = W[at(OFF_X, X_UX, j)]
            U[b, 1, j] = W[at(OFF_X, X_UY, j)]


@allocating_kernel
def rolling_derivative(P, Y, D):
    """Time derivative D (n_blocks, N_STATE, BLOCK) of every lane's state Y in rolling
    contact (every lane sticking), from the kernel's own right-hand side. For checks
    such as the linear-stability Jacobian; the launch velocity must satisfy rolling."""
    W = np.zeros(N_WORK * BLOCK)  # switching state zero: every lane sticks
    for b in range(P.shape[0]):
        for j in range(BLOCK):
            load_lane(W, P[b], Y[b], j, OFF_P, OFF_Y)
            derive_parameters(W, j)
        reevaluate_state(W, False)
        for k in range(N_STATE):
            for j in range(BLOCK):
                D[b, k, j] = W[at(OFF_A, k, j)]  # the first RK stage leaves d in A
