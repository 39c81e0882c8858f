"""The angular acceleration of the rattleback in either contact mode, with the spin and
rolling couples (docs/model.md: dynamics, with the couples), and the normal force:
phases 2 and 3 of :func:`.dynamics.eval_block`.
"""

from __future__ import annotations

import math

import numba

from ..jit import kernel
from ..workspace import (
    COUPLES,
    DT,
    GRAV,
    MU_K,
    MU_ROLL,
    MU_SPIN,
    OFF_P,
    OFF_S,
    S_MODE,
    S_ROLL,
    S_SPIN,
    S_SPIN_SENSE,
    at,
    lane_range,
)
from .contact import horizontal_rows
from .geometry import adjugate_solve, cross
from .slip import RELAX_STEPS
from .layout import (
    ALPHA_X,
    ALPHA_Y,
    ALPHA_Z,
    DAMPING_PM,
    DET,
    INV_QQ,
    J_XX,
    J_XY,
    J_XZ,
    J_YY,
    J_YZ,
    J_ZZ,
    JI_XX,
    JI_YY,
    JI_ZZ,
    NORMAL_PM,
    OFF_E,
    OFF_G,
    OMEGA_X,
    OMEGA_Y,
    OMEGA_Z,
    Q0,
    Q1,
    Q2,
    Q3,
    RHO_X,
    RHO_Y,
    RHO_Z,
    ROLL_FRACTION,
    ROLL_MARGIN,
    SPIN_LAMBDA,
    SPIN_RATE,
    UHAT_X,
    UHAT_Y,
    UP_X,
    UP_Y,
    UP_Z,
    WW_X,
    WW_Y,
    WW_Z,
)

__all__ = ["accelerations", "divide_out"]


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
            floor = (
                mu_roll
                * g
                * (W[at(OFF_E, JI_XX, j)] + W[at(OFF_E, JI_YY, j)] + W[at(OFF_E, JI_ZZ, j)])
                * W[at(OFF_P, DT, j)]
                / RELAX_STEPS
            )
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
        x0, x1, x2, det = adjugate_solve(
            m00,
            m01,
            m02,
            m10,
            m11,
            m12,
            m20,
            m21,
            m22,
            t0 - gy0 - cvm * w0,
            t1 - gy1 - cvm * w1,
            t2 - gy2 - cvm * w2,
        )
        if slip_possible == COUPLES:
            # a stuck spin: the couple λ n̂ (per unit mass) that keeps ω̇ · n̂ = 0, with
            # ω̇ = M⁻¹(b + λ n̂)
            y0, y1, y2, _ = adjugate_solve(
                m00, m01, m02, m10, m11, m12, m20, m21, m22, n0, n1, n2
            )
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
                bound - demand if roll_stuck else max(wh - floor, demand - bound)
            )
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
            l0, l1, l2 = cross(
                W[at(OFF_G, RHO_X, j)],
                W[at(OFF_G, RHO_Y, j)],
                W[at(OFF_G, RHO_Z, j)],
                n0,
                n1,
                n2,
            )
            W[at(OFF_G, NORMAL_PM, j)] = (
                W[at(OFF_P, GRAV, j)]
                - (
                    n0 * W[at(OFF_G, WW_X, j)]
                    + n1 * W[at(OFF_G, WW_Y, j)]
                    + n2 * W[at(OFF_G, WW_Z, j)]
                )
            ) - (l0 * x0 + l1 * x1 + l2 * x2)
