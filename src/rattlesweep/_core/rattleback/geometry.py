"""Closed-form contact geometry of a semi-ellipsoid on a floor (docs/model.md: contact
geometry).

Scalar functions of plain floats, returning tuples, so they inline into the lane loops.
Body frame: origin C at the centre of the flat face, z out of the flat face; the curved
surface is x²/a² + y²/b² + z²/c² = 1 with z ≤ 0.
"""

from __future__ import annotations

import math

from ..jit import inline_kernel, kernel
from ..workspace import GRAV, OFF_P, at
from .layout import (
    A2,
    B2,
    C2,
    COM_X,
    COM_Y,
    COM_Z,
    I_XX,
    I_XY,
    I_XZ,
    I_YY,
    I_YZ,
    I_ZZ,
    MASS,
    OMEGA_X,
    OMEGA_Y,
    OMEGA_Z,
    Q0,
    Q1,
    Q2,
    Q3,
    VEL_X,
    VEL_Y,
)

__all__ = [
    "adjugate_solve",
    "contact_point",
    "cross",
    "energy_terms",
    "plastic_contact_impulse",
    "plastic_roll_impulse",
    "rotation",
    "solve3",
]


@kernel
def cross(ax, ay, az, bx, by, bz):
    """a × b."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@kernel
def rotation(q0, q1, q2, q3):
    """Rotation matrix R (body → world) of the quaternion (q0, q1, q2, q3).

    The quaternion need not be exactly unit: R is built with 2/|q|², so it is a proper
    rotation for any non-zero q (RK stages carry slightly non-unit quaternions).
    Returns the nine elements row by row.
    """
    s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    r00 = 1.0 - s * (q2 * q2 + q3 * q3)
    r01 = s * (q1 * q2 - q0 * q3)
    r02 = s * (q1 * q3 + q0 * q2)
    r10 = s * (q1 * q2 + q0 * q3)
    r11 = 1.0 - s * (q1 * q1 + q3 * q3)
    r12 = s * (q2 * q3 - q0 * q1)
    r20 = s * (q1 * q3 - q0 * q2)
    r21 = s * (q2 * q3 + q0 * q1)
    r22 = 1.0 - s * (q1 * q1 + q2 * q2)
    return r00, r01, r02, r10, r11, r12, r20, r21, r22


@kernel
def contact_point(a2, b2, c2, n0, n1, n2):
    """Contact point s_P (body components, from C) for world-up n̂ in body components.

    s_P = −A n̂ / σ with A = diag(a², b², c²), σ = √(n̂ᵀ A n̂). Returns (s0, s1, s2, σ).
    """
    an0 = a2 * n0
    an1 = b2 * n1
    an2 = c2 * n2
    sigma = math.sqrt(n0 * an0 + n1 * an1 + n2 * an2)
    inv = 1.0 / sigma
    return -an0 * inv, -an1 * inv, -an2 * inv, sigma


@kernel
def energy_terms(W, off, j):
    """Energy (J), height of G (m) and vertical velocity of G (m/s) of lane j of the
    state region starting at row ``off`` of the block workspace W.

    E = ½ m |v_G|² + ½ ωᵀ I ω + m g z_G, with z_G = −ρ·n̂ and v_G,z = −n̂·(ω × ρ): the
    material point at P has no vertical velocity in stick and in slip alike.
    """
    q0 = W[at(off, Q0, j)]
    q1 = W[at(off, Q1, j)]
    q2 = W[at(off, Q2, j)]
    q3 = W[at(off, Q3, j)]
    s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    n0 = s * (q1 * q3 - q0 * q2)
    n1 = s * (q2 * q3 + q0 * q1)
    n2 = 1.0 - s * (q1 * q1 + q2 * q2)
    sp0, sp1, sp2, _ = contact_point(
        W[at(OFF_P, A2, j)], W[at(OFF_P, B2, j)], W[at(OFF_P, C2, j)], n0, n1, n2
    )
    r0 = sp0 - W[at(OFF_P, COM_X, j)]
    r1 = sp1 - W[at(OFF_P, COM_Y, j)]
    r2 = sp2 - W[at(OFF_P, COM_Z, j)]
    w0 = W[at(off, OMEGA_X, j)]
    w1 = W[at(off, OMEGA_Y, j)]
    w2 = W[at(off, OMEGA_Z, j)]
    c0, c1, c2 = cross(w0, w1, w2, r0, r1, r2)
    vz = -(n0 * c0 + n1 * c1 + n2 * c2)
    zg = -(r0 * n0 + r1 * n1 + r2 * n2)
    m = W[at(OFF_P, MASS, j)]
    ixy = W[at(OFF_P, I_XY, j)]
    ixz = W[at(OFF_P, I_XZ, j)]
    iyz = W[at(OFF_P, I_YZ, j)]
    iw0 = W[at(OFF_P, I_XX, j)] * w0 + ixy * w1 + ixz * w2
    iw1 = ixy * w0 + W[at(OFF_P, I_YY, j)] * w1 + iyz * w2
    iw2 = ixz * w0 + iyz * w1 + W[at(OFF_P, I_ZZ, j)] * w2
    vx = W[at(off, VEL_X, j)]
    vy = W[at(off, VEL_Y, j)]
    e = (
        0.5 * m * (vx * vx + vy * vy + vz * vz)
        + 0.5 * (w0 * iw0 + w1 * iw1 + w2 * iw2)
        + m * W[at(OFF_P, GRAV, j)] * zg
    )
    return e, zg, vz


@inline_kernel  # must inline into the lane loops: a call there stops vectorisation
def adjugate_solve(m00, m01, m02, m10, m11, m12, m20, m21, m22, b0, b1, b2):
    """adj(M) b and det M, so that M x = b has x = adj(M) b / det M (Cramer's rule)."""
    c00 = m11 * m22 - m12 * m21
    c01 = m12 * m20 - m10 * m22
    c02 = m10 * m21 - m11 * m20
    c10 = m02 * m21 - m01 * m22
    c11 = m00 * m22 - m02 * m20
    c12 = m01 * m20 - m00 * m21
    c20 = m01 * m12 - m02 * m11
    c21 = m02 * m10 - m00 * m12
    c22 = m00 * m11 - m01 * m10
    return (
        c00 * b0 + c10 * b1 + c20 * b2,
        c01 * b0 + c11 * b1 + c21 * b2,
        c02 * b0 + c12 * b1 + c22 * b2,
        m00 * c00 + m01 * c01 + m02 * c02,
    )


@inline_kernel  # must inline into the lane loops: a call there stops vectorisation
def solve3(m00, m01, m02, m10, m11, m12, m20, m21, m22, b0, b1, b2):
    """Solve the 3×3 system M x = b by Cramer's rule (adjugate over determinant)."""
    x0, x1, x2, det = adjugate_solve(
        m00, m01, m02, m10, m11, m12, m20, m21, m22, b0, b1, b2
    )
    inv_det = 1.0 / det
    return x0 * inv_det, x1 * inv_det, x2 * inv_det


@kernel
def impulse_column(r0, r1, r2, ixx, iyy, izz, ixy, ixz, iyz, inv_m, col):
    """Column ``col`` of K = 𝟙/m − [ρ]ₓ I⁻¹ [ρ]ₓ: K e = e/m − ρ × I⁻¹(ρ × e)."""
    e0 = 1.0 if col == 0 else 0.0
    e1 = 1.0 if col == 1 else 0.0
    e2 = 1.0 if col == 2 else 0.0
    t0, t1, t2 = cross(r0, r1, r2, e0, e1, e2)
    a0, a1, a2 = solve3(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz, t0, t1, t2)
    c0, c1, c2 = cross(r0, r1, r2, a0, a1, a2)
    return e0 * inv_m - c0, e1 * inv_m - c1, e2 * inv_m - c2


@kernel
def plastic_contact_impulse(W, off, j, ux, uy):
    """Bring the material contact point of lane j to rest with a perfectly plastic impulse.

    The impulse J (body components) acts at the contact point P: ΔV = R J / m and
    Δω = I⁻¹(ρ × J), with J = −K⁻¹ u, K = 𝟙/m − [ρ]ₓ I⁻¹ [ρ]ₓ, u = (ux, uy, 0) the
    slip velocity (world). The vertical slip velocity stays zero, so the floor constraint
    still holds, and the energy change −½ uᵀ K⁻¹ u is never positive. (Zeroing u through
    G's velocity alone, as docs/model.md: dynamics words it, is not an impulse and can add
    energy; both agree as dt → 0.)

    Returns the world-horizontal components of R J (N s).
    """
    r00, r01, r02, r10, r11, r12, n0, n1, n2 = rotation(
        W[at(off, Q0, j)], W[at(off, Q1, j)], W[at(off, Q2, j)], W[at(off, Q3, j)]
    )
    sp0, sp1, sp2, _ = contact_point(
        W[at(OFF_P, A2, j)], W[at(OFF_P, B2, j)], W[at(OFF_P, C2, j)], n0, n1, n2
    )
    r0 = sp0 - W[at(OFF_P, COM_X, j)]
    r1 = sp1 - W[at(OFF_P, COM_Y, j)]
    r2 = sp2 - W[at(OFF_P, COM_Z, j)]
    inv_m = 1.0 / W[at(OFF_P, MASS, j)]
    ixx = W[at(OFF_P, I_XX, j)]
    iyy = W[at(OFF_P, I_YY, j)]
    izz = W[at(OFF_P, I_ZZ, j)]
    ixy = W[at(OFF_P, I_XY, j)]
    ixz = W[at(OFF_P, I_XZ, j)]
    iyz = W[at(OFF_P, I_YZ, j)]
    # K e_k = e_k/m − ρ × I⁻¹(ρ × e_k), column by column (scalars: no allocation here,
    # this runs inside the time loop)
    k00, k10, k20 = impulse_column(r0, r1, r2, ixx, iyy, izz, ixy, ixz, iyz, inv_m, 0)
    k01, k11, k21 = impulse_column(r0, r1, r2, ixx, iyy, izz, ixy, ixz, iyz, inv_m, 1)
    k02, k12, k22 = impulse_column(r0, r1, r2, ixx, iyy, izz, ixy, ixz, iyz, inv_m, 2)
    # slip velocity in body components (world vertical part is zero)
    u0 = r00 * ux + r10 * uy
    u1 = r01 * ux + r11 * uy
    u2 = r02 * ux + r12 * uy
    j0, j1, j2 = solve3(k00, k01, k02, k10, k11, k12, k20, k21, k22, -u0, -u1, -u2)
    t0, t1, t2 = cross(r0, r1, r2, j0, j1, j2)
    dw0, dw1, dw2 = solve3(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz, t0, t1, t2)
    W[at(off, OMEGA_X, j)] += dw0
    W[at(off, OMEGA_Y, j)] += dw1
    W[at(off, OMEGA_Z, j)] += dw2
    jx = r00 * j0 + r01 * j1 + r02 * j2
    jy = r10 * j0 + r11 * j1 + r12 * j2
    W[at(off, VEL_X, j)] += jx * inv_m
    W[at(off, VEL_Y, j)] += jy * inv_m
    return jx, jy


@kernel
def plastic_roll_impulse(W, off, j, sticking):
    """Stop the rolling of lane j (its horizontal angular velocity ω_h) with a perfectly
    plastic horizontal couple impulse, as its rolling couple sticks.

    The floor keeps its constraints through the impulse: the contact point stays at rest
    when ``sticking``, else only its vertical velocity stays zero. Per unit mass, the
    kinetic energy is then ½ ωᵀ K ω (+ ½ |v_h|² while slipping) with
    K = J + |ρ|²𝟙 − ρρᵀ (sticking) or J + l lᵀ, l = ρ × n̂ (slipping), and a couple
    impulse τ changes ω by K⁻¹τ. With τ ⊥ n̂ and ω⁺ = s n̂: s = n̂·Kω / n̂·K n̂, the
    K-orthogonal projection of ω on n̂, so the energy never rises. A sticking contact's
    centre of mass follows, v_G = −ω × ρ.
    """
    q0 = W[at(off, Q0, j)]
    q1 = W[at(off, Q1, j)]
    q2 = W[at(off, Q2, j)]
    q3 = W[at(off, Q3, j)]
    r00, r01, r02, r10, r11, r12, n0, n1, n2 = rotation(q0, q1, q2, q3)
    sp0, sp1, sp2, _ = contact_point(
        W[at(OFF_P, A2, j)], W[at(OFF_P, B2, j)], W[at(OFF_P, C2, j)], n0, n1, n2
    )
    r0 = sp0 - W[at(OFF_P, COM_X, j)]
    r1 = sp1 - W[at(OFF_P, COM_Y, j)]
    r2 = sp2 - W[at(OFF_P, COM_Z, j)]
    m = W[at(OFF_P, MASS, j)]
    k00 = W[at(OFF_P, I_XX, j)]
    k11 = W[at(OFF_P, I_YY, j)]
    k22 = W[at(OFF_P, I_ZZ, j)]
    k01 = W[at(OFF_P, I_XY, j)]
    k02 = W[at(OFF_P, I_XZ, j)]
    k12 = W[at(OFF_P, I_YZ, j)]
    if sticking:
        rr = r0 * r0 + r1 * r1 + r2 * r2
        k00 += m * (rr - r0 * r0)
        k11 += m * (rr - r1 * r1)
        k22 += m * (rr - r2 * r2)
        k01 -= m * r0 * r1
        k02 -= m * r0 * r2
        k12 -= m * r1 * r2
    else:
        l0, l1, l2 = cross(r0, r1, r2, n0, n1, n2)
        k00 += m * l0 * l0
        k11 += m * l1 * l1
        k22 += m * l2 * l2
        k01 += m * l0 * l1
        k02 += m * l0 * l2
        k12 += m * l1 * l2
    w0 = W[at(off, OMEGA_X, j)]
    w1 = W[at(off, OMEGA_Y, j)]
    w2 = W[at(off, OMEGA_Z, j)]
    kn0 = k00 * n0 + k01 * n1 + k02 * n2
    kn1 = k01 * n0 + k11 * n1 + k12 * n2
    kn2 = k02 * n0 + k12 * n1 + k22 * n2
    spin = (kn0 * w0 + kn1 * w1 + kn2 * w2) / (kn0 * n0 + kn1 * n1 + kn2 * n2)
    d0 = spin * n0 - w0
    d1 = spin * n1 - w1
    d2 = spin * n2 - w2
    W[at(off, OMEGA_X, j)] = spin * n0
    W[at(off, OMEGA_Y, j)] = spin * n1
    W[at(off, OMEGA_Z, j)] = spin * n2
    if sticking:
        v0, v1, v2 = cross(d0, d1, d2, r0, r1, r2)  # Δv_G = −Δω × ρ
        W[at(off, VEL_X, j)] -= r00 * v0 + r01 * v1 + r02 * v2
        W[at(off, VEL_Y, j)] -= r10 * v0 + r11 * v1 + r12 * v2
