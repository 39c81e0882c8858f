"""Kernel for the planar rocking semi-ellipse (MODEL.md section 8), on the 3-D engine's plan.

The lamina x²/a² + y²/b² ≤ 1, y ≤ 0 (body frame, y up, origin C at the centre of the flat
edge) rocks on the line Y = 0 by the angle θ (counter-clockwise, rad). G lies d below C.
With σ(θ) = √(a² sin²θ + b² cos²θ):

* contact point, body frame from C: (−a² sin θ, −b² cos θ)/σ, on the curved part while
  |θ| < π/2 (its y is −b² cos θ/σ < 0); |θ| reaching π/2 puts the corner of the flat edge
  on the floor: status ``capsized``;
* height of G: h = σ − d cos θ; contact point from G, world: (−h′, −h);
  h′ = (a² − b²) sin θ cos θ/σ + d sin θ and h + h″ = a²b²/σ³ (the radius of curvature
  at the contact point), which is how h″ is evaluated;
* slip velocity of the material contact point u = ẋ_G + θ̇ h (its vertical velocity,
  ẏ_G − θ̇ h′, vanishes because y_G = h(θ)).

Newton (ẍ_G = F/m, m(h′θ̈ + h″θ̇²) = N − m g) and Euler about G (I θ̈ = −h′ N + h F) give

* stick (u ≡ 0): θ̈ = −m h′ (g + (h + h″) θ̇²)/(I + m(h² + h′²)), F = −m(h θ̈ + h′ θ̇²);
* slip (F = −μ_k N s, s = sgn u): with k = h′ + μ_k s h,
  θ̈ = −k N₀/(I + m h′ k), N₀ = m(g + h″ θ̇²);
* in both modes N = N₀ + m h′ θ̈.

When I + m h′ k ≤ 0 in slip (the Painlevé paradox; homogeneous bodies need μ_k above
about 1.1 for it, a small explicit inertia less) no contact force is consistent: N comes
out negative and the lane stops as ``lifted_off``.

Layout, switching and the time loop mirror :mod:`.stepper`: one flat workspace per block
of ``BLOCK`` lanes with compile-time row offsets (so the lane loops vectorise), the mode
decided once per step at the step start and held through the RK stages, lanes frozen at
their last valid state with a status. Switching follows MODEL.md section 4: slip → stick
when u reversed over the step or a decaying slip is about to die (|u| < μ_k g dt and
smaller than a step earlier), through the plastic impulse of :func:`contact_impulse`;
stick → slip when |F| > μ_s N, first in the direction −sgn F.

One planar specialisation: the slip direction s is held through a step with the mode (it
is sgn u at the step start, or −sgn F at a slip onset). In 3-D the direction u/|u| turns
continuously and is re-read at every stage; on a line it only changes when u passes
through zero, which is the reversal event itself. Re-reading it at the stages would flip
the friction inside the step, let RK4 land on an end-of-step u of the old sign (a missed
reversal: chattering instead of sticking), and add energy: measured, per-step rises of
~1e-7 of the energy instead of ~1e-10 (tests/test_planar.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .jit import allocating_kernel, kernel, parallel_kernel
from .layout import BLOCK, CAPSIZED, LIFTED_OFF, NON_FINITE, OK
from .stepper import EULER, RK4, at, load_lane

__all__ = ["EULER", "RK4", "integrate_parallel", "integrate_serial"]

# --- integrated state, rows of Y ---------------------------------------------------
THETA = 0  # rocking angle, rad (counter-clockwise)
RATE = 1  # dθ/dt, rad/s
XG = 2  # horizontal position of G, m
VXG = 3  # horizontal velocity of G, m/s
N_STATE = 4

# --- per-lane parameters, rows of P ----------------------------------------------------
A2 = 0  # a², m²
B2 = 1  # b², m²
AB2 = 2  # a² b², m⁴
DEPTH = 3  # d, depth of G below the flat edge, m
MASS = 4  # kg
INERTIA = 5  # I_G, kg m²
MU_K = 6  # kinetic friction coefficient (may be inf)
MU_S = 7  # static friction coefficient (may be inf)
GRAV = 8  # m/s²
DT = 9  # s
EPS_U = 10  # slip speed below which the stored slip direction is used, m/s
N_PARAM = 11

# --- auxiliary outputs of a right-hand-side evaluation, rows of X --------------------
X_N = 0  # normal force, N
X_F = 1  # horizontal friction force on the body, N
X_U = 2  # slip velocity of the material contact point, m/s
N_AUX = 3

# --- per-lane switching state, rows of S ---------------------------------------------
S_MODE = 0  # 0.0 stick, 1.0 slip
S_DIR = 1  # last known slip direction, ±1
S_U0 = 2  # slip velocity at the start of the current step
S_UPREV = 3  # |u| at the start of the current step (a step earlier, at the next check)
N_SWITCH = 4

# --- the flat per-block workspace (see layout.py for why one array) ------------------
OFF_P = 0
OFF_Y = OFF_P + N_PARAM  # state at the step start
OFF_T = OFF_Y + N_STATE  # stage input
OFF_D = OFF_T + N_STATE  # derivative at the stage input
OFF_A = OFF_D + N_STATE  # RK4 accumulator
OFF_X = OFF_A + N_STATE  # auxiliary outputs
OFF_S = OFF_X + N_AUX  # switching state
N_WORK = OFF_S + N_SWITCH

# --- per-run observables, rows of O --------------------------------------------------
O_E0 = 0  # J
O_E_END = 1  # J
O_SLIP_FRAC = 2
O_STATUS = 3
O_T_END = 4  # s, time reached
O_STEPS = 5
O_MAX_ANGLE = 6  # rad, max |θ|
O_FINAL_ANGLE = 7  # rad
O_FINAL_RATE = 8  # rad/s
N_OBS = 9

# --- recorded time series, rows of the record array -----------------------------------
R_ANGLE = 0
R_RATE = 1
R_XG = 2
R_YG = 3
R_VX = 4
R_VY = 5
R_U = 6
R_N = 7
R_F = 8
R_ENERGY = 9
R_SLIP = 10
N_REC = 11

HALF_PI = 0.5 * math.pi


@kernel
def shape(a2, b2, ab2, d, theta):
    """(h, h′, h + h″) at θ: height of G (m), its derivative (m/rad) and the radius of
    curvature at the contact point (m)."""
    s = math.sin(theta)
    c = math.cos(theta)
    sigma = math.sqrt(a2 * s * s + b2 * c * c)
    h = sigma - d * c
    hp = (a2 - b2) * s * c / sigma + d * s
    return h, hp, ab2 / (sigma * sigma * sigma)


@kernel
def energy(m, inertia, g, h, hp, rate, vx):
    """Mechanical energy (J): translation of G (ẏ_G = h′θ̇), rotation about G, gravity
    with the floor as zero."""
    vy = hp * rate
    return 0.5 * m * (vx * vx + vy * vy) + 0.5 * inertia * rate * rate + m * g * h


@kernel
def contact_impulse(m, inertia, h, hp, u):
    """Changes (Δẋ_G, Δθ̇) of a perfectly plastic impulse that stops the material contact
    point (slip velocity u, m/s).

    A horizontal impulse J at P turns the body by h J about G, and changing θ̇ changes
    ẏ_G = h′θ̇, which takes a normal impulse m h′ Δθ̇ (it does no work: P has no vertical
    velocity). So Δθ̇ = h J/(I + m h′²), Δẋ_G = J/m and Δu = J (1/m + h²/(I + m h′²)),
    giving J = −u/(1/m + h²/(I + m h′²)) and an energy change −u²/(2(1/m + h²/(I + m h′²)))
    that is never positive. (Without the normal impulse, i.e. with I alone, the vertical
    kinetic energy of G would change to first order in J and could grow.)
    """
    eff = inertia + m * hp * hp
    imp = -u / (1.0 / m + h * h / eff)
    return imp / m, h * imp / eff


@kernel
def eval_block(W):
    """Time derivative of every lane at the stage input (region T), with N, F and u
    (region X); reads each lane's mode and held slip direction (region S).

    Stick: θ̈ = −m h′(g + (h + h″)θ̇²)/(I + m(h² + h′²)), F = −m(h θ̈ + h′θ̇²).
    Slip:  θ̈ = −k N₀/(I + m h′ k), k = h′ + μ_k s h, N₀ = m(g + h″θ̇²), F = −μ_k s N.
    Both:  N = N₀ + m h′ θ̈, ẍ_G = F/m.
    """
    for j in range(BLOCK):
        p = OFF_P * BLOCK + j
        y = OFF_T * BLOCK + j
        dd = OFF_D * BLOCK + j
        x = OFF_X * BLOCK + j
        sw = OFF_S * BLOCK + j
        rate = W[y + RATE * BLOCK]
        vx = W[y + VXG * BLOCK]
        m = W[p + MASS * BLOCK]
        inertia = W[p + INERTIA * BLOCK]
        g = W[p + GRAV * BLOCK]
        h, hp, rho = shape(W[p + A2 * BLOCK], W[p + B2 * BLOCK], W[p + AB2 * BLOCK],
                           W[p + DEPTH * BLOCK], W[y + THETA * BLOCK])
        w2 = rate * rate
        u = vx + rate * h
        slip = W[sw + S_MODE * BLOCK] > 0.5
        sgn = W[sw + S_DIR * BLOCK]  # slip direction, held through the step
        mu = W[p + MU_K * BLOCK] if slip else 0.0  # a stick lane may carry mu = inf
        n_free = m * (g + (rho - h) * w2)  # m(g + h″θ̇²)
        if slip:
            k = hp + mu * sgn * h
            alpha = -k * n_free / (inertia + m * hp * k)
        else:
            alpha = -m * hp * (g + rho * w2) / (inertia + m * (h * h + hp * hp))
        normal = n_free + m * hp * alpha
        if slip:
            force = -mu * sgn * normal
        else:
            force = -m * (alpha * h + hp * w2)  # keeps u̇ = ẍ_G + θ̈ h + θ̇² h′ = 0
        W[dd + THETA * BLOCK] = rate
        W[dd + RATE * BLOCK] = alpha
        W[dd + XG * BLOCK] = vx
        W[dd + VXG * BLOCK] = force / m
        W[x + X_N * BLOCK] = normal
        W[x + X_F * BLOCK] = force
        W[x + X_U * BLOCK] = u


@kernel
def evaluate_state(W):
    """Evaluate the right-hand side at the step-start state Y (copied into region T)."""
    for k in range(N_STATE):
        for j in range(BLOCK):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)]
    eval_block(W)


@kernel
def rk4_step(W):
    """Classic RK4 from region Y (derivative at Y already in D) into region T."""
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] = dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + 0.5 * W[at(OFF_P, DT, j)] * dk
    eval_block(W)
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] += 2.0 * dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + 0.5 * W[at(OFF_P, DT, j)] * dk
    eval_block(W)
    for k in range(N_STATE):
        for j in range(BLOCK):
            dk = W[at(OFF_D, k, j)]
            W[at(OFF_A, k, j)] += 2.0 * dk
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + W[at(OFF_P, DT, j)] * dk
    eval_block(W)
    for k in range(N_STATE):
        for j in range(BLOCK):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + W[at(OFF_P, DT, j)] / 6.0 * (
                W[at(OFF_A, k, j)] + W[at(OFF_D, k, j)])


@kernel
def euler_step(W):
    """Semi-implicit Euler from region Y (derivative in D) into region T: velocities
    first, then positions with the new velocities."""
    for j in range(BLOCK):
        dt = W[at(OFF_P, DT, j)]
        for k in (RATE, VXG):
            W[at(OFF_T, k, j)] = W[at(OFF_Y, k, j)] + dt * W[at(OFF_D, k, j)]
        W[at(OFF_T, THETA, j)] = W[at(OFF_Y, THETA, j)] + dt * W[at(OFF_T, RATE, j)]
        W[at(OFF_T, XG, j)] = W[at(OFF_Y, XG, j)] + dt * W[at(OFF_T, VXG, j)]


@kernel
def param(W, row, j):
    return W[at(OFF_P, row, j)]


@kernel
def lane_shape(W, j):
    """(h, h′, h + h″) of lane j at its step-start state."""
    return shape(param(W, A2, j), param(W, B2, j), param(W, AB2, j), param(W, DEPTH, j),
                 W[at(OFF_Y, THETA, j)])


@kernel
def lane_energy(W, j):
    h, hp, _ = lane_shape(W, j)
    return energy(param(W, MASS, j), param(W, INERTIA, j), param(W, GRAV, j), h, hp,
                  W[at(OFF_Y, RATE, j)], W[at(OFF_Y, VXG, j)])


@kernel
def record_lane(W, j, out):
    """Write the recorded quantities of lane j (state region Y) into out (N_REC,)."""
    h, hp, _ = lane_shape(W, j)
    rate = W[at(OFF_Y, RATE, j)]
    out[R_ANGLE] = W[at(OFF_Y, THETA, j)]
    out[R_RATE] = rate
    out[R_XG] = W[at(OFF_Y, XG, j)]
    out[R_YG] = h
    out[R_VX] = W[at(OFF_Y, VXG, j)]
    out[R_VY] = hp * rate
    out[R_U] = W[at(OFF_X, X_U, j)]
    out[R_N] = W[at(OFF_X, X_N, j)]
    out[R_F] = W[at(OFF_X, X_F, j)]
    out[R_ENERGY] = lane_energy(W, j)
    out[R_SLIP] = W[at(OFF_S, S_MODE, j)]


@kernel
def start_slip(W, j, force):
    """Stick → slip from rest, sliding opposite the friction sticking would need."""
    direction = -1.0 if force > 0.0 else 1.0
    W[at(OFF_S, S_MODE, j)] = 1.0
    W[at(OFF_S, S_DIR, j)] = direction
    W[at(OFF_S, S_U0, j)] = direction  # only its sign matters for the reversal test
    W[at(OFF_S, S_UPREV, j)] = 0.0  # an onset slip grows: never "decaying" at once


@kernel
def note_slip(W, j):
    """Remember the slip velocity at the start of this step (and its direction)."""
    u = W[at(OFF_X, X_U, j)]
    W[at(OFF_S, S_U0, j)] = u
    W[at(OFF_S, S_UPREV, j)] = abs(u)
    if abs(u) > param(W, EPS_U, j):
        W[at(OFF_S, S_DIR, j)] = 1.0 if u > 0.0 else -1.0


@kernel
def roll_now(W, j):
    """Start lane j rolling: set ẋ_G so that the contact point is at rest (a launch
    condition, not a collision)."""
    W[at(OFF_S, S_MODE, j)] = 0.0
    W[at(OFF_Y, VXG, j)] -= W[at(OFF_X, X_U, j)]


@kernel
def stick_now(W, j):
    """Slip → stick: a perfectly plastic impulse brings the contact point to rest."""
    W[at(OFF_S, S_MODE, j)] = 0.0
    h, hp, _ = lane_shape(W, j)
    dv, dw = contact_impulse(param(W, MASS, j), param(W, INERTIA, j), h, hp,
                             W[at(OFF_X, X_U, j)])
    W[at(OFF_Y, VXG, j)] += dv
    W[at(OFF_Y, RATE, j)] += dw


@allocating_kernel
def advance_block(P, Y, nsteps, method, record_every, O, REC):
    """Integrate one block from t = 0 for nsteps[j] steps of P[DT, j] per lane.

    P (N_PARAM, BLOCK) parameters; Y (N_STATE, BLOCK) initial state, overwritten with the
    final state; nsteps (BLOCK,) int64 (0 for padding lanes); method RK4 or EULER; REC
    (n_rec, N_REC, BLOCK) receives every ``record_every``-th step (NaN after a lane
    stopped); O (N_OBS, BLOCK) receives the observables.

    A lane launched with |u| ≤ EPS_U (and μ_s > 0) starts rolling with u = 0 exactly;
    any other lane starts slipping in the direction of u.
    """
    W = np.zeros(N_WORK * BLOCK)
    status = np.zeros(BLOCK, dtype=np.int64)
    stop = np.empty(BLOCK, dtype=np.int64)  # last step index with a valid state
    max_angle = np.zeros(BLOCK)
    slip_steps = np.zeros(BLOCK)
    rec = np.empty(REC.shape[1])
    n_rec = REC.shape[0]

    # --- initial state, statuses, mode ----------------------------------------------
    max_steps = 0
    for j in range(BLOCK):
        if not load_lane(W, P, Y, j, OFF_P, OFF_Y):
            status[j] = NON_FINITE
        stop[j] = nsteps[j]
        max_steps = max(max_steps, nsteps[j])
        W[at(OFF_S, S_MODE, j)] = 1.0  # any mode: u does not depend on it
        W[at(OFF_S, S_DIR, j)] = 1.0
        if status[j] == OK and abs(Y[THETA, j]) >= HALF_PI:
            status[j] = CAPSIZED
        if status[j] != OK:
            stop[j] = 0
    evaluate_state(W)
    for j in range(BLOCK):
        if param(W, MU_S, j) > 0.0 and abs(W[at(OFF_X, X_U, j)]) <= param(W, EPS_U, j):
            roll_now(W, j)  # a rolling launch: exactly
        else:
            note_slip(W, j)
        O[O_E0, j] = lane_energy(W, j)
        max_angle[j] = abs(W[at(OFF_Y, THETA, j)])

    # --- time loop ------------------------------------------------------------------
    for step in range(max_steps + 1):
        evaluate_state(W)
        # slip → stick: the slip velocity reversed over the last step, or a decaying
        # slip is about to die (|u| < μ_k g dt and smaller than a step earlier)
        changed = False
        for j in range(BLOCK):
            if status[j] != OK or step > stop[j]:
                continue
            if W[at(OFF_S, S_MODE, j)] > 0.5 and param(W, MU_S, j) > 0.0:
                u = W[at(OFF_X, X_U, j)]
                reversed_ = u * W[at(OFF_S, S_U0, j)] < 0.0
                dying = (abs(u) < param(W, MU_K, j) * param(W, GRAV, j) * param(W, DT, j)
                         and abs(u) < W[at(OFF_S, S_UPREV, j)])
                if reversed_ or dying:
                    stick_now(W, j)
                    changed = True
        if changed:
            evaluate_state(W)
        # stick → slip when the friction sticking needs leaves the cone (checked at
        # once after a re-stick too)
        changed = False
        for j in range(BLOCK):
            if status[j] != OK or step > stop[j]:
                continue
            normal = W[at(OFF_X, X_N, j)]
            if W[at(OFF_S, S_MODE, j)] < 0.5:
                mu_s = param(W, MU_S, j)
                force = W[at(OFF_X, X_F, j)]
                if mu_s < math.inf and normal >= 0.0 and abs(force) > mu_s * normal:
                    start_slip(W, j, force)
                    changed = True
            else:
                note_slip(W, j)
        if changed:
            evaluate_state(W)
        for j in range(BLOCK):
            if status[j] == OK and step <= stop[j] and not W[at(OFF_X, X_N, j)] >= 0.0:
                status[j] = LIFTED_OFF  # N < 0 (or NaN: no consistent contact force)
                stop[j] = step

        if n_rec > 0 and step % record_every == 0 and step // record_every < n_rec:
            i_rec = step // record_every
            for j in range(BLOCK):
                if step <= stop[j]:
                    record_lane(W, j, rec)
                    for k in range(N_REC):
                        REC[i_rec, k, j] = rec[k]
                else:
                    for k in range(N_REC):
                        REC[i_rec, k, j] = np.nan
        if step == max_steps:
            break

        if method == RK4:
            rk4_step(W)
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
            angle = abs(W[at(OFF_T, THETA, j)])
            if angle >= HALF_PI:  # the corner of the flat edge reached the floor
                status[j] = CAPSIZED
                stop[j] = step
                continue
            for k in range(N_STATE):
                W[at(OFF_Y, k, j)] = W[at(OFF_T, k, j)]
            slip_steps[j] += W[at(OFF_S, S_MODE, j)]
            max_angle[j] = max(max_angle[j], angle)

    # --- observables and final state -------------------------------------------------
    for j in range(BLOCK):
        for k in range(N_STATE):
            Y[k, j] = W[at(OFF_Y, k, j)]
        O[O_STATUS, j] = status[j]
        O[O_STEPS, j] = stop[j]
        O[O_T_END, j] = stop[j] * param(W, DT, j)
        O[O_SLIP_FRAC, j] = slip_steps[j] / stop[j] if stop[j] > 0 else np.nan
        if status[j] == NON_FINITE and stop[j] == 0:
            O[O_E0, j] = np.nan
            O[O_E_END, j] = np.nan
            O[O_MAX_ANGLE, j] = np.nan
            O[O_FINAL_ANGLE, j] = np.nan
            O[O_FINAL_RATE, j] = np.nan
        else:
            O[O_E_END, j] = lane_energy(W, j)
            O[O_MAX_ANGLE, j] = max_angle[j]
            O[O_FINAL_ANGLE, j] = W[at(OFF_Y, THETA, j)]
            O[O_FINAL_RATE, j] = W[at(OFF_Y, RATE, j)]


@parallel_kernel
def integrate_parallel(P, Y, nsteps, method, record_every, O, REC):
    """Integrate all blocks, spread over numba's threads (one block per task).

    Arrays carry a leading block axis: P (n_blocks, N_PARAM, BLOCK), Y (n_blocks,
    N_STATE, BLOCK), nsteps (n_blocks, BLOCK), O (n_blocks, N_OBS, BLOCK), REC
    (n_blocks, n_rec, N_REC, BLOCK).
    """
    for b in prange(P.shape[0]):
        advance_block(P[b], Y[b], nsteps[b], method, record_every, O[b], REC[b])


@kernel
def integrate_serial(P, Y, nsteps, method, record_every, O, REC):
    """As :func:`integrate_parallel`, on the calling thread only (the GIL released)."""
    for b in range(P.shape[0]):
        advance_block(P[b], Y[b], nsteps[b], method, record_every, O[b], REC[b])
