"""Right-hand side of the rattleback with Coulomb stick/slip contact (MODEL.md section 4).

One function, :func:`eval_block`, evaluates the time derivative of every lane of a block
in a few short straight loops over the lanes. The contact mode of each lane (stick or
slip) is an input, held through the stages of a step; stick and slip share one 3×3
solve, with the matrix and right-hand side chosen per lane, so the loops have no data-dependent branches
and LLVM vectorises them across lanes.
"""

from __future__ import annotations

import math

import numba

from ..jit import inline_kernel, kernel
from ..stages import first_stage, put_derivative
from ..switching import stop_time
from ..workspace import (
    BLOCK, EPS_U, GRAV, MU_K, OFF_P, OFF_S, OFF_X, S_MODE, S_UHX, S_UHY, STAGE_FIRST,
    STAGE_START, X_FX, X_FY, X_N, X_TSTOP, X_UX, X_UY, at, lane_range,
)
from .geometry import adjugate_solve, cross
from .layout import (
    A2, ALPHA_X, ALPHA_Y, ALPHA_Z, B2, C2, COM_X, COM_Y, COM_Z, DAMPING, DAMPING_PM, DET,
    INV_QQ, INV_SIGMA, I_XX, I_XY, I_XZ, I_YY, I_YZ, I_ZZ, J_XX, J_XY, J_XZ, J_YY, J_YZ,
    J_ZZ, MASS, NORMAL_PM, OFF_A, OFF_B, OFF_E, OFF_G, OFF_T, OFF_Y, OMEGA_X, OMEGA_Y, OMEGA_Z,
    POS_X, POS_Y, Q0, Q1, Q2, Q3, RHO_X, RHO_Y, RHO_Z, SLIP_X, SLIP_Y, UHAT_X, UHAT_Y, UP_X,
    UP_Y, UP_Z, VEL_X, VEL_Y, WW_X, WW_Y, WW_Z,
)

__all__ = ["derive_parameters", "eval_block"]


@kernel
def derive_parameters(W, j):
    """Fill lane j's derived parameters (region E) from its parameters (region P)."""
    m = W[at(OFF_P, MASS, j)]
    for src, dst in ((I_XX, J_XX), (I_YY, J_YY), (I_ZZ, J_ZZ), (I_XY, J_XY), (I_XZ, J_XZ),
                     (I_YZ, J_YZ), (DAMPING, DAMPING_PM)):
        W[at(OFF_E, dst, j)] = W[at(OFF_P, src, j)] / m


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
    * ``STAGE_2``: A += 2d and T = Y + (h/2) d;
    * ``STAGE_3``: A += 2d and T = Y + h d;
    * ``STAGE_4``: Y = Y + (h/6)(A + d), the new state, in place, and A = the old Y,
      for a lane whose step fails. Forces, which nobody reads in these inner stages,
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
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    elif stage == STAGE_FIRST:
        contact_kinematics(W, slip_possible, OFF_Y, one_lane, lane)
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    else:
        contact_kinematics(W, slip_possible, OFF_T, one_lane, lane)
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
            ux = W[at(OFF_G, SLIP_X, j)]
            uy = W[at(OFF_G, SLIP_Y, j)]
            uu = math.sqrt(ux * ux + uy * uy)
            if uu > W[at(OFF_P, EPS_U, j)]:
                uhx = ux / uu
                uhy = uy / uu
            else:
                uhx = W[at(OFF_S, S_UHX, j)]
                uhy = W[at(OFF_S, S_UHY, j)]
            W[at(OFF_G, UHAT_X, j)] = uhx
            W[at(OFF_G, UHAT_Y, j)] = uhy
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
        # Cramer's rule, without the division: that is left to store_derivative, so that
        # its latency does not lengthen this loop's chain
        x0, x1, x2, det = adjugate_solve(m00, m01, m02, m10, m11, m12, m20, m21, m22,
                                         t0 - gy0 - cvm * w0, t1 - gy1 - cvm * w1,
                                         t2 - gy2 - cvm * w2)
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
