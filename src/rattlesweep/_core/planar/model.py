"""What the planar model supplies to the shared stepper (:mod:`..stepper`): its set-up,
its step checks, what it observes and records, and its contact impulse (see
:mod:`..rattleback.model` for the same for the 3-D body)."""

from __future__ import annotations

import math

from ..jit import inline_kernel, kernel
from ..workspace import (
    BLOCK,
    DT,
    GRAV,
    K_WATCH_LOW,
    OFF_K,
    OFF_P,
    OFF_S,
    OFF_X,
    S_MODE,
    X_FX,
    X_N,
    X_UX,
    at,
)
from .dynamics import contact_impulse, energy as planar_energy, shape
from .layout import (
    OFF_A,
    OFF_B,
    A2,
    AB2,
    B2,
    DEPTH,
    INERTIA,
    MASS,
    N_STATE,
    OFF_T,
    OFF_Y,
    O_FINAL_ANGLE,
    O_FINAL_RATE,
    O_MAX_ANGLE,
    RATE,
    R_ANGLE,
    R_ENERGY,
    R_F,
    R_N,
    R_RATE,
    R_SLIP,
    R_U,
    R_VX,
    R_VY,
    R_XG,
    R_YG,
    THETA,
    VXG,
    XG,
)

__all__ = [
    "LOCATES_SWITCHES",
    "check_step",
    "couple_rates",
    "derive",
    "energy",
    "euler_step",
    "finish",
    "park",
    "record",
    "roll_start",
    "separation",
    "spin_and_watch",
    "start_lane",
    "stick_couples",
    "stick_impulse",
]

HALF_PI = 0.5 * math.pi

LOCATES_SWITCHES = True
"""Stick/slip switches are located inside the RK4 step (:mod:`..events`)."""


@kernel
def derive(W, j):
    """Nothing to derive: the planar right-hand side reads its parameters directly."""


@kernel
def lane_shape(W, j):
    """(h, h′, h + h″) of lane j at its state Y."""
    return shape(
        W[at(OFF_P, A2, j)],
        W[at(OFF_P, B2, j)],
        W[at(OFF_P, AB2, j)],
        W[at(OFF_P, DEPTH, j)],
        W[at(OFF_Y, THETA, j)],
    )


@kernel
def energy(W, j):
    """Mechanical energy of lane j's state Y, J."""
    h, hp, _ = lane_shape(W, j)
    return planar_energy(
        W[at(OFF_P, MASS, j)],
        W[at(OFF_P, INERTIA, j)],
        W[at(OFF_P, GRAV, j)],
        h,
        hp,
        W[at(OFF_Y, RATE, j)],
        W[at(OFF_Y, VXG, j)],
    )


@kernel
def separation(W, j, k):
    """Distance between the states Y of lanes j and k (lane j's parameters): the angle
    (rad) and the rate in units of sqrt(g/b). The motion does not depend on x_G."""
    rate2 = W[at(OFF_P, GRAV, j)] / math.sqrt(W[at(OFF_P, B2, j)])
    da = W[at(OFF_Y, THETA, k)] - W[at(OFF_Y, THETA, j)]
    dw = W[at(OFF_Y, RATE, k)] - W[at(OFF_Y, RATE, j)]
    return math.sqrt(da * da + dw * dw / rate2)


@kernel
def start_lane(W, j):
    """True when the launch angle puts a corner of the flat edge on the floor."""
    return abs(W[at(OFF_Y, THETA, j)]) >= HALF_PI


@inline_kernel
def check_step(W, j):
    """(non-finite, capsized) of lane j's new state (region Y)."""
    theta = W[at(OFF_Y, THETA, j)]
    total = (theta + W[at(OFF_Y, RATE, j)]) + (W[at(OFF_Y, XG, j)] + W[at(OFF_Y, VXG, j)])
    return (total - total) != 0.0, abs(theta) >= HALF_PI


@inline_kernel
def spin_and_watch(W, j):
    """(spin, watched quantity) of lane j's state Y: no spin about the vertical in the
    plane (reversal tracking stays off), and −|θ|, whose smallest value gives the
    largest |θ|."""
    return 0.0, -abs(W[at(OFF_Y, THETA, j)])


@inline_kernel
def heading(W, j):
    """The lamina's long axis never turns about the vertical: its heading is fixed."""
    return 1.0, 0.0


@kernel
def roll_start(W, j):
    """Set ẋ_G so that lane j's contact point is at rest (a launch condition, not a
    collision)."""
    W[at(OFF_Y, VXG, j)] -= W[at(OFF_X, X_UX, j)]


@kernel
def stick_impulse(W, j):
    """Apply the plastic impulse that brings lane j's slipping contact point to rest;
    returns its horizontal components (N s), the second zero."""
    h, hp, _ = lane_shape(W, j)
    m = W[at(OFF_P, MASS, j)]
    dv, dw = contact_impulse(m, W[at(OFF_P, INERTIA, j)], h, hp, W[at(OFF_X, X_UX, j)])
    W[at(OFF_Y, VXG, j)] += dv
    W[at(OFF_Y, RATE, j)] += dw
    return m * dv, 0.0


@kernel
def stick_couples(W, j):
    """Nothing: the rolling couple's switch is located where θ̇ crosses zero."""


@kernel
def couple_rates(W, j):
    """(0, θ̇) of lane j's state, rad/s: no spin about the normal here; the rocking rate
    the rolling couple opposes."""
    return 0.0, W[at(OFF_Y, RATE, j)]


@kernel
def park(W, j):
    """A harmless state for a lane that is no longer stepped: upright at rest."""
    for k in range(N_STATE):
        W[at(OFF_Y, k, j)] = 0.0
        W[at(OFF_T, k, j)] = 0.0


@kernel
def finish(W, j, O, launched):
    """Write this model's own observables of lane j into O; ``launched`` is False for a
    lane whose launch state was not finite."""
    if launched:
        O[O_MAX_ANGLE, j] = -W[at(OFF_K, K_WATCH_LOW, j)]
        O[O_FINAL_ANGLE, j] = W[at(OFF_Y, THETA, j)]
        O[O_FINAL_RATE, j] = W[at(OFF_Y, RATE, j)]
    else:
        O[O_MAX_ANGLE, j] = math.nan
        O[O_FINAL_ANGLE, j] = math.nan
        O[O_FINAL_RATE, j] = math.nan


@kernel
def record(W, j, out):
    """Write the recorded quantities of lane j (state Y, contact outputs X) into out."""
    h, hp, _ = lane_shape(W, j)
    rate = W[at(OFF_Y, RATE, j)]
    out[R_ANGLE] = W[at(OFF_Y, THETA, j)]
    out[R_RATE] = rate
    out[R_XG] = W[at(OFF_Y, XG, j)]
    out[R_YG] = h
    out[R_VX] = W[at(OFF_Y, VXG, j)]
    out[R_VY] = hp * rate
    out[R_U] = W[at(OFF_X, X_UX, j)]
    out[R_N] = W[at(OFF_X, X_N, j)]
    out[R_F] = W[at(OFF_X, X_FX, j)]
    out[R_ENERGY] = energy(W, j)
    out[R_SLIP] = W[at(OFF_S, S_MODE, j)]


@kernel
def euler_step(W):
    """Semi-implicit Euler on region Y, in place, with the derivative in A from the first
    stage: velocities first, then positions with the new velocities. Leaves the old state
    in B, as the RK4 stages do."""
    for j in range(BLOCK):
        dt = W[at(OFF_P, DT, j)]
        rate = W[at(OFF_Y, RATE, j)] + dt * W[at(OFF_A, RATE, j)]
        vx = W[at(OFF_Y, VXG, j)] + dt * W[at(OFF_A, VXG, j)]
        theta = W[at(OFF_Y, THETA, j)] + dt * rate
        x = W[at(OFF_Y, XG, j)] + dt * vx
        for k in (THETA, RATE, XG, VXG):
            W[at(OFF_B, k, j)] = W[at(OFF_Y, k, j)]
        W[at(OFF_Y, THETA, j)] = theta
        W[at(OFF_Y, RATE, j)] = rate
        W[at(OFF_Y, XG, j)] = x
        W[at(OFF_Y, VXG, j)] = vx
