"""The friction force and the whole time derivative of the rattleback's state, used as
the RK4 stage asks (:mod:`..stages`): phase 4 of :func:`.dynamics.eval_block`.
"""

from __future__ import annotations

import math

import numba

from ..jit import inline_kernel, kernel
from ..stages import first_stage, put_derivative
from ..switching import stop_time
from ..workspace import (
    BLOCK,
    COUPLES,
    EPS_U,
    MU_K,
    MU_ROLL,
    MU_SPIN,
    OFF_P,
    OFF_S,
    OFF_X,
    S_MODE,
    S_ROLL,
    S_SPIN,
    S_SPIN_SENSE,
    STAGE_FIRST,
    STAGE_START,
    X_FX,
    X_FY,
    X_N,
    X_ROLL_COUPLE,
    X_ROLL_EVENT,
    X_SPIN_COUPLE,
    X_SPIN_EVENT,
    X_TSTOP,
    X_UX,
    X_UY,
    at,
    lane_range,
)
from .contact import horizontal_rows
from .geometry import cross
from .layout import (
    ALPHA_X,
    ALPHA_Y,
    ALPHA_Z,
    INV_QQ,
    MASS,
    NORMAL_PM,
    OFF_A,
    OFF_B,
    OFF_G,
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
    RHO_X,
    RHO_Y,
    RHO_Z,
    ROLL_FRACTION,
    ROLL_MARGIN,
    SLIP_X,
    SLIP_Y,
    SPIN_LAMBDA,
    SPIN_RATE,
    UHAT_X,
    UHAT_Y,
    VEL_X,
    VEL_Y,
    WW_X,
    WW_Y,
    WW_Z,
)

__all__ = ["friction_lane", "store_derivative"]


@inline_kernel
def friction_lane(W, j, slip_possible, stage, q0, q1, q2, q3):
    """Friction force per unit mass on lane j, world horizontal (m/s²), for
    :func:`store_derivative`, which passes the state's quaternion; writes the outputs
    of region X at STAGE_START and STAGE_FIRST (at STAGE_START with the time until the
    slip stops at its present deceleration, from the slip acceleration u̇). Inlined into the
    derivative loop, which is bound by its loads and stores: the friction's arithmetic fits
    in beside them, and its result never goes to memory."""
    outputs = stage == STAGE_START
    normal_output = outputs or stage == STAGE_FIRST
    nm = W[at(OFF_G, NORMAL_PM, j)]  # N/m, after divide_out
    inv_q = W[at(OFF_G, INV_QQ, j)]
    # stick: F/m = a_G + g n̂ with a_G = −(ω̇ × ρ + w); its world-horizontal part
    e0, e1, e2 = cross(
        W[at(OFF_G, ALPHA_X, j)],
        W[at(OFF_G, ALPHA_Y, j)],
        W[at(OFF_G, ALPHA_Z, j)],
        W[at(OFF_G, RHO_X, j)],
        W[at(OFF_G, RHO_Y, j)],
        W[at(OFF_G, RHO_Z, j)],
    )
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
        W[at(OFF_X, X_TSTOP, j)] = stop_time(
            ux,
            uy,
            dux,
            duy,
            W[at(OFF_G, UHAT_X, j)],
            W[at(OFF_G, UHAT_Y, j)],
            W[at(OFF_P, EPS_U, j)],
        )
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
                if W[at(OFF_S, S_ROLL, j)] > 0.5
                else mu_roll * nm - roll_margin
            )
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
        put_derivative(
            W,
            j,
            Q0 * BLOCK + j,
            stage,
            -(q1 * h0 + q2 * h1 + q3 * h2),
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            Q1 * BLOCK + j,
            stage,
            q0 * h0 + q2 * h2 - q3 * h1,
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            Q2 * BLOCK + j,
            stage,
            q0 * h1 + q3 * h0 - q1 * h2,
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            Q3 * BLOCK + j,
            stage,
            q0 * h2 + q1 * h1 - q2 * h0,
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        # ω̇, after divide_out
        put_derivative(
            W,
            j,
            OMEGA_X * BLOCK + j,
            stage,
            W[at(OFF_G, ALPHA_X, j)],
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            OMEGA_Y * BLOCK + j,
            stage,
            W[at(OFF_G, ALPHA_Y, j)],
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            OMEGA_Z * BLOCK + j,
            stage,
            W[at(OFF_G, ALPHA_Z, j)],
            True,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        # no stage reads the position of G, so no stage state has one
        put_derivative(
            W,
            j,
            POS_X * BLOCK + j,
            stage,
            W[at(state, VEL_X, j)],
            False,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(
            W,
            j,
            POS_Y * BLOCK + j,
            stage,
            W[at(state, VEL_Y, j)],
            False,
            OFF_Y,
            OFF_T,
            OFF_A,
            OFF_B,
        )
        put_derivative(W, j, VEL_X * BLOCK + j, stage, fx, True, OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(W, j, VEL_Y * BLOCK + j, stage, fy, True, OFF_Y, OFF_T, OFF_A, OFF_B)
