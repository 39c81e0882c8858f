"""What the rattleback model supplies to the shared stepper (:mod:`..stepper`): its
set-up, its step checks, what it observes and records, and its contact impulses.

Every function works on lane j of a block workspace laid out by :mod:`.layout`; the
once-per-step ones (:func:`check_step`, :func:`spin_and_watch`) are inlined into the
stepper's vector passes.
"""

from __future__ import annotations

import math

from ..jit import inline_kernel, kernel
from ..workspace import (
    BLOCK,
    DT,
    GRAV,
    K_HEAD_EXT_X,
    K_HEAD_EXT_Y,
    K_HEAD_TURNS,
    K_WATCH_LOW,
    MU_ROLL,
    OFF_K,
    OFF_P,
    OFF_S,
    OFF_X,
    S_JX,
    S_JY,
    S_MODE,
    S_ROLL,
    X_FX,
    X_FY,
    X_N,
    X_UX,
    X_UY,
    at,
)
from .geometry import (
    contact_point,
    energy_terms,
    plastic_contact_impulse,
    plastic_roll_impulse,
    rotation,
)
from .layout import (
    DAMPING,
    DAMPING_PM,
    I_XX,
    I_XY,
    I_XZ,
    I_YY,
    I_YZ,
    I_ZZ,
    J_XX,
    J_XY,
    J_XZ,
    J_YY,
    J_YZ,
    J_ZZ,
    JI_XX,
    JI_XY,
    JI_XZ,
    JI_YY,
    JI_YZ,
    JI_ZZ,
    MASS,
    OFF_E,
    A2,
    B2,
    C2,
    COM_X,
    COM_Y,
    COM_Z,
    FULL,
    N_STATE,
    O_MAX_TILT,
    OFF_A,
    OFF_B,
    OFF_T,
    OFF_Y,
    OMEGA_X,
    OMEGA_Y,
    OMEGA_Z,
    POS_X,
    POS_Y,
    Q0,
    Q1,
    Q2,
    Q3,
    R_CONTACT,
    R_ENERGY,
    R_FRICTION,
    R_HEADING,
    R_IMPULSE,
    R_NORMAL,
    R_OMEGA,
    R_POSITION,
    R_QUATERNION,
    R_SLIP_VELOCITY,
    R_SLIPPING,
    R_SPIN,
    R_TILT,
    R_VELOCITY,
    VEL_X,
    VEL_Y,
)

__all__ = [
    "LOCATES_SWITCHES",
    "check_step",
    "couple_rates",
    "derive",
    "energy",
    "euler_step",
    "finish",
    "heading",
    "park",
    "record",
    "roll_start",
    "separation",
    "spin_and_watch",
    "start_lane",
    "stick_couples",
    "stick_impulse",
]

LOCATES_SWITCHES = True
"""The rattleback's stick/slip switches are located inside the step (:mod:`..events`).
Its slow slips, whose direction relaxes faster than the step follows, are steered onto
their slow manifold (:func:`.slip.slip_direction`)."""


@kernel
def derive(W, j):
    """Fill lane j's derived parameters (region E) from its parameters (region P)."""
    m = W[at(OFF_P, MASS, j)]
    for src, dst in (
        (I_XX, J_XX),
        (I_YY, J_YY),
        (I_ZZ, J_ZZ),
        (I_XY, J_XY),
        (I_XZ, J_XZ),
        (I_YZ, J_YZ),
        (DAMPING, DAMPING_PM),
    ):
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
def energy(W, j):
    """Mechanical energy of the state Y, J."""
    return energy_terms(W, OFF_Y, j)[0]


@kernel
def separation(W, j, k):
    """Distance between the states Y of lanes j and k (lane j's parameters) in the
    variables the motion of a rolling body depends on: the world up-vector in body
    components (dimensionless) and the body angular velocity in units of sqrt(g/c).
    Position and heading are left out: the motion does not depend on them."""
    gj = up_vector(W, OFF_Y, j)
    gk = up_vector(W, OFF_Y, k)
    rate2 = W[at(OFF_P, GRAV, j)] / math.sqrt(W[at(OFF_P, C2, j)])
    d2 = 0.0
    for i in range(3):
        d2 += (gk[i] - gj[i]) ** 2
        dw = W[at(OFF_Y, OMEGA_X + i, k)] - W[at(OFF_Y, OMEGA_X + i, j)]
        d2 += dw * dw / rate2
    return math.sqrt(d2)


@kernel
def start_lane(W, j):
    """Normalise the launch quaternion of a finite lane; True when a semi-ellipsoid
    starts with its rim on or below the floor (capsized)."""
    q0 = W[at(OFF_Y, Q0, j)]
    q1 = W[at(OFF_Y, Q1, j)]
    q2 = W[at(OFF_Y, Q2, j)]
    q3 = W[at(OFF_Y, Q3, j)]
    qn = 1.0 / math.sqrt(q0**2 + q1**2 + q2**2 + q3**2)
    for k in range(4):
        W[at(OFF_Y, Q0 + k, j)] *= qn
    return W[at(OFF_P, FULL, j)] < 0.5 and up_vector(W, OFF_Y, j)[2] <= 0.0


@kernel
def euler_step(W):
    """Semi-implicit Euler on region Y, in place, with the derivative in A from the first
    RK stage: velocities first, then positions and orientation with the new velocities.
    Leaves the old state in B, as the RK4 stages do."""
    for j in range(BLOCK):
        dt = W[at(OFF_P, DT, j)]
        h = 0.5 * dt
        q0 = W[at(OFF_Y, Q0, j)]
        q1 = W[at(OFF_Y, Q1, j)]
        q2 = W[at(OFF_Y, Q2, j)]
        q3 = W[at(OFF_Y, Q3, j)]
        w0 = W[at(OFF_Y, OMEGA_X, j)] + dt * W[at(OFF_A, OMEGA_X, j)]
        w1 = W[at(OFF_Y, OMEGA_Y, j)] + dt * W[at(OFF_A, OMEGA_Y, j)]
        w2 = W[at(OFF_Y, OMEGA_Z, j)] + dt * W[at(OFF_A, OMEGA_Z, j)]
        vx = W[at(OFF_Y, VEL_X, j)] + dt * W[at(OFF_A, VEL_X, j)]
        vy = W[at(OFF_Y, VEL_Y, j)] + dt * W[at(OFF_A, VEL_Y, j)]
        px = W[at(OFF_Y, POS_X, j)] + dt * vx
        py = W[at(OFF_Y, POS_Y, j)] + dt * vy
        for k in range(N_STATE):
            W[at(OFF_B, k, j)] = W[at(OFF_Y, k, j)]
        W[at(OFF_Y, Q0, j)] = q0 - h * (q1 * w0 + q2 * w1 + q3 * w2)
        W[at(OFF_Y, Q1, j)] = q1 + h * (q0 * w0 + q2 * w2 - q3 * w1)
        W[at(OFF_Y, Q2, j)] = q2 + h * (q0 * w1 + q3 * w0 - q1 * w2)
        W[at(OFF_Y, Q3, j)] = q3 + h * (q0 * w2 + q1 * w1 - q2 * w0)
        W[at(OFF_Y, OMEGA_X, j)] = w0
        W[at(OFF_Y, OMEGA_Y, j)] = w1
        W[at(OFF_Y, OMEGA_Z, j)] = w2
        W[at(OFF_Y, POS_X, j)] = px
        W[at(OFF_Y, POS_Y, j)] = py
        W[at(OFF_Y, VEL_X, j)] = vx
        W[at(OFF_Y, VEL_Y, j)] = vy


@inline_kernel
def check_step(W, j):
    """Renormalise the quaternion of lane j's new state (region Y) and return
    (non-finite, capsized): whether a component of the new state is NaN or inf, and
    whether a semi-ellipsoid's rim reached the floor."""
    q0 = W[at(OFF_Y, Q0, j)]
    q1 = W[at(OFF_Y, Q1, j)]
    q2 = W[at(OFF_Y, Q2, j)]
    q3 = W[at(OFF_Y, Q3, j)]
    # a sum of the state is non-finite when a component is (or, harmlessly, when the
    # finite ones overflow together), and s − s is NaN exactly then: fewer operations
    # than a test per component, in a tree of short dependency chains
    total = (
        ((q0 + q1) + (q2 + q3))
        + (
            (W[at(OFF_Y, OMEGA_X, j)] + W[at(OFF_Y, OMEGA_Y, j)])
            + (W[at(OFF_Y, OMEGA_Z, j)] + W[at(OFF_Y, POS_X, j)])
        )
        + ((W[at(OFF_Y, POS_Y, j)] + W[at(OFF_Y, VEL_X, j)]) + W[at(OFF_Y, VEL_Y, j)])
    )
    nan_or_inf = total - total
    qn = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    q1 *= qn
    q2 *= qn
    W[at(OFF_Y, Q0, j)] = q0 * qn
    W[at(OFF_Y, Q1, j)] = q1
    W[at(OFF_Y, Q2, j)] = q2
    W[at(OFF_Y, Q3, j)] = q3 * qn
    up_z = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    return nan_or_inf != 0.0, (W[at(OFF_P, FULL, j)] < 0.5) & (up_z <= 0.0)


@inline_kernel
def spin_and_watch(W, j):
    """(spin, watched quantity) of lane j's state Y: the vertical angular velocity
    (rad/s) and the vertical component of the body's up-axis, whose smallest value
    gives the largest tilt. The quaternion is unit here (after :func:`check_step`)."""
    q0 = W[at(OFF_Y, Q0, j)]
    q1 = W[at(OFF_Y, Q1, j)]
    q2 = W[at(OFF_Y, Q2, j)]
    q3 = W[at(OFF_Y, Q3, j)]
    up_z = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    n = (
        W[at(OFF_Y, OMEGA_X, j)] * (2.0 * (q1 * q3 - q0 * q2))
        + W[at(OFF_Y, OMEGA_Y, j)] * (2.0 * (q2 * q3 + q0 * q1))
        + W[at(OFF_Y, OMEGA_Z, j)] * up_z
    )
    return n, up_z


@inline_kernel
def heading(W, j):
    """(X, Y) world components of lane j's body x axis (state Y, unit quaternion): the
    first column of R(q), whose direction seen from above is the heading."""
    q0 = W[at(OFF_Y, Q0, j)]
    q1 = W[at(OFF_Y, Q1, j)]
    q2 = W[at(OFF_Y, Q2, j)]
    q3 = W[at(OFF_Y, Q3, j)]
    return 1.0 - 2.0 * (q2 * q2 + q3 * q3), 2.0 * (q1 * q2 + q0 * q3)


@kernel
def roll_start(W, j):
    """Set G's velocity so that lane j's material contact point is at rest (a rolling
    launch, not a collision), from the slip velocity in region X."""
    W[at(OFF_Y, VEL_X, j)] -= W[at(OFF_X, X_UX, j)]
    W[at(OFF_Y, VEL_Y, j)] -= W[at(OFF_X, X_UY, j)]


@kernel
def stick_impulse(W, j):
    """Apply the plastic contact impulse that brings lane j's slipping contact point to
    rest; returns its world-horizontal components (N s)."""
    return plastic_contact_impulse(
        W, OFF_Y, j, W[at(OFF_X, X_UX, j)], W[at(OFF_X, X_UY, j)]
    )


@kernel
def stick_couples(W, j):
    """Lane j's couples have just switched: a rolling couple that now sticks stops the
    rolling, ω_h, with a plastic couple impulse (a stuck spin needs none: its switch is
    located where ω · n̂ crosses zero)."""
    if W[at(OFF_S, S_ROLL, j)] < 0.5 and W[at(OFF_P, MU_ROLL, j)] > 0.0:
        plastic_roll_impulse(W, OFF_Y, j, W[at(OFF_S, S_MODE, j)] < 0.5)


@kernel
def couple_rates(W, j):
    """(ω · n̂, |ω_h|) of lane j's state, rad/s: the spin the spin couple opposes, and
    the size of the rolling that the rolling couple opposes (a direction, not a sense,
    in 3-D)."""
    n0, n1, n2 = up_vector(W, OFF_Y, j)
    w0 = W[at(OFF_Y, OMEGA_X, j)]
    w1 = W[at(OFF_Y, OMEGA_Y, j)]
    w2 = W[at(OFF_Y, OMEGA_Z, j)]
    wn = w0 * n0 + w1 * n1 + w2 * n2
    h0 = w0 - wn * n0
    h1 = w1 - wn * n1
    h2 = w2 - wn * n2
    return wn, math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)


@kernel
def park(W, j):
    """A harmless state for a lane that is no longer stepped: upright at rest."""
    for k in range(N_STATE):
        W[at(OFF_Y, k, j)] = 0.0
        W[at(OFF_T, k, j)] = 0.0
    W[at(OFF_Y, Q0, j)] = 1.0
    W[at(OFF_T, Q0, j)] = 1.0


@kernel
def finish(W, j, O, launched):
    """Write this model's own observables of lane j into O; ``launched`` is False for a
    lane whose launch state was not finite (nothing is computed from it)."""
    if launched:
        O[O_MAX_TILT, j] = math.acos(min(1.0, max(-1.0, W[at(OFF_K, K_WATCH_LOW, j)])))
    else:
        O[O_MAX_TILT, j] = math.nan


@kernel
def record(W, j, out):
    """Write the recorded quantities of lane j (state region Y, contact outputs X) into
    out (N_REC,)."""
    for k in range(4):
        out[R_QUATERNION + k] = W[at(OFF_Y, Q0 + k, j)]
    for k in range(3):
        out[R_OMEGA + k] = W[at(OFF_Y, OMEGA_X + k, j)]
    e, zg, vz = energy_terms(W, OFF_Y, j)
    out[R_POSITION] = W[at(OFF_Y, POS_X, j)]
    out[R_POSITION + 1] = W[at(OFF_Y, POS_Y, j)]
    out[R_POSITION + 2] = zg
    out[R_VELOCITY] = W[at(OFF_Y, VEL_X, j)]
    out[R_VELOCITY + 1] = W[at(OFF_Y, VEL_Y, j)]
    out[R_VELOCITY + 2] = vz
    out[R_SPIN] = spin_and_watch(W, j)[0]
    # the heading, unwrapped: that of the furthest direction the stepper follows (within
    # HEADING_BAND of it, its whole turns counted), plus the angle from there; + 0.0
    # turns a -0.0 into +0.0, on the side of the cut that the stepper counts it on
    hx, hy = heading(W, j)
    ex = W[at(OFF_K, K_HEAD_EXT_X, j)]
    ey = W[at(OFF_K, K_HEAD_EXT_Y, j)]
    turns = W[at(OFF_K, K_HEAD_TURNS, j)]
    out[R_HEADING] = (
        math.atan2(ey + 0.0, ex)
        + 2.0 * math.pi * turns
        + math.atan2(ex * hy - ey * hx, ex * hx + ey * hy)
    )
    n0, n1, n2 = up_vector(W, OFF_Y, j)
    # atan2 keeps full precision at tiny tilts, where 1 - cos(tilt) underflows float64
    out[R_TILT] = math.atan2(math.sqrt(n0 * n0 + n1 * n1), n2)
    out[R_ENERGY] = e
    out[R_NORMAL] = W[at(OFF_X, X_N, j)]
    out[R_FRICTION] = W[at(OFF_X, X_FX, j)]
    out[R_FRICTION + 1] = W[at(OFF_X, X_FY, j)]
    out[R_SLIP_VELOCITY] = W[at(OFF_X, X_UX, j)]
    out[R_SLIP_VELOCITY + 1] = W[at(OFF_X, X_UY, j)]
    out[R_SLIPPING] = W[at(OFF_S, S_MODE, j)]
    out[R_IMPULSE] = W[at(OFF_S, S_JX, j)]
    out[R_IMPULSE + 1] = W[at(OFF_S, S_JY, j)]
    out[R_CONTACT], out[R_CONTACT + 1] = floor_contact(W, j)


@kernel
def floor_contact(W, j):
    """World-horizontal position (m) of lane j's contact point on the floor: G plus
    R ρ, with ρ from G to the contact point (docs/model.md: contact geometry)."""
    r00, r01, r02, r10, r11, r12, n0, n1, n2 = rotation(
        W[at(OFF_Y, Q0, j)], W[at(OFF_Y, Q1, j)], W[at(OFF_Y, Q2, j)], W[at(OFF_Y, Q3, j)]
    )
    s0, s1, s2, _ = contact_point(
        W[at(OFF_P, A2, j)], W[at(OFF_P, B2, j)], W[at(OFF_P, C2, j)], n0, n1, n2
    )
    rho0 = s0 - W[at(OFF_P, COM_X, j)]
    rho1 = s1 - W[at(OFF_P, COM_Y, j)]
    rho2 = s2 - W[at(OFF_P, COM_Z, j)]
    return (
        W[at(OFF_Y, POS_X, j)] + r00 * rho0 + r01 * rho1 + r02 * rho2,
        W[at(OFF_Y, POS_Y, j)] + r10 * rho0 + r11 * rho1 + r12 * rho2,
    )
