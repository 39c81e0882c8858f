"""Right-hand side of the rattleback with Coulomb stick/slip contact (MODEL.md section 4).

One function, :func:`eval_block`, evaluates the time derivative of every lane of a block
in a few short straight loops over the lanes. The contact mode of each lane (stick or
slip) is an input, held through the stages of a step; stick and slip share one 3×3 solve, with the
matrix and right-hand side chosen per lane, so the loops have no data-dependent branches
and LLVM vectorises them across lanes.
"""

from __future__ import annotations

import math

import numba

from .geometry import adjugate_solve, cross
from .jit import inline_kernel, kernel
from .layout import (
    A2, B2, BLOCK, C2, DAMP, DT, EPS_U, E_CVM, E_HALF_DT, E_JXX, E_JXY, E_JXZ, E_JYY, E_JYZ, E_JZZ,
    E_SIXTH_DT, GRAV, GX, GY, GZ, G_DET, G_INV_Q, G_INV_S, G_N0, G_R0, G_R1, G_R2, G_U0, G_U1, G_U2,
    G_UHX, G_UHY, G_UX, G_UY, G_WW0, G_WW1, G_WW2, G_X0, G_X1, G_X2, IXX, IXY, IXZ, IYY, IYZ, IZZ,
    MASS, MU_K, OFF_A, OFF_E, OFF_G, OFF_P, OFF_S, OFF_T, OFF_X, OFF_Y, PX, PY, Q0, Q1, Q2, Q3,
    S_MODE, S_UHX, S_UHY, VX, VY, W0, W1, W2, X_FX, X_FY, X_N, X_UX, X_UY,
)


STAGE_START = 0
STAGE_FIRST = 1
STAGE_2 = 2
STAGE_3 = 3
STAGE_4 = 4


@kernel
def derive_parameters(W, j):
    """Fill lane j's derived parameters (region E) from its parameters (region P)."""
    m = W[(OFF_P + MASS) * BLOCK + j]
    for src, dst in ((IXX, E_JXX), (IYY, E_JYY), (IZZ, E_JZZ), (IXY, E_JXY), (IXZ, E_JXZ),
                     (IYZ, E_JYZ), (DAMP, E_CVM)):
        W[(OFF_E + dst) * BLOCK + j] = W[(OFF_P + src) * BLOCK + j] / m
    h = W[(OFF_P + DT) * BLOCK + j]
    W[(OFF_E + E_HALF_DT) * BLOCK + j] = 0.5 * h
    W[(OFF_E + E_SIXTH_DT) * BLOCK + j] = h / 6.0


@kernel
def first_stage(stage):
    """True for the stages that evaluate the step-start state, region Y."""
    return stage == STAGE_START or stage == STAGE_FIRST


@kernel
def put_derivative(W, j, row, stage, dk, stage_state):
    """Use lane j's derivative component ``dk``, of state row k, as ``stage`` asks (see
    :func:`eval_block`); ``row`` = k·BLOCK + j, and ``stage_state`` says whether the
    stage state T has row k.

    Called with the row as a number that depends on j, not as the literal k: numba
    compiles a function once per combination of literal arguments, and a literal k
    would make eleven copies of each stage's variant (seconds of compile time). The
    compiled calls are inlined into the lane loop all the same.
    """
    a = OFF_A * BLOCK + row
    t = OFF_T * BLOCK + row
    y = OFF_Y * BLOCK + row
    if first_stage(stage):
        W[a] = dk
        if stage_state:
            W[t] = W[y] + W[(OFF_E + E_HALF_DT) * BLOCK + j] * dk
    elif stage == STAGE_2:
        W[a] += 2.0 * dk
        if stage_state:
            W[t] = W[y] + W[(OFF_E + E_HALF_DT) * BLOCK + j] * dk
    elif stage == STAGE_3:
        W[a] += 2.0 * dk
        if stage_state:
            W[t] = W[y] + W[(OFF_P + DT) * BLOCK + j] * dk
    else:
        y_old = W[y]
        W[y] = y_old + W[(OFF_E + E_SIXTH_DT) * BLOCK + j] * (W[a] + dk)
        W[a] = y_old  # A is free now: it keeps the old state, for a step that fails


@kernel
def eval_block(W, slip_possible, stage):
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

    Both flags must be literals, so each combination compiles to its own variant;
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
    if stage == STAGE_START:
        contact_kinematics(W, True, OFF_Y)  # the slip velocity is an output
        accelerations(W, slip_possible, OFF_Y)
    elif stage == STAGE_FIRST:
        contact_kinematics(W, slip_possible, OFF_Y)
        accelerations(W, slip_possible, OFF_Y)
    else:
        contact_kinematics(W, slip_possible, OFF_T)
        accelerations(W, slip_possible, OFF_T)
    if slip_possible or first_stage(stage):
        divide_out(W, True)
    else:
        divide_out(W, False)  # the normal force, which no lane needs
    store_derivative(W, slip_possible, stage)


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
def contact_kinematics(W, slip_velocity, state):
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
    for j in range(BLOCK):
        y = state * BLOCK + j
        o = OFF_G * BLOCK + j
        p = OFF_P * BLOCK + j
        q0 = W[y + Q0 * BLOCK]
        q1 = W[y + Q1 * BLOCK]
        q2 = W[y + Q2 * BLOCK]
        q3 = W[y + Q3 * BLOCK]
        q00 = q0 * q0
        q11 = q1 * q1
        q22 = q2 * q2
        q33 = q3 * q3
        qq = (q00 + q11) + (q22 + q33)
        u0 = 2.0 * (q1 * q3 - q0 * q2)
        u1 = 2.0 * (q2 * q3 + q0 * q1)
        u2 = (q00 + q33) - (q11 + q22)
        sig = math.sqrt(u0 * u0 * W[p + A2 * BLOCK] + u1 * u1 * W[p + B2 * BLOCK]
                        + u2 * u2 * W[p + C2 * BLOCK])
        inv = 1.0 / (qq * sig)
        W[o + G_U0 * BLOCK] = u0
        W[o + G_U1 * BLOCK] = u1
        W[o + G_U2 * BLOCK] = u2
        W[o + G_INV_Q * BLOCK] = inv * sig  # 1/|q|²
        W[o + G_INV_S * BLOCK] = inv * qq  # 1/σ̃
    for j in range(BLOCK):
        p = OFF_P * BLOCK + j
        y = state * BLOCK + j
        o = OFF_G * BLOCK + j
        w0 = W[y + W0 * BLOCK]
        w1 = W[y + W1 * BLOCK]
        w2 = W[y + W2 * BLOCK]
        a2 = W[p + A2 * BLOCK]
        b2 = W[p + B2 * BLOCK]
        c2 = W[p + C2 * BLOCK]
        u0 = W[o + G_U0 * BLOCK]
        u1 = W[o + G_U1 * BLOCK]
        u2 = W[o + G_U2 * BLOCK]
        inv_s = W[o + G_INV_S * BLOCK]
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
        r0 = sp0 - W[p + GX * BLOCK]
        r1 = sp1 - W[p + GY * BLOCK]
        r2 = sp2 - W[p + GZ * BLOCK]
        wr0, wr1, wr2 = cross(w0, w1, w2, r0, r1, r2)
        ww0, ww1, ww2 = cross(w0, w1, w2, wr0 + ds0, wr1 + ds1, wr2 + ds2)
        W[o + G_R0 * BLOCK] = r0
        W[o + G_R1 * BLOCK] = r1
        W[o + G_R2 * BLOCK] = r2
        W[o + G_WW0 * BLOCK] = ww0
        W[o + G_WW1 * BLOCK] = ww1
        W[o + G_WW2 * BLOCK] = ww2
        if slip_velocity:
            # slip velocity of the material contact point, world horizontal: v_G + R(ω × ρ)
            q0 = W[y + Q0 * BLOCK]
            q1 = W[y + Q1 * BLOCK]
            q2 = W[y + Q2 * BLOCK]
            q3 = W[y + Q3 * BLOCK]
            inv_q = W[o + G_INV_Q * BLOCK]
            e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
            W[o + G_UX * BLOCK] = W[y + VX * BLOCK] + (e00 * wr0 + e01 * wr1 + e02 * wr2) * inv_q
            W[o + G_UY * BLOCK] = W[y + VY * BLOCK] + (e10 * wr0 + e11 * wr1 + e12 * wr2) * inv_q


@kernel
def accelerations(W, slip_possible, state):
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
    for j in range(BLOCK):
        p = OFF_P * BLOCK + j
        e = OFF_E * BLOCK + j
        y = state * BLOCK + j
        o = OFF_G * BLOCK + j
        sw = OFF_S * BLOCK + j
        w0 = W[y + W0 * BLOCK]
        w1 = W[y + W1 * BLOCK]
        w2 = W[y + W2 * BLOCK]
        r0 = W[o + G_R0 * BLOCK]
        r1 = W[o + G_R1 * BLOCK]
        r2 = W[o + G_R2 * BLOCK]
        ww0 = W[o + G_WW0 * BLOCK]
        ww1 = W[o + G_WW1 * BLOCK]
        ww2 = W[o + G_WW2 * BLOCK]
        u0 = W[o + G_U0 * BLOCK]
        u1 = W[o + G_U1 * BLOCK]
        u2 = W[o + G_U2 * BLOCK]
        inv_q = W[o + G_INV_Q * BLOCK]
        g = W[p + GRAV * BLOCK]
        jxx = W[e + E_JXX * BLOCK]
        jyy = W[e + E_JYY * BLOCK]
        jzz = W[e + E_JZZ * BLOCK]
        jxy = W[e + E_JXY * BLOCK]
        jxz = W[e + E_JXZ * BLOCK]
        jyz = W[e + E_JYZ * BLOCK]
        cvm = W[e + E_CVM * BLOCK]

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
            slip = W[sw + S_MODE * BLOCK] > 0.5
            ux = W[o + G_UX * BLOCK]
            uy = W[o + G_UY * BLOCK]
            uu = math.sqrt(ux * ux + uy * uy)
            if uu > W[p + EPS_U * BLOCK]:
                uhx = ux / uu
                uhy = uy / uu
            else:
                uhx = W[sw + S_UHX * BLOCK]
                uhy = W[sw + S_UHY * BLOCK]
            W[o + G_UHX * BLOCK] = uhx
            W[o + G_UHY * BLOCK] = uhy
            mu = W[p + MU_K * BLOCK] if slip else 0.0  # a stick lane may carry mu = inf
            # û in body components: R̃ᵀ (û_x, û_y, 0) / |q|²
            q0 = W[y + Q0 * BLOCK]
            q1 = W[y + Q1 * BLOCK]
            q2 = W[y + Q2 * BLOCK]
            q3 = W[y + Q3 * BLOCK]
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
        W[o + G_X0 * BLOCK] = x0
        W[o + G_X1 * BLOCK] = x1
        W[o + G_X2 * BLOCK] = x2
        W[o + G_DET * BLOCK] = det


@kernel
def divide_out(W, normal):
    """Phase 3 of :func:`eval_block`: finish Cramer's rule, ω̇ = adj(M) b / det M, in
    place, and, if ``normal`` (a literal), the normal force per unit mass,
    N/m = g − n̂·w − l·ω̇ with l = ρ × n̂, into G_N0.

    Its own loop: the division's latency overlaps across lanes instead of lengthening
    another loop's chain. The normal force is here rather than in
    :func:`accelerations`, whose loop is bound by the multiply pipes and, with it,
    short of registers; this loop has the multiply pipes idle while it waits on the
    divider.
    """
    numba.literally(normal)
    for j in range(BLOCK):
        o = OFF_G * BLOCK + j
        inv_det = 1.0 / W[o + G_DET * BLOCK]
        x0 = W[o + G_X0 * BLOCK] * inv_det
        x1 = W[o + G_X1 * BLOCK] * inv_det
        x2 = W[o + G_X2 * BLOCK] * inv_det
        W[o + G_X0 * BLOCK] = x0
        W[o + G_X1 * BLOCK] = x1
        W[o + G_X2 * BLOCK] = x2
        if normal:
            inv_q = W[o + G_INV_Q * BLOCK]
            n0 = W[o + G_U0 * BLOCK] * inv_q
            n1 = W[o + G_U1 * BLOCK] * inv_q
            n2 = W[o + G_U2 * BLOCK] * inv_q
            l0, l1, l2 = cross(W[o + G_R0 * BLOCK], W[o + G_R1 * BLOCK], W[o + G_R2 * BLOCK],
                               n0, n1, n2)
            W[o + G_N0 * BLOCK] = (
                (W[(OFF_P + GRAV) * BLOCK + j]
                 - (n0 * W[o + G_WW0 * BLOCK] + n1 * W[o + G_WW1 * BLOCK]
                    + n2 * W[o + G_WW2 * BLOCK]))
                - (l0 * x0 + l1 * x1 + l2 * x2))


@inline_kernel
def friction_lane(W, j, slip_possible, stage, q0, q1, q2, q3):
    """Friction force per unit mass on lane j, world horizontal (m/s²), for
    :func:`store_derivative`, which passes the state's quaternion; writes the outputs
    of region X at STAGE_START and STAGE_FIRST. Inlined into the derivative loop,
    which is bound by its loads and stores: the friction's arithmetic fits in beside
    them, and its result never goes to memory."""
    outputs = stage == STAGE_START
    normal_output = outputs or stage == STAGE_FIRST
    p = OFF_P * BLOCK + j
    o = OFF_G * BLOCK + j
    x = OFF_X * BLOCK + j
    nm = W[o + G_N0 * BLOCK]  # N/m, after divide_out
    inv_q = W[o + G_INV_Q * BLOCK]
    # stick: F/m = a_G + g n̂ with a_G = −(ω̇ × ρ + w); its world-horizontal part
    e0, e1, e2 = cross(W[o + G_X0 * BLOCK], W[o + G_X1 * BLOCK], W[o + G_X2 * BLOCK],
                       W[o + G_R0 * BLOCK], W[o + G_R1 * BLOCK], W[o + G_R2 * BLOCK])
    e0 = -(e0 + W[o + G_WW0 * BLOCK])
    e1 = -(e1 + W[o + G_WW1 * BLOCK])
    e2 = -(e2 + W[o + G_WW2 * BLOCK])
    e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
    fx = (e00 * e0 + e01 * e1 + e02 * e2) * inv_q
    fy = (e10 * e0 + e11 * e1 + e12 * e2) * inv_q
    if slip_possible:
        if W[(OFF_S + S_MODE) * BLOCK + j] > 0.5:  # slip: F/m = −μ_k (N/m) û
            mu_n = -W[p + MU_K * BLOCK] * nm
            fx = mu_n * W[o + G_UHX * BLOCK]
            fy = mu_n * W[o + G_UHY * BLOCK]
    if normal_output:
        W[x + X_N * BLOCK] = W[p + MASS * BLOCK] * nm
    if outputs:
        m = W[p + MASS * BLOCK]
        W[x + X_FX * BLOCK] = m * fx
        W[x + X_FY * BLOCK] = m * fy
        W[x + X_UX * BLOCK] = W[o + G_UX * BLOCK]
        W[x + X_UY * BLOCK] = W[o + G_UY * BLOCK]
    return fx, fy


@kernel
def store_derivative(W, slip_possible, stage):
    """Phase 4 of :func:`eval_block`: the friction force and the whole derivative, used
    as ``stage`` asks."""
    numba.literally(slip_possible)
    numba.literally(stage)
    state = OFF_Y if first_stage(stage) else OFF_T
    for j in range(BLOCK):
        y = state * BLOCK + j
        o = OFF_G * BLOCK + j
        q0 = W[y + Q0 * BLOCK]
        q1 = W[y + Q1 * BLOCK]
        q2 = W[y + Q2 * BLOCK]
        q3 = W[y + Q3 * BLOCK]
        fx, fy = friction_lane(W, j, slip_possible, stage, q0, q1, q2, q3)
        h0 = 0.5 * W[y + W0 * BLOCK]
        h1 = 0.5 * W[y + W1 * BLOCK]
        h2 = 0.5 * W[y + W2 * BLOCK]
        put_derivative(W, j, Q0 * BLOCK + j, stage, -(q1 * h0 + q2 * h1 + q3 * h2), True)
        put_derivative(W, j, Q1 * BLOCK + j, stage, q0 * h0 + q2 * h2 - q3 * h1, True)
        put_derivative(W, j, Q2 * BLOCK + j, stage, q0 * h1 + q3 * h0 - q1 * h2, True)
        put_derivative(W, j, Q3 * BLOCK + j, stage, q0 * h2 + q1 * h1 - q2 * h0, True)
        # ω̇, after divide_out
        put_derivative(W, j, W0 * BLOCK + j, stage, W[o + G_X0 * BLOCK], True)
        put_derivative(W, j, W1 * BLOCK + j, stage, W[o + G_X1 * BLOCK], True)
        put_derivative(W, j, W2 * BLOCK + j, stage, W[o + G_X2 * BLOCK], True)
        # no stage reads the position of G, so no stage state has one
        put_derivative(W, j, PX * BLOCK + j, stage, W[y + VX * BLOCK], False)
        put_derivative(W, j, PY * BLOCK + j, stage, W[y + VY * BLOCK], False)
        put_derivative(W, j, VX * BLOCK + j, stage, fx, True)
        put_derivative(W, j, VY * BLOCK + j, stage, fy, True)
