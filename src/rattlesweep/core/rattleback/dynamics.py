"""Right-hand side of the rattleback with Coulomb stick/slip contact (MODEL.md section 4).

One function, :func:`eval_block`, evaluates the time derivative of every lane of a block
in a few short straight loops over the lanes. The contact mode of each lane (stick or
slip) is an input, held through the stages of a step; stick and slip share one 3×3
solve, with the matrix and right-hand side chosen per lane, so the loops have no
data-dependent branches and LLVM vectorises them across lanes. Only the friction
direction of slow slips (:func:`slip_direction`) is scalar work, per slipping lane.
"""

from __future__ import annotations

import math

import numba
from numba import types
from numba.core.errors import TypingError
from numba.extending import overload

from ..jit import OVERLOAD_OPTIONS, inline_kernel, kernel
from ..stages import first_stage, put_derivative
from ..switching import stop_time
from ..workspace import (
    BLOCK, COUPLES, DT, EPS_U, GRAV, MU_K, MU_ROLL, MU_SPIN, OFF_P, OFF_S, OFF_X, ROLLING,
    S_DCX, S_DCY, S_DPX, S_DPY, S_MODE, S_ROLL, S_SPIN, S_SPIN_SENSE, S_TURN, S_UHX, S_UHY,
    STAGE_FIRST, STAGE_START,
    X_DCX, X_DCY, X_FX, X_FY, X_N, X_ROLL_COUPLE, X_ROLL_EVENT, X_SPIN_COUPLE, X_SPIN_EVENT, X_TSTOP,
    X_TURN, X_UX, X_UY, at, lane_range,
)
from .geometry import adjugate_solve, cross
from .layout import (
    A2, ALPHA_X, ALPHA_Y, ALPHA_Z, B2, C2, COM_X, COM_Y, COM_Z, DAMPING, DAMPING_PM, DET,
    INV_QQ, INV_SIGMA, I_XX, I_XY, I_XZ, I_YY, I_YZ, I_ZZ, J_XX, J_XY, J_XZ, J_YY, J_YZ,
    J_ZZ, JI_XX, JI_XY, JI_XZ, JI_YY, JI_YZ, JI_ZZ, MASS, NORMAL_PM, OFF_A, OFF_B, OFF_E,
    OFF_G, OFF_T, OFF_Y, OMEGA_X, OMEGA_Y, OMEGA_Z, POS_X, POS_Y, Q0, Q1, Q2, Q3, RHO_X,
    RHO_Y, RHO_Z, ROLL_FRACTION, ROLL_MARGIN, SLIP_KIND, SLIP_X, SLIP_Y, SPIN_LAMBDA,
    SPIN_RATE, UHAT_X, UHAT_Y, UP_X, UP_Y, UP_Z, VEL_X, VEL_Y, WW_X, WW_Y, WW_Z,
)

__all__ = ["derive_parameters", "eval_block"]

FAST_SLIP = 1.0
"""``SLIP_KIND`` of a slipping lane whose friction acts along its slip velocity."""

SLOW_SLIP = 2.0
"""``SLIP_KIND`` of a slip slow enough to be steered (:func:`slip_direction`)."""

CONSISTENT_ITERATIONS = 5
"""Newton iterations for the consistent slip direction, from the one at the last step
start (usually a few hundredths of a radian away; quadratic convergence reaches rounding
in three)."""

NEWTON_TOL = 1e-8
"""The consistent direction's Newton iteration stops after a step (rad) below this: the
error left is of order its square."""

SLOPE_BOUND = 4.0
"""A slip faster than this many times μ g (1 + |ρ|² tr J⁻¹) dt / ``RELAX_STEPS`` is not
steered, without computing d*: the bound exceeds the relaxation's s (μ N times the
contact's response, at most 1 + |ρ|² tr J⁻¹ per unit mass) with a margin for N > m g."""

RELAX_STEPS = 2.0
"""A slip whose direction relaxes within fewer than ``1 / RELAX_STEPS`` steps is steered
(:func:`slip_direction`): its relaxation is slowed to this many per step, inside the
interval (−2.79, 0) of the real axis on which classic RK4 is stable."""


@kernel
def derive_parameters(W, j):
    """Fill lane j's derived parameters (region E) from its parameters (region P)."""
    m = W[at(OFF_P, MASS, j)]
    for src, dst in ((I_XX, J_XX), (I_YY, J_YY), (I_ZZ, J_ZZ), (I_XY, J_XY), (I_XZ, J_XZ),
                     (I_YZ, J_YZ), (DAMPING, DAMPING_PM)):
        W[at(OFF_E, dst, j)] = W[at(OFF_P, src, j)] / m
    a = W[at(OFF_E, J_XX, j)]
    b = W[at(OFF_E, J_YY, j)]
    c = W[at(OFF_E, J_ZZ, j)]
    d = W[at(OFF_E, J_XY, j)]
    e = W[at(OFF_E, J_XZ, j)]
    f = W[at(OFF_E, J_YZ, j)]
    cxx = b * c - f * f
    cxy = e * f - d * c
    cxz = d * f - b * e
    inv = 1.0 / (a * cxx + d * cxy + e * cxz)
    W[at(OFF_E, JI_XX, j)] = cxx * inv
    W[at(OFF_E, JI_YY, j)] = (a * c - e * e) * inv
    W[at(OFF_E, JI_ZZ, j)] = (a * b - d * d) * inv
    W[at(OFF_E, JI_XY, j)] = cxy * inv
    W[at(OFF_E, JI_XZ, j)] = cxz * inv
    W[at(OFF_E, JI_YZ, j)] = (d * e - a * f) * inv


@kernel
def eval_block(W, slip_possible, stage, one_lane, lane):
    """Time derivative of every lane of a block, plus its contact forces.

    W is the block workspace (see :mod:`.layout`). Reads the parameters (regions P and
    E), the state (region Y in the first stage, the stage state T in the others) and,
    from the switching state (region S), each lane's contact mode and stored slip
    direction. ``stage`` says what becomes of the derivative d, fused with the classic
    RK4 stage arithmetic so that d never goes to memory on its own (Y is the state at
    the start of the step, h the time step):

    * ``STAGE_START``: A = d and T = Y + (h/2) d (but for the position of G, which no
      stage reads: T has none), and the normal force, friction force and slip velocity
      go to region X (the semi-implicit Euler step also starts from A = d);
    * ``STAGE_FIRST``: the same with the normal force as the only output, for steps
      where nothing reads the others;
    * ``STAGE_MID``: A += 2d and T = Y + c d (c = h/2 in the second stage, h in the
      third: :func:`.stages.set_mid_stage`);
    * ``STAGE_4``: Y = Y + (h/6)(A + d), the new state, in place, and B = the old Y,
      for a lane whose step fails or whose contact mode changed inside it. Forces, which nobody reads in these inner stages,
      are not written.

    ``one_lane`` (a literal) restricts the evaluation to lane ``lane``.

    The flags must be literals, so each combination compiles to its own variant;
    ``slip_possible=False`` promises that every lane sticks and drops the slip-only work.
    A lane's derivative is computed by the same operations in every variant, so it does
    not depend on which one ran.

    Stick (material contact point at rest):
        (I + m(|ρ|²𝟙 − ρρᵀ)) ω̇ = −ω × Iω − c_v ω + m ρ × (g n̂ − w)
    Slip (friction −μ_k N û opposite the slip velocity u):
        (I + m k lᵀ) ω̇ = −ω × Iω − c_v ω + N₀ k,  l = ρ × n̂,  k = ρ × (n̂ − μ_k û)
    with w = ω × (ω × ρ + ṡ_P), N₀ = m(g − n̂·w) and, in both modes, N = N₀ − m l·ω̇.
    """
    numba.literally(slip_possible)
    numba.literally(stage)
    numba.literally(one_lane)
    if stage == STAGE_START:
        contact_kinematics(W, True, OFF_Y, one_lane, lane)  # the slip velocity is an output
        if one_lane:
            steer(W, slip_possible, OFF_Y, True, lane, False)
        else:  # once per step: measure φ̇*
            steer(W, slip_possible, OFF_Y, False, lane, True)
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    elif stage == STAGE_FIRST:
        contact_kinematics(W, slip_possible, OFF_Y, one_lane, lane)
        steer(W, slip_possible, OFF_Y, one_lane, lane, False)
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    else:
        contact_kinematics(W, slip_possible, OFF_T, one_lane, lane)
        steer(W, slip_possible, OFF_T, one_lane, lane, False)
        accelerations(W, slip_possible, OFF_T, one_lane, lane)
    if slip_possible or first_stage(stage):
        divide_out(W, True, one_lane, lane)
    else:
        divide_out(W, False, one_lane, lane)  # the normal force, which no lane needs
    store_derivative(W, slip_possible, stage, one_lane, lane)


@kernel
def horizontal_rows(q0, q1, q2, q3):
    """First two rows of R̃ = |q|² R (R: body -> world), the world-horizontal ones."""
    q00 = q0 * q0
    q11 = q1 * q1
    q22 = q2 * q2
    q33 = q3 * q3
    q12 = q1 * q2
    q03 = q0 * q3
    return (
        (q00 + q11) - (q22 + q33), 2.0 * (q12 - q03), 2.0 * (q1 * q3 + q0 * q2),
        2.0 * (q12 + q03), (q00 + q22) - (q11 + q33), 2.0 * (q2 * q3 - q0 * q1),
    )


@kernel
def contact_kinematics(W, slip_velocity, state, one_lane, lane):
    """Phase 1 of :func:`eval_block`: contact point, its rate, w, and the slip velocity.

    The rotation body -> world is R = R̃/|q|² with R̃ quadratic in q (stage quaternions
    are not unit), and the world up-vector in body components n̂ = ũ/|q|², ũ the last
    row of R̃. The contact point s_P = −A n̂/σ, σ = √(n̂ᵀA n̂), A = diag(a², b², c²), and
    its rate ṡ_P = −(A ṅ + s_P (An̂·ṅ)/σ)/σ with ṅ = n̂ × ω (MODEL.md section 3) are
    unchanged when n̂ is replaced by ũ and σ by σ̃ = √(ũᵀAũ) = |q|² σ, so the only
    divisions are 1/|q|² and 1/σ̃, taken together as one. ``slip_velocity`` (a literal)
    asks for the slip velocity too; ``state`` (a literal) is the region of the state.
    """
    numba.literally(slip_velocity)
    numba.literally(state)
    numba.literally(one_lane)
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        q0 = W[at(state, Q0, j)]
        q1 = W[at(state, Q1, j)]
        q2 = W[at(state, Q2, j)]
        q3 = W[at(state, Q3, j)]
        q00 = q0 * q0
        q11 = q1 * q1
        q22 = q2 * q2
        q33 = q3 * q3
        qq = (q00 + q11) + (q22 + q33)
        u0 = 2.0 * (q1 * q3 - q0 * q2)
        u1 = 2.0 * (q2 * q3 + q0 * q1)
        u2 = (q00 + q33) - (q11 + q22)
        sig = math.sqrt(u0 * u0 * W[at(OFF_P, A2, j)] + u1 * u1 * W[at(OFF_P, B2, j)]
                        + u2 * u2 * W[at(OFF_P, C2, j)])
        inv = 1.0 / (qq * sig)
        W[at(OFF_G, UP_X, j)] = u0
        W[at(OFF_G, UP_Y, j)] = u1
        W[at(OFF_G, UP_Z, j)] = u2
        W[at(OFF_G, INV_QQ, j)] = inv * sig  # 1/|q|²
        W[at(OFF_G, INV_SIGMA, j)] = inv * qq  # 1/σ̃
    for j in range(first, stop):
        w0 = W[at(state, OMEGA_X, j)]
        w1 = W[at(state, OMEGA_Y, j)]
        w2 = W[at(state, OMEGA_Z, j)]
        a2 = W[at(OFF_P, A2, j)]
        b2 = W[at(OFF_P, B2, j)]
        c2 = W[at(OFF_P, C2, j)]
        u0 = W[at(OFF_G, UP_X, j)]
        u1 = W[at(OFF_G, UP_Y, j)]
        u2 = W[at(OFF_G, UP_Z, j)]
        inv_s = W[at(OFF_G, INV_SIGMA, j)]
        ai0 = a2 * inv_s  # A/σ̃
        ai1 = b2 * inv_s
        ai2 = c2 * inv_s
        sp0 = -ai0 * u0
        sp1 = -ai1 * u1
        sp2 = -ai2 * u2
        du0, du1, du2 = cross(u0, u1, u2, w0, w1, w2)
        # ṡ_P = −(A u̇ + s_P (Aũ·u̇)/σ̃)/σ̃ with Aũ/σ̃ = −s_P
        f = (sp0 * du0 + sp1 * du1 + sp2 * du2) * inv_s
        ds0 = sp0 * f - ai0 * du0
        ds1 = sp1 * f - ai1 * du1
        ds2 = sp2 * f - ai2 * du2
        r0 = sp0 - W[at(OFF_P, COM_X, j)]
        r1 = sp1 - W[at(OFF_P, COM_Y, j)]
        r2 = sp2 - W[at(OFF_P, COM_Z, j)]
        wr0, wr1, wr2 = cross(w0, w1, w2, r0, r1, r2)
        ww0, ww1, ww2 = cross(w0, w1, w2, wr0 + ds0, wr1 + ds1, wr2 + ds2)
        W[at(OFF_G, RHO_X, j)] = r0
        W[at(OFF_G, RHO_Y, j)] = r1
        W[at(OFF_G, RHO_Z, j)] = r2
        W[at(OFF_G, WW_X, j)] = ww0
        W[at(OFF_G, WW_Y, j)] = ww1
        W[at(OFF_G, WW_Z, j)] = ww2
        if slip_velocity:
            # slip velocity of the material contact point, world horizontal: v_G + R(ω × ρ)
            q0 = W[at(state, Q0, j)]
            q1 = W[at(state, Q1, j)]
            q2 = W[at(state, Q2, j)]
            q3 = W[at(state, Q3, j)]
            inv_q = W[at(OFF_G, INV_QQ, j)]
            e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
            W[at(OFF_G, SLIP_X, j)] = (W[at(state, VEL_X, j)]
                                       + (e00 * wr0 + e01 * wr1 + e02 * wr2) * inv_q)
            W[at(OFF_G, SLIP_Y, j)] = (W[at(state, VEL_Y, j)]
                                       + (e10 * wr0 + e11 * wr1 + e12 * wr2) * inv_q)


@inline_kernel
def consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey):
    """(f, f′, D) of the consistent slip direction's equation at the direction (ex, ey):
    u̇ / N = V(d) = a D(d) + K_hz − μ K_hh d with D = K_zz − μ K_zh · d (a the free
    horizontal acceleration over what the normal force holds up), f = V × d, zero at
    consistency, and f′ its derivative along the angle of d."""
    dd = k_zz - mu * (k_xz * ex + k_yz * ey)
    vx = ax * dd + k_xz - mu * (k_xx * ex + k_xy * ey)
    vy = ay * dd + k_yz - mu * (k_xy * ex + k_yy * ey)
    # derivatives along d⊥ = (−e_y, e_x)
    ddd = -mu * (k_yz * ex - k_xz * ey)
    dvx = ax * ddd - mu * (k_xy * ex - k_xx * ey)
    dvy = ay * ddd - mu * (k_yy * ex - k_xy * ey)
    return vx * ey - vy * ex, (dvx * ey - dvy * ex) + (vx * ex + vy * ey), dd


@kernel
def consistent_direction(W, j, state, mu, gx, gy, dx, dy):
    """The consistent slip direction of lane j at its state, and its normal force.

    With friction −μ N d (d a horizontal unit vector, world), the contact point's
    acceleration is u̇ = A_h + N (K_hz − μ K_hh d), N = −A_z / (K_zz − μ K_zh · d), where
    A is its acceleration without contact force and K (per unit mass, 𝟙 + [ρ]ᵀ J⁻¹ [ρ])
    its response to one, both in the world axes. The consistent direction d* is the one
    along which the slip speed grows or shrinks without turning, u̇ ∥ d*: Newton's method
    on the angle, from the guess (gx, gy), the root taken only within 60° of the slip's
    direction (dx, dy). A slow slip's direction locks onto it on the time scale
    |u| / (μ N k), far below the step (MODEL.md section 4).

    Returns (d*_x, d*_y, s) with s (m/s²) such that u's direction relaxes onto d* at the
    rate s / |u|; s ≤ 0 where d* does not attract it or no consistent slip exists (then
    d* = (dx, dy)).
    """
    q0 = W[at(state, Q0, j)]
    q1 = W[at(state, Q1, j)]
    q2 = W[at(state, Q2, j)]
    q3 = W[at(state, Q3, j)]
    inv_q = W[at(OFF_G, INV_QQ, j)]
    e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
    x0 = e00 * inv_q  # world x, y and up in body components
    x1 = e01 * inv_q
    x2 = e02 * inv_q
    y0 = e10 * inv_q
    y1 = e11 * inv_q
    y2 = e12 * inv_q
    n0 = W[at(OFF_G, UP_X, j)] * inv_q
    n1 = W[at(OFF_G, UP_Y, j)] * inv_q
    n2 = W[at(OFF_G, UP_Z, j)] * inv_q
    r0 = W[at(OFF_G, RHO_X, j)]
    r1 = W[at(OFF_G, RHO_Y, j)]
    r2 = W[at(OFF_G, RHO_Z, j)]
    kxx = W[at(OFF_E, JI_XX, j)]
    kyy = W[at(OFF_E, JI_YY, j)]
    kzz = W[at(OFF_E, JI_ZZ, j)]
    kxy = W[at(OFF_E, JI_XY, j)]
    kxz = W[at(OFF_E, JI_XZ, j)]
    kyz = W[at(OFF_E, JI_YZ, j)]
    px0, px1, px2 = cross(r0, r1, r2, x0, x1, x2)
    py0, py1, py2 = cross(r0, r1, r2, y0, y1, y2)
    pn0, pn1, pn2 = cross(r0, r1, r2, n0, n1, n2)
    jn0 = kxx * pn0 + kxy * pn1 + kxz * pn2
    jn1 = kxy * pn0 + kyy * pn1 + kyz * pn2
    jn2 = kxz * pn0 + kyz * pn1 + kzz * pn2
    jy0 = kxx * py0 + kxy * py1 + kxz * py2
    jy1 = kxy * py0 + kyy * py1 + kyz * py2
    jy2 = kxz * py0 + kyz * py1 + kzz * py2
    k_xx = 1.0 + (px0 * (kxx * px0 + kxy * px1 + kxz * px2)
                  + px1 * (kxy * px0 + kyy * px1 + kyz * px2)
                  + px2 * (kxz * px0 + kyz * px1 + kzz * px2))
    k_yy = 1.0 + (py0 * jy0 + py1 * jy1 + py2 * jy2)
    k_zz = 1.0 + (pn0 * jn0 + pn1 * jn1 + pn2 * jn2)
    k_xy = px0 * jy0 + px1 * jy1 + px2 * jy2
    k_xz = px0 * jn0 + px1 * jn1 + px2 * jn2
    k_yz = py0 * jn0 + py1 * jn1 + py2 * jn2
    # acceleration of the contact point without contact force: −g n̂ + α₀ × ρ + w, with
    # α₀ = J⁻¹(−ω × Jω − (c_v/m) ω)
    w0 = W[at(state, OMEGA_X, j)]
    w1 = W[at(state, OMEGA_Y, j)]
    w2 = W[at(state, OMEGA_Z, j)]
    jxx = W[at(OFF_E, J_XX, j)]
    jyy = W[at(OFF_E, J_YY, j)]
    jzz = W[at(OFF_E, J_ZZ, j)]
    jxy = W[at(OFF_E, J_XY, j)]
    jxz = W[at(OFF_E, J_XZ, j)]
    jyz = W[at(OFF_E, J_YZ, j)]
    cvm = W[at(OFF_E, DAMPING_PM, j)]
    g0, g1, g2 = cross(w0, w1, w2, jxx * w0 + jxy * w1 + jxz * w2,
                       jxy * w0 + jyy * w1 + jyz * w2, jxz * w0 + jyz * w1 + jzz * w2)
    g0 = -g0 - cvm * w0
    g1 = -g1 - cvm * w1
    g2 = -g2 - cvm * w2
    a0, a1, a2 = cross(kxx * g0 + kxy * g1 + kxz * g2, kxy * g0 + kyy * g1 + kyz * g2,
                       kxz * g0 + kyz * g1 + kzz * g2, r0, r1, r2)
    g = W[at(OFF_P, GRAV, j)]
    a0 += W[at(OFF_G, WW_X, j)] - g * n0
    a1 += W[at(OFF_G, WW_Y, j)] - g * n1
    a2 += W[at(OFF_G, WW_Z, j)] - g * n2
    press = -(a0 * n0 + a1 * n1 + a2 * n2)  # −A_z, what the normal force must hold up
    ax = (a0 * x0 + a1 * x1 + a2 * x2) / press
    ay = (a0 * y0 + a1 * y1 + a2 * y2) / press
    ex = gx
    ey = gy
    for _ in range(CONSISTENT_ITERATIONS):
        f, df, _ = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
        # the direction of u turns at a rate ∝ −f: only roots where f rises attract it.
        # Newton towards those; elsewhere the largest step along the turn
        step = -f / df if df > 0.0 else (-0.5 if f > 0.0 else 0.5)
        step = min(max(step, -0.5), 0.5)
        ex, ey = ex - step * ey, ey + step * ex
        norm = 1.0 / math.sqrt(ex * ex + ey * ey)
        ex *= norm
        ey *= norm
        if abs(step) < NEWTON_TOL:  # quadratic convergence: the next step is far smaller
            break
        if ex * dx + ey * dy <= 0.5:  # out of the cone searched: no root taken there
            break
    _, df, dd = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
    nm = press / dd
    # |u| times the rate at which u's direction relaxes onto d*: N f'(φ*) for the angle φ
    # of u, whose rate is −N f(φ) / |u|, m/s²
    slope = nm * df
    found = (press > 0.0) & (dd > 0.0) & (slope > 0.0) & (ex * dx + ey * dy > 0.5)
    if not found:
        return dx, dy, -1.0
    return ex, ey, slope


@inline_kernel
def turn_rate(W, j, x, y, h):
    """Rate (rad/s) at which lane j's consistent slip direction turned over the last step
    (h, s), to (x, y) from the one at the step before's start; 0 where there is none yet
    (a zero vector)."""
    px = W[at(OFF_S, S_DPX, j)]
    py = W[at(OFF_S, S_DPY, j)]
    return math.atan2(px * y - py * x, px * x + py * y) / h


@kernel
def slip_direction(W, state, one_lane, lane, history):
    """Phase between :func:`contact_kinematics` and :func:`accelerations`: the friction
    direction û of every slipping lane, world horizontal, into UHAT.

    A slip whose direction relaxes slowly enough for the step, τ = |u| / s ≥ dt /
    ``RELAX_STEPS`` (:func:`consistent_direction`), uses û = u/|u|. A faster one lies on
    a slow manifold: u's direction trails the consistent direction d* by τ φ̇* (φ̇* the
    rate at which d* turns), and the friction acts along u. There the friction is steered,
    û ∝ w u/|u| + (1 − w) t̂ with t̂ = d* turned back by τ φ̇* and w = ``RELAX_STEPS`` τ /
    dt < 1: on the manifold û is unchanged, and off it u's direction relaxes onto it at
    the rate ``RELAX_STEPS`` / dt, which the step follows. φ̇* is measured over the last
    step: ``history`` (a literal, True for the block's step-start evaluation) measures it
    afresh and puts d* and φ̇* into the contact outputs, which
    :func:`.switching.keep_directions` makes the lane's switching state; the evaluation
    itself writes no switching state.

    A first, branch-free pass gives every lane u/|u| (a sticking lane, or a slip too
    slow to have a direction, keeps its stored one) and sorts the slipping lanes into
    fast and slow ones (``SLIP_KIND``); the scalar work, steering and the history, then
    visits only the lanes that need it. Sticking lanes keep their stored direction; the
    stepper reads it only in slip.
    """
    numba.literally(state)
    numba.literally(one_lane)
    numba.literally(history)
    first, stop = lane_range(one_lane, lane)
    n_slow = 0
    n_slip = 0
    for j in range(first, stop):
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        ux = W[at(OFF_G, SLIP_X, j)]
        uy = W[at(OFF_G, SLIP_Y, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        moving = slipping & (uu > W[at(OFF_P, EPS_U, j)])
        W[at(OFF_G, UHAT_X, j)] = ux / uu if moving else W[at(OFF_S, S_UHX, j)]
        W[at(OFF_G, UHAT_Y, j)] = uy / uu if moving else W[at(OFF_S, S_UHY, j)]
        mu = W[at(OFF_P, MU_K, j)]
        slow = slipping & (mu > 0.0) & (
            RELAX_STEPS * uu < SLOPE_BOUND * mu * W[at(OFF_P, GRAV, j)] * (
                1.0 + (W[at(OFF_G, RHO_X, j)] ** 2 + W[at(OFF_G, RHO_Y, j)] ** 2
                       + W[at(OFF_G, RHO_Z, j)] ** 2)
                * (W[at(OFF_E, JI_XX, j)] + W[at(OFF_E, JI_YY, j)]
                   + W[at(OFF_E, JI_ZZ, j)])) * W[at(OFF_P, DT, j)])
        W[at(OFF_G, SLIP_KIND, j)] = SLOW_SLIP if slow else (FAST_SLIP if slipping else 0.0)
        n_slow += 1 if slow else 0
        n_slip += 1 if slipping else 0
    if n_slow == 0 and not (history and n_slip > 0):
        return
    for j in range(first, stop):
        kind = W[at(OFF_G, SLIP_KIND, j)]
        if kind == 0.0:
            continue
        dx = W[at(OFF_G, UHAT_X, j)]
        dy = W[at(OFF_G, UHAT_Y, j)]
        h = W[at(OFF_P, DT, j)]
        if kind == FAST_SLIP:
            if history:  # its direction stands in for d*
                W[at(OFF_X, X_TURN, j)] = turn_rate(W, j, dx, dy, h)
                W[at(OFF_X, X_DCX, j)] = dx
                W[at(OFF_X, X_DCY, j)] = dy
            continue
        ux = W[at(OFF_G, SLIP_X, j)]
        uy = W[at(OFF_G, SLIP_Y, j)]
        uu = math.sqrt(ux * ux + uy * uy)
        turn = W[at(OFF_S, S_TURN, j)]
        # the guess: the last step start's d* (at this step's start, where the block may
        # be evaluated again, the one before, so that each evaluation solves alike)
        gx = W[at(OFF_S, S_DPX, j)] if history else W[at(OFF_S, S_DCX, j)]
        gy = W[at(OFF_S, S_DPY, j)] if history else W[at(OFF_S, S_DCY, j)]
        dx = W[at(OFF_S, S_UHX, j)]
        dy = W[at(OFF_S, S_UHY, j)]
        none = gx * gx + gy * gy < 0.5  # no d* yet: the launch's step
        cx, cy, slope = consistent_direction(
            W, j, state, W[at(OFF_P, MU_K, j)], dx if none else gx, dy if none else gy,
            dx, dy)
        if history:
            turn = turn_rate(W, j, cx, cy, h) if slope > 0.0 else 0.0
            W[at(OFF_X, X_TURN, j)] = turn
            W[at(OFF_X, X_DCX, j)] = cx
            W[at(OFF_X, X_DCY, j)] = cy
        if slope > 0.0 and RELAX_STEPS * uu < slope * h:
            lag = -turn * uu / slope  # the manifold's angle from d*, rad
            lag = min(max(lag, -0.5), 0.5)
            tx = cx - lag * cy
            ty = cy + lag * cx
            scale = RELAX_STEPS / (slope * h)
            bx = scale * ux + (1.0 - scale * uu) * tx
            by = scale * uy + (1.0 - scale * uu) * ty
            bb = math.sqrt(bx * bx + by * by)
            W[at(OFF_G, UHAT_X, j)] = bx / bb if bb > 1e-3 else cx
            W[at(OFF_G, UHAT_Y, j)] = by / bb if bb > 1e-3 else cy


def steer(W, slip_possible, state, one_lane, lane, history):
    """:func:`slip_direction` where lanes may slip (``slip_possible``, a literal, not
    ``ROLLING``); nothing, and nothing compiled, where every lane sticks."""


@overload(steer, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _steer(W, slip_possible, state, one_lane, lane, history):
    if not isinstance(slip_possible, (types.IntegerLiteral, types.BooleanLiteral)):
        raise TypingError("slip_possible must be a literal (numba.literally)")
    if slip_possible.literal_value == ROLLING:
        return lambda W, slip_possible, state, one_lane, lane, history: None
    return lambda W, slip_possible, state, one_lane, lane, history: slip_direction(
        W, state, one_lane, lane, history)


@kernel
def accelerations(W, slip_possible, state, one_lane, lane):
    """Phase 2 of :func:`eval_block`: the angular acceleration, as adj(M) b and det M
    (see :func:`divide_out`).

    Per unit mass, with J = I/m:
    stick: (J + |ρ|²𝟙 − ρρᵀ) ω̇ = −ω × Jω − (c_v/m) ω + ρ × (g n̂ − w);
    slip:  (J + k lᵀ) ω̇ = −ω × Jω − (c_v/m) ω + (N₀/m) k, l = ρ × n̂, k = ρ × (n̂ − μ_k û);
    N₀/m = g − n̂·w. ``state`` (a literal) is the region of the state. The normal force
    N/m = N₀/m − l·ω̇ is left to :func:`divide_out`, which needs ω̇.
    """
    numba.literally(slip_possible)
    numba.literally(state)
    numba.literally(one_lane)
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        w0 = W[at(state, OMEGA_X, j)]
        w1 = W[at(state, OMEGA_Y, j)]
        w2 = W[at(state, OMEGA_Z, j)]
        r0 = W[at(OFF_G, RHO_X, j)]
        r1 = W[at(OFF_G, RHO_Y, j)]
        r2 = W[at(OFF_G, RHO_Z, j)]
        ww0 = W[at(OFF_G, WW_X, j)]
        ww1 = W[at(OFF_G, WW_Y, j)]
        ww2 = W[at(OFF_G, WW_Z, j)]
        u0 = W[at(OFF_G, UP_X, j)]
        u1 = W[at(OFF_G, UP_Y, j)]
        u2 = W[at(OFF_G, UP_Z, j)]
        inv_q = W[at(OFF_G, INV_QQ, j)]
        g = W[at(OFF_P, GRAV, j)]
        jxx = W[at(OFF_E, J_XX, j)]
        jyy = W[at(OFF_E, J_YY, j)]
        jzz = W[at(OFF_E, J_ZZ, j)]
        jxy = W[at(OFF_E, J_XY, j)]
        jxz = W[at(OFF_E, J_XZ, j)]
        jyz = W[at(OFF_E, J_YZ, j)]
        cvm = W[at(OFF_E, DAMPING_PM, j)]

        jw0 = jxx * w0 + jxy * w1 + jxz * w2
        jw1 = jxy * w0 + jyy * w1 + jyz * w2
        jw2 = jxz * w0 + jyz * w1 + jzz * w2
        gy0, gy1, gy2 = cross(w0, w1, w2, jw0, jw1, jw2)
        gq = g * inv_q
        n0 = u0 * inv_q
        n1 = u1 * inv_q
        n2 = u2 * inv_q
        n_free = g - (n0 * ww0 + n1 * ww1 + n2 * ww2)
        l0, l1, l2 = cross(r0, r1, r2, n0, n1, n2)
        p00 = r0 * r0
        p11 = r1 * r1
        p22 = r2 * r2
        m00 = jxx + (p11 + p22)
        m11 = jyy + (p00 + p22)
        m22 = jzz + (p00 + p11)
        m01 = jxy - r0 * r1
        m02 = jxz - r0 * r2
        m12 = jyz - r1 * r2
        m10 = m01
        m20 = m02
        m21 = m12
        t0, t1, t2 = cross(r0, r1, r2, gq * u0 - ww0, gq * u1 - ww1, gq * u2 - ww2)
        if slip_possible:
            slip = W[at(OFF_S, S_MODE, j)] > 0.5
            uhx = W[at(OFF_G, UHAT_X, j)]
            uhy = W[at(OFF_G, UHAT_Y, j)]
            mu = W[at(OFF_P, MU_K, j)] if slip else 0.0  # a stick lane may carry mu = inf
            # û in body components: R̃ᵀ (û_x, û_y, 0) / |q|²
            q0 = W[at(state, Q0, j)]
            q1 = W[at(state, Q1, j)]
            q2 = W[at(state, Q2, j)]
            q3 = W[at(state, Q3, j)]
            e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
            ub0 = (e00 * uhx + e10 * uhy) * inv_q
            ub1 = (e01 * uhx + e11 * uhy) * inv_q
            ub2 = (e02 * uhx + e12 * uhy) * inv_q
            k0, k1, k2 = cross(r0, r1, r2, n0 - mu * ub0, n1 - mu * ub1, n2 - mu * ub2)
            if slip:
                m00 = jxx + k0 * l0
                m01 = jxy + k0 * l1
                m02 = jxz + k0 * l2
                m10 = jxy + k1 * l0
                m11 = jyy + k1 * l1
                m12 = jyz + k1 * l2
                m20 = jxz + k2 * l0
                m21 = jyz + k2 * l1
                m22 = jzz + k2 * l2
                t0 = n_free * k0
                t1 = n_free * k1
                t2 = n_free * k2
        if slip_possible == COUPLES:
            # sliding couples −(N/m) c, with N/m = N₀/m − l·ω̇ as for the friction force:
            # (M − c lᵀ) ω̇ = b − (N₀/m) c
            wn = w0 * n0 + w1 * n1 + w2 * n2
            wh0 = w0 - wn * n0
            wh1 = w1 - wn * n1
            wh2 = w2 - wn * n2
            wh = math.sqrt(wh0 * wh0 + wh1 * wh1 + wh2 * wh2)
            mu_spin = W[at(OFF_P, MU_SPIN, j)]
            mu_roll = W[at(OFF_P, MU_ROLL, j)]
            spin_slips = W[at(OFF_S, S_SPIN, j)] > 0.5
            roll_slips = (W[at(OFF_S, S_ROLL, j)] > 0.5) & (mu_roll > 0.0)
            cs = mu_spin * W[at(OFF_S, S_SPIN_SENSE, j)] if spin_slips else 0.0
            # the rolling couple's direction ω_h/|ω_h| turns faster than the step can follow
            # below |ω_h| ~ μ_roll g tr(J⁻¹) dt: there it is proportional to ω_h
            floor = (mu_roll * g * (W[at(OFF_E, JI_XX, j)] + W[at(OFF_E, JI_YY, j)]
                                    + W[at(OFF_E, JI_ZZ, j)]) * W[at(OFF_P, DT, j)]
                     / RELAX_STEPS)
            cr = mu_roll / max(wh, floor) if roll_slips else 0.0
            c0 = cs * n0 + cr * wh0
            c1 = cs * n1 + cr * wh1
            c2 = cs * n2 + cr * wh2
            m00 -= c0 * l0
            m01 -= c0 * l1
            m02 -= c0 * l2
            m10 -= c1 * l0
            m11 -= c1 * l1
            m12 -= c1 * l2
            m20 -= c2 * l0
            m21 -= c2 * l1
            m22 -= c2 * l2
            t0 -= n_free * c0
            t1 -= n_free * c1
            t2 -= n_free * c2
            W[at(OFF_G, SPIN_RATE, j)] = wn
            W[at(OFF_G, ROLL_FRACTION, j)] = wh / max(wh, floor) if roll_slips else 0.0
        # Cramer's rule, without the division: that is left to store_derivative, so that
        # its latency does not lengthen this loop's chain
        x0, x1, x2, det = adjugate_solve(m00, m01, m02, m10, m11, m12, m20, m21, m22,
                                         t0 - gy0 - cvm * w0, t1 - gy1 - cvm * w1,
                                         t2 - gy2 - cvm * w2)
        if slip_possible == COUPLES:
            # a stuck spin: the couple λ n̂ (per unit mass) that keeps ω̇ · n̂ = 0, with
            # ω̇ = M⁻¹(b + λ n̂)
            y0, y1, y2, _ = adjugate_solve(m00, m01, m02, m10, m11, m12, m20, m21, m22,
                                           n0, n1, n2)
            spin_stuck = (not spin_slips) & (mu_spin > 0.0)
            lam = -(n0 * x0 + n1 * x1 + n2 * x2) / (n0 * y0 + n1 * y1 + n2 * y2)
            lam = lam if spin_stuck else 0.0
            x0 += lam * y0
            x1 += lam * y1
            x2 += lam * y2
            # a stuck roll: a horizontal couple τ_h (per unit mass) keeps ω̇ = a n̂, so that
            # ω_h stays zero: M a n̂ = b' + τ_h, b' the right-hand side without the
            # rolling couple's slip, gives a = n̂·b' / n̂·M n̂ (a = 0 with the spin stuck
            # too). Then N/m = N₀/m (l · n̂ = 0). Whether it holds: |τ_h| ≤ μ_roll N/m.
            # A slipping roll would stick once |ω_h| is below the floor with the couple
            # sticking needs within the bound.
            b0 = t0 - gy0 - cvm * w0 + n_free * cr * wh0
            b1 = t1 - gy1 - cvm * w1 + n_free * cr * wh1
            b2 = t2 - gy2 - cvm * w2 + n_free * cr * wh2
            mn0 = m00 * n0 + m01 * n1 + m02 * n2  # M n̂ is the same for every couple
            mn1 = m10 * n0 + m11 * n1 + m12 * n2
            mn2 = m20 * n0 + m21 * n1 + m22 * n2
            nb = n0 * b0 + n1 * b1 + n2 * b2
            a = 0.0 if spin_stuck else nb / (n0 * mn0 + n1 * mn1 + n2 * mn2)
            tau0 = a * mn0 - b0
            tau1 = a * mn1 - b1
            tau2 = a * mn2 - b2
            tn = n0 * tau0 + n1 * tau1 + n2 * tau2  # the stuck spin's share, if any
            tau0 -= tn * n0
            tau1 -= tn * n1
            tau2 -= tn * n2
            demand = math.sqrt(tau0 * tau0 + tau1 * tau1 + tau2 * tau2)
            bound = mu_roll * n_free
            roll_stuck = (not roll_slips) & (mu_roll > 0.0)
            W[at(OFF_G, ROLL_MARGIN, j)] = (
                bound - demand if roll_stuck else max(wh - floor, demand - bound))
            x0 = a * n0 if roll_stuck else x0
            x1 = a * n1 if roll_stuck else x1
            x2 = a * n2 if roll_stuck else x2
            det = 1.0 if roll_stuck else det
            lam = (-nb if spin_stuck else 0.0) if roll_stuck else lam
            W[at(OFF_G, SPIN_LAMBDA, j)] = lam
        W[at(OFF_G, ALPHA_X, j)] = x0
        W[at(OFF_G, ALPHA_Y, j)] = x1
        W[at(OFF_G, ALPHA_Z, j)] = x2
        W[at(OFF_G, DET, j)] = det


@kernel
def divide_out(W, normal, one_lane, lane):
    """Phase 3 of :func:`eval_block`: finish Cramer's rule, ω̇ = adj(M) b / det M, in
    place, and, if ``normal`` (a literal), the normal force per unit mass,
    N/m = g − n̂·w − l·ω̇ with l = ρ × n̂, into NORMAL_PM.

    Its own loop: the division's latency overlaps across lanes instead of lengthening
    another loop's chain. The normal force is here rather than in
    :func:`accelerations`, whose loop is bound by the multiply pipes and, with it,
    short of registers; this loop has the multiply pipes idle while it waits on the
    divider.
    """
    numba.literally(normal)
    numba.literally(one_lane)
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        inv_det = 1.0 / W[at(OFF_G, DET, j)]
        x0 = W[at(OFF_G, ALPHA_X, j)] * inv_det
        x1 = W[at(OFF_G, ALPHA_Y, j)] * inv_det
        x2 = W[at(OFF_G, ALPHA_Z, j)] * inv_det
        W[at(OFF_G, ALPHA_X, j)] = x0
        W[at(OFF_G, ALPHA_Y, j)] = x1
        W[at(OFF_G, ALPHA_Z, j)] = x2
        if normal:
            inv_q = W[at(OFF_G, INV_QQ, j)]
            n0 = W[at(OFF_G, UP_X, j)] * inv_q
            n1 = W[at(OFF_G, UP_Y, j)] * inv_q
            n2 = W[at(OFF_G, UP_Z, j)] * inv_q
            l0, l1, l2 = cross(W[at(OFF_G, RHO_X, j)], W[at(OFF_G, RHO_Y, j)],
                               W[at(OFF_G, RHO_Z, j)], n0, n1, n2)
            W[at(OFF_G, NORMAL_PM, j)] = (
                (W[at(OFF_P, GRAV, j)]
                 - (n0 * W[at(OFF_G, WW_X, j)] + n1 * W[at(OFF_G, WW_Y, j)]
                    + n2 * W[at(OFF_G, WW_Z, j)]))
                - (l0 * x0 + l1 * x1 + l2 * x2))


@inline_kernel
def friction_lane(W, j, slip_possible, stage, q0, q1, q2, q3):
    """Friction force per unit mass on lane j, world horizontal (m/s²), for
    :func:`store_derivative`, which passes the state's quaternion; writes the outputs
    of region X at STAGE_START and STAGE_FIRST (at STAGE_START with the time until the
    slip stops at its present deceleration, from the slip acceleration u̇). Inlined into the derivative loop,
    which is bound by its loads and stores: the friction's arithmetic fits in beside
    them, and its result never goes to memory."""
    outputs = stage == STAGE_START
    normal_output = outputs or stage == STAGE_FIRST
    nm = W[at(OFF_G, NORMAL_PM, j)]  # N/m, after divide_out
    inv_q = W[at(OFF_G, INV_QQ, j)]
    # stick: F/m = a_G + g n̂ with a_G = −(ω̇ × ρ + w); its world-horizontal part
    e0, e1, e2 = cross(W[at(OFF_G, ALPHA_X, j)], W[at(OFF_G, ALPHA_Y, j)],
                       W[at(OFF_G, ALPHA_Z, j)], W[at(OFF_G, RHO_X, j)],
                       W[at(OFF_G, RHO_Y, j)], W[at(OFF_G, RHO_Z, j)])
    e0 = -(e0 + W[at(OFF_G, WW_X, j)])
    e1 = -(e1 + W[at(OFF_G, WW_Y, j)])
    e2 = -(e2 + W[at(OFF_G, WW_Z, j)])
    e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
    fx = (e00 * e0 + e01 * e1 + e02 * e2) * inv_q
    fy = (e10 * e0 + e11 * e1 + e12 * e2) * inv_q
    # the slip acceleration u̇ is the friction force per unit mass less the force sticking
    # would need (both modes share the kinematics: d/dt R(ω × ρ) = R(ω̇ × ρ + w))
    dux = 0.0
    duy = 0.0
    if slip_possible:
        if W[at(OFF_S, S_MODE, j)] > 0.5:  # slip: F/m = −μ_k (N/m) û
            mu_n = -W[at(OFF_P, MU_K, j)] * nm
            stick_x = fx
            stick_y = fy
            fx = mu_n * W[at(OFF_G, UHAT_X, j)]
            fy = mu_n * W[at(OFF_G, UHAT_Y, j)]
            dux = fx - stick_x
            duy = fy - stick_y
    if normal_output:
        W[at(OFF_X, X_N, j)] = W[at(OFF_P, MASS, j)] * nm
    if outputs:
        m = W[at(OFF_P, MASS, j)]
        W[at(OFF_X, X_FX, j)] = m * fx
        W[at(OFF_X, X_FY, j)] = m * fy
        ux = W[at(OFF_G, SLIP_X, j)]
        uy = W[at(OFF_G, SLIP_Y, j)]
        W[at(OFF_X, X_UX, j)] = ux
        W[at(OFF_X, X_UY, j)] = uy
        W[at(OFF_X, X_TSTOP, j)] = stop_time(ux, uy, dux, duy, W[at(OFF_G, UHAT_X, j)],
                                             W[at(OFF_G, UHAT_Y, j)], W[at(OFF_P, EPS_U, j)])
        if slip_possible == COUPLES:
            mu_spin = W[at(OFF_P, MU_SPIN, j)]
            lam = W[at(OFF_G, SPIN_LAMBDA, j)]
            sense = W[at(OFF_S, S_SPIN_SENSE, j)]
            slips = W[at(OFF_S, S_SPIN, j)] > 0.5
            event = sense * W[at(OFF_G, SPIN_RATE, j)] if slips else mu_spin * nm - abs(lam)
            W[at(OFF_X, X_SPIN_EVENT, j)] = event if mu_spin > 0.0 else math.inf
            W[at(OFF_X, X_SPIN_COUPLE, j)] = m * (-mu_spin * nm * sense if slips else lam)
            mu_roll = W[at(OFF_P, MU_ROLL, j)]
            roll_margin = W[at(OFF_G, ROLL_MARGIN, j)]
            W[at(OFF_X, X_ROLL_EVENT, j)] = roll_margin if mu_roll > 0.0 else math.inf
            # its magnitude: sticking, the bound less the margin
            W[at(OFF_X, X_ROLL_COUPLE, j)] = m * (
                mu_roll * nm * W[at(OFF_G, ROLL_FRACTION, j)]
                if W[at(OFF_S, S_ROLL, j)] > 0.5 else mu_roll * nm - roll_margin)
    return fx, fy


@kernel
def store_derivative(W, slip_possible, stage, one_lane, lane):
    """Phase 4 of :func:`eval_block`: the friction force and the whole derivative, used
    as ``stage`` asks."""
    numba.literally(slip_possible)
    numba.literally(stage)
    numba.literally(one_lane)
    state = OFF_Y if first_stage(stage) else OFF_T
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        q0 = W[at(state, Q0, j)]
        q1 = W[at(state, Q1, j)]
        q2 = W[at(state, Q2, j)]
        q3 = W[at(state, Q3, j)]
        fx, fy = friction_lane(W, j, slip_possible, stage, q0, q1, q2, q3)
        h0 = 0.5 * W[at(state, OMEGA_X, j)]
        h1 = 0.5 * W[at(state, OMEGA_Y, j)]
        h2 = 0.5 * W[at(state, OMEGA_Z, j)]
        put_derivative(W, j, Q0 * BLOCK + j, stage, -(q1 * h0 + q2 * h1 + q3 * h2), True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, Q1 * BLOCK + j, stage, q0 * h0 + q2 * h2 - q3 * h1, True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, Q2 * BLOCK + j, stage, q0 * h1 + q3 * h0 - q1 * h2, True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, Q3 * BLOCK + j, stage, q0 * h2 + q1 * h1 - q2 * h0, True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        # ω̇, after divide_out
        put_derivative(W, j, OMEGA_X * BLOCK + j, stage, W[at(OFF_G, ALPHA_X, j)], True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, OMEGA_Y * BLOCK + j, stage, W[at(OFF_G, ALPHA_Y, j)], True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, OMEGA_Z * BLOCK + j, stage, W[at(OFF_G, ALPHA_Z, j)], True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        # no stage reads the position of G, so no stage state has one
        put_derivative(W, j, POS_X * BLOCK + j, stage, W[at(state, VEL_X, j)], False,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, POS_Y * BLOCK + j, stage, W[at(state, VEL_Y, j)], False,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, VEL_X * BLOCK + j, stage, fx, True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, VEL_Y * BLOCK + j, stage, fy, True,
                       OFF_Y, OFF_T, OFF_A, OFF_B)
