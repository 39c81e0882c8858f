"""Contact kinematics of the rattleback: where the contact point is, how it moves, and
the slip velocity of the material point there (docs/model.md: contact geometry); phase 1 of
:func:`.dynamics.eval_block`.
"""

from __future__ import annotations

import math

import numba

from ..jit import kernel
from ..workspace import OFF_P, at, lane_range
from .geometry import cross
from .layout import (
    A2,
    B2,
    C2,
    COM_X,
    COM_Y,
    COM_Z,
    INV_QQ,
    INV_SIGMA,
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
    SLIP_X,
    SLIP_Y,
    UP_X,
    UP_Y,
    UP_Z,
    VEL_X,
    VEL_Y,
    WW_X,
    WW_Y,
    WW_Z,
)

__all__ = ["contact_kinematics", "horizontal_rows"]


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
        (q00 + q11) - (q22 + q33),
        2.0 * (q12 - q03),
        2.0 * (q1 * q3 + q0 * q2),
        2.0 * (q12 + q03),
        (q00 + q22) - (q11 + q33),
        2.0 * (q2 * q3 - q0 * q1),
    )


@kernel
def contact_kinematics(W, slip_velocity, state, one_lane, lane):
    """Phase 1 of :func:`eval_block`: contact point, its rate, w, and the slip velocity.

    The rotation body -> world is R = R̃/|q|² with R̃ quadratic in q (stage quaternions
    are not unit), and the world up-vector in body components n̂ = ũ/|q|², ũ the last
    row of R̃. The contact point s_P = −A n̂/σ, σ = √(n̂ᵀA n̂), A = diag(a², b², c²), and
    its rate ṡ_P = −(A ṅ + s_P (An̂·ṅ)/σ)/σ with ṅ = n̂ × ω (docs/model.md: contact
    geometry) are unchanged when n̂ is replaced by ũ and σ by σ̃ = √(ũᵀAũ) = |q|² σ, so the
    only divisions are 1/|q|² and 1/σ̃, taken together as one. ``slip_velocity`` (a literal)
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
        sig = math.sqrt(
            u0 * u0 * W[at(OFF_P, A2, j)]
            + u1 * u1 * W[at(OFF_P, B2, j)]
            + u2 * u2 * W[at(OFF_P, C2, j)]
        )
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
            W[at(OFF_G, SLIP_X, j)] = (
                W[at(state, VEL_X, j)] + (e00 * wr0 + e01 * wr1 + e02 * wr2) * inv_q
            )
            W[at(OFF_G, SLIP_Y, j)] = (
                W[at(state, VEL_Y, j)] + (e10 * wr0 + e11 * wr1 + e12 * wr2) * inv_q
            )
