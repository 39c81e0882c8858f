"""Right-hand side of the rattleback with Coulomb stick/slip contact (MODEL.md section 4).

One function, :func:`eval_block`, evaluates the time derivative of every lane of a block
in one straight loop. The contact mode of each lane (stick or slip) is an input, held
through the stages of a step; stick and slip share one 3×3 solve, with the matrix and
right-hand side chosen per lane, so the loop has no data-dependent branches and LLVM
vectorises it across lanes.
"""

from __future__ import annotations

import math

import numba

from .geometry import contact_point, contact_point_rate, cross, solve3
from .jit import kernel
from .layout import (
    A2, B2, BLOCK, C2, DAMP, EPS_U, GRAV, GX, GY, GZ, IXX, IXY, IXZ, IYY, IYZ, IZZ,
    MASS, MU_K, OFF_D, OFF_P, OFF_S, OFF_T, OFF_X, PX, PY, Q0, Q1, Q2, Q3, S_MODE,
    S_UHX, S_UHY, VX, VY, W0, W1, W2, X_FX, X_FY, X_N, X_UX, X_UY,
)


@kernel
def eval_block(W, slip_possible, outputs):
    """Time derivative of every lane of a block, plus its contact forces.

    W is the block workspace (see :mod:`.layout`). Reads the parameters (region P), the
    stage input state (region T) and, from the switching state (region S), each lane's
    contact mode and stored slip direction; writes the derivative (region D) and, when
    ``outputs``, the normal force, friction force and slip velocity (region X). Both
    flags must be literals, so each combination compiles to its own variant:
    ``slip_possible=False`` promises that every lane sticks and drops the slip-only work;
    ``outputs=False`` (the inner RK stages, whose forces nobody reads) drops the work
    that only feeds region X. A lane's derivative is computed by the same operations in
    every variant, so it does not depend on which one ran.

    Stick (material contact point at rest):
        (I + m(|ρ|²𝟙 − ρρᵀ)) ω̇ = −ω × Iω − c_v ω + m ρ × (g n̂ − w)
    Slip (friction −μ_k N û opposite the slip velocity u):
        (I + m k lᵀ) ω̇ = −ω × Iω − c_v ω + N₀ k,  l = ρ × n̂,  k = ρ × (n̂ − μ_k û)
    with w = ω × (ω × ρ + ṡ_P), N₀ = m(g − n̂·w) and, in both modes, N = N₀ − m l·ω̇.
    """
    numba.literally(slip_possible)
    numba.literally(outputs)
    for j in range(BLOCK):
        # row r of region R is W[(OFF_R + r) * BLOCK]
        p = OFF_P * BLOCK + j
        y = OFF_T * BLOCK + j
        d = OFF_D * BLOCK + j
        x = OFF_X * BLOCK + j
        sw = OFF_S * BLOCK + j
        q0 = W[y + Q0 * BLOCK]
        q1 = W[y + Q1 * BLOCK]
        q2 = W[y + Q2 * BLOCK]
        q3 = W[y + Q3 * BLOCK]
        w0 = W[y + W0 * BLOCK]
        w1 = W[y + W1 * BLOCK]
        w2 = W[y + W2 * BLOCK]
        m = W[p + MASS * BLOCK]
        g = W[p + GRAV * BLOCK]
        ixx = W[p + IXX * BLOCK]
        iyy = W[p + IYY * BLOCK]
        izz = W[p + IZZ * BLOCK]
        ixy = W[p + IXY * BLOCK]
        ixz = W[p + IXZ * BLOCK]
        iyz = W[p + IYZ * BLOCK]
        a2 = W[p + A2 * BLOCK]
        b2 = W[p + B2 * BLOCK]
        c2 = W[p + C2 * BLOCK]

        # rotation body -> world; its last row is the world up-vector in body components
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        r00 = 1.0 - s * (q2 * q2 + q3 * q3)
        r01 = s * (q1 * q2 - q0 * q3)
        r02 = s * (q1 * q3 + q0 * q2)
        r10 = s * (q1 * q2 + q0 * q3)
        r11 = 1.0 - s * (q1 * q1 + q3 * q3)
        r12 = s * (q2 * q3 - q0 * q1)
        n0 = s * (q1 * q3 - q0 * q2)
        n1 = s * (q2 * q3 + q0 * q1)
        n2 = 1.0 - s * (q1 * q1 + q2 * q2)

        sp0, sp1, sp2, sigma = contact_point(a2, b2, c2, n0, n1, n2)
        r0 = sp0 - W[p + GX * BLOCK]
        r1 = sp1 - W[p + GY * BLOCK]
        r2 = sp2 - W[p + GZ * BLOCK]
        dn0, dn1, dn2 = cross(n0, n1, n2, w0, w1, w2)
        ds0, ds1, ds2 = contact_point_rate(a2, b2, c2, n0, n1, n2, sigma, dn0, dn1, dn2)
        wr0, wr1, wr2 = cross(w0, w1, w2, r0, r1, r2)
        ww0, ww1, ww2 = cross(w0, w1, w2, wr0 + ds0, wr1 + ds1, wr2 + ds2)

        # slip velocity of the material contact point, world horizontal
        ux = W[y + VX * BLOCK] + r00 * wr0 + r01 * wr1 + r02 * wr2
        uy = W[y + VY * BLOCK] + r10 * wr0 + r11 * wr1 + r12 * wr2
        slip = slip_possible and W[sw + S_MODE * BLOCK] > 0.5
        uu = math.sqrt(ux * ux + uy * uy)
        inv_uu = 1.0 / uu
        if uu > W[p + EPS_U * BLOCK]:
            uhx = ux * inv_uu
            uhy = uy * inv_uu
        else:
            uhx = W[sw + S_UHX * BLOCK]
            uhy = W[sw + S_UHY * BLOCK]
        mu = W[p + MU_K * BLOCK] if slip else 0.0  # a stick lane may carry mu = inf: keep it out
        # slip direction in body components
        ub0 = r00 * uhx + r10 * uhy
        ub1 = r01 * uhx + r11 * uhy
        ub2 = r02 * uhx + r12 * uhy

        iw0 = ixx * w0 + ixy * w1 + ixz * w2
        iw1 = ixy * w0 + iyy * w1 + iyz * w2
        iw2 = ixz * w0 + iyz * w1 + izz * w2
        gy0, gy1, gy2 = cross(w0, w1, w2, iw0, iw1, iw2)
        cv = W[p + DAMP * BLOCK]
        nw = n0 * ww0 + n1 * ww1 + n2 * ww2
        n_free = m * (g - nw)
        l0, l1, l2 = cross(r0, r1, r2, n0, n1, n2)
        k0, k1, k2 = cross(r0, r1, r2, n0 - mu * ub0, n1 - mu * ub1, n2 - mu * ub2)
        if slip:
            m00 = ixx + m * k0 * l0
            m01 = ixy + m * k0 * l1
            m02 = ixz + m * k0 * l2
            m10 = ixy + m * k1 * l0
            m11 = iyy + m * k1 * l1
            m12 = iyz + m * k1 * l2
            m20 = ixz + m * k2 * l0
            m21 = iyz + m * k2 * l1
            m22 = izz + m * k2 * l2
            f0 = n_free * k0
            f1 = n_free * k1
            f2 = n_free * k2
        else:
            rr = r0 * r0 + r1 * r1 + r2 * r2
            m00 = ixx + m * (rr - r0 * r0)
            m01 = ixy - m * r0 * r1
            m02 = ixz - m * r0 * r2
            m10 = m01
            m11 = iyy + m * (rr - r1 * r1)
            m12 = iyz - m * r1 * r2
            m20 = m02
            m21 = m12
            m22 = izz + m * (rr - r2 * r2)
            f0, f1, f2 = cross(r0, r1, r2, m * (g * n0 - ww0), m * (g * n1 - ww1),
                               m * (g * n2 - ww2))
        b0 = f0 - gy0 - cv * w0
        b1 = f1 - gy1 - cv * w1
        b2 = f2 - gy2 - cv * w2

        a0, a1, a2_ = solve3(m00, m01, m02, m10, m11, m12, m20, m21, m22, b0, b1, b2)
        normal = n_free - m * (l0 * a0 + l1 * a1 + l2 * a2_)
        if slip:
            fx = -mu * normal * uhx
            fy = -mu * normal * uhy
        else:
            # F = m(a_G + g n̂) with a_G = −(ω̇ × ρ + w); its world-horizontal part
            e0, e1, e2 = cross(a0, a1, a2_, r0, r1, r2)
            e0 = -m * (e0 + ww0)
            e1 = -m * (e1 + ww1)
            e2 = -m * (e2 + ww2)
            fx = r00 * e0 + r01 * e1 + r02 * e2
            fy = r10 * e0 + r11 * e1 + r12 * e2

        W[d + Q0 * BLOCK] = -0.5 * (q1 * w0 + q2 * w1 + q3 * w2)
        W[d + Q1 * BLOCK] = 0.5 * (q0 * w0 + q2 * w2 - q3 * w1)
        W[d + Q2 * BLOCK] = 0.5 * (q0 * w1 + q3 * w0 - q1 * w2)
        W[d + Q3 * BLOCK] = 0.5 * (q0 * w2 + q1 * w1 - q2 * w0)
        W[d + W0 * BLOCK] = a0
        W[d + W1 * BLOCK] = a1
        W[d + W2 * BLOCK] = a2_
        W[d + PX * BLOCK] = W[y + VX * BLOCK]
        W[d + PY * BLOCK] = W[y + VY * BLOCK]
        W[d + VX * BLOCK] = fx / m
        W[d + VY * BLOCK] = fy / m
        if outputs:
            W[x + X_N * BLOCK] = normal
            W[x + X_FX * BLOCK] = fx
            W[x + X_FY * BLOCK] = fy
            W[x + X_UX * BLOCK] = ux
            W[x + X_UY * BLOCK] = uy
