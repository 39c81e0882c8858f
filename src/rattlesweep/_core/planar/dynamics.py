"""Kernel for the planar rocking semi-ellipse (docs/model.md: the planar rocking
semi-ellipse), on the 3-D engine's plan.

The lamina x²/a² + y²/b² ≤ 1, y ≤ 0 (body frame, y up, origin C at the centre of the flat
edge) rocks on the line Y = 0 by the angle θ (counter-clockwise, rad). G lies d below C.
With σ(θ) = √(a² sin²θ + b² cos²θ):

* contact point, body frame from C: (−a² sin θ, −b² cos θ)/σ, on the curved part while
  |θ| < π/2 (its y is −b² cos θ/σ < 0); |θ| reaching π/2 puts the corner of the flat edge
  on the floor: status ``capsized``;
* height of G: h = σ − d cos θ; contact point from G, world: (−h′, −h);
  h′ = (a² − b²) sin θ cos θ/σ + d sin θ and h + h″ = a²b²/σ³ (the radius of curvature
  at the contact point), which is how h″ is evaluated;
* slip velocity of the material contact point u = ẋ_G + θ̇ h (its vertical velocity,
  ẏ_G − θ̇ h′, vanishes because y_G = h(θ)).

Newton (ẍ_G = F/m, m(h′θ̈ + h″θ̇²) = N − m g) and Euler about G (I θ̈ = −h′ N + h F) give

* stick (u ≡ 0): θ̈ = −m h′ (g + (h + h″) θ̇²)/(I + m(h² + h′²)), F = −m(h θ̈ + h′ θ̇²);
* slip (F = −μ_k N s, s = sgn u): with k = h′ + μ_k s h,
  θ̈ = −k N₀/(I + m h′ k), N₀ = m(g + h″ θ̇²);
* in both modes N = N₀ + m h′ θ̈.

When I + m h′ k ≤ 0 in slip (the Painlevé paradox; homogeneous bodies need μ_k above
about 1.1 for it, a small explicit inertia less) no contact force is consistent: N comes
out negative and the lane stops as ``lifted_off``.

The time loop, the switching rules and the layout of the shared rows are the 3-D
model's (:mod:`..stepper`, :mod:`..switching`, :mod:`..workspace`); horizontal vectors of
the shared rows have a zero Y component here. Its switches are located inside the step
(:mod:`..events`); a re-stick is the plastic impulse of :func:`contact_impulse`, which
removes the residual slip a located stop leaves. The first stage also gives the time
until the slip stops at its present deceleration, u / (−u̇) with
u̇ = ẍ_G + θ̈ h + θ̇² h′, from which stops are found.

One planar specialisation: the slip direction s (the shared row S_UHX) is held through
a step with the mode (it is sgn u at the step start, or −sgn F at a slip onset). In 3-D
the direction u/|u| turns continuously and is re-read at every stage; on a line it only
changes when u passes through zero, which is the stop itself, where the located
switching takes over.
"""

from __future__ import annotations

import math

import numba

from ..jit import kernel
from ..stages import first_stage, put_derivative
from ..switching import stop_time
from ..workspace import (
    BLOCK,
    COUPLES,
    EPS_U,
    GRAV,
    MU_K,
    MU_ROLL,
    OFF_P,
    OFF_S,
    OFF_X,
    S_MODE,
    S_ROLL,
    S_ROLL_SENSE,
    S_UHX,
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
from .layout import (
    A2,
    AB2,
    B2,
    DEPTH,
    INERTIA,
    MASS,
    OFF_A,
    OFF_B,
    OFF_T,
    OFF_Y,
    RATE,
    THETA,
    VXG,
    XG,
)

__all__ = ["contact_impulse", "energy", "eval_block", "shape"]


@kernel
def shape(a2, b2, ab2, d, theta):
    """(h, h′, h + h″) at θ: height of G (m), its derivative (m/rad) and the radius of
    curvature at the contact point (m)."""
    s = math.sin(theta)
    c = math.cos(theta)
    sigma = math.sqrt(a2 * s * s + b2 * c * c)
    h = sigma - d * c
    hp = (a2 - b2) * s * c / sigma + d * s
    return h, hp, ab2 / (sigma * sigma * sigma)


@kernel
def energy(m, inertia, g, h, hp, rate, vx):
    """Mechanical energy (J): translation of G (ẏ_G = h′θ̇), rotation about G, gravity
    with the floor as zero."""
    vy = hp * rate
    return 0.5 * m * (vx * vx + vy * vy) + 0.5 * inertia * rate * rate + m * g * h


@kernel
def contact_impulse(m, inertia, h, hp, u):
    """Changes (Δẋ_G, Δθ̇) of a perfectly plastic impulse that stops the material contact
    point (slip velocity u, m/s).

    A horizontal impulse J at P turns the body by h J about G, and changing θ̇ changes
    ẏ_G = h′θ̇, which takes a normal impulse m h′ Δθ̇ (it does no work: P has no vertical
    velocity). So Δθ̇ = h J/(I + m h′²), Δẋ_G = J/m and Δu = J (1/m + h²/(I + m h′²)),
    giving J = −u/(1/m + h²/(I + m h′²)) and an energy change −u²/(2(1/m + h²/(I + m h′²)))
    that is never positive. (Without the normal impulse, i.e. with I alone, the vertical
    kinetic energy of G would change to first order in J and could grow.)
    """
    eff = inertia + m * hp * hp
    imp = -u / (1.0 / m + h * h / eff)
    return imp / m, h * imp / eff


@kernel
def eval_block(W, slip_possible, stage, one_lane, lane):
    """Time derivative of every lane, used as ``stage`` asks (:mod:`..stages`), with the
    contact outputs N, F and u (region X) at the first stages; reads each lane's mode and
    held slip direction (region S). ``slip_possible`` matters only as ``COUPLES``, which
    adds the rolling couple (docs/model.md: dynamics, the couples): this model's loop is
    short and computes both sliding modes' terms anyway.

    Stick: θ̈ = −m h′(g + (h + h″)θ̇²)/(I + m(h² + h′²)), F = −m(h θ̈ + h′θ̇²).
    Slip:  θ̈ = −k N₀/(I + m h′ k), k = h′ + μ_k s h, N₀ = m(g + h″θ̇²), F = −μ_k s N.
    Both:  N = N₀ + m h′ θ̈, ẍ_G = F/m.
    Rolling resistance (``COUPLES``): a slipping couple −c N, c = μ_roll r (r the held
    sense of θ̇), adds c to the lever of N (k + c in slip, h′ + c in stick); a stuck one
    holds θ̈ = 0 with the couple h′N − hF.
    """
    numba.literally(one_lane)
    state = OFF_Y if first_stage(stage) else OFF_T
    first, stop = lane_range(one_lane, lane)
    for j in range(first, stop):
        theta = W[at(state, THETA, j)]
        rate = W[at(state, RATE, j)]
        vx = W[at(state, VXG, j)]
        m = W[at(OFF_P, MASS, j)]
        inertia = W[at(OFF_P, INERTIA, j)]
        g = W[at(OFF_P, GRAV, j)]
        h, hp, rho = shape(
            W[at(OFF_P, A2, j)],
            W[at(OFF_P, B2, j)],
            W[at(OFF_P, AB2, j)],
            W[at(OFF_P, DEPTH, j)],
            theta,
        )
        w2 = rate * rate
        slip = W[at(OFF_S, S_MODE, j)] > 0.5
        sgn = W[at(OFF_S, S_UHX, j)]  # slip direction, held through the step
        mu = W[at(OFF_P, MU_K, j)] if slip else 0.0  # a stick lane may carry mu = inf
        n_free = m * (g + (rho - h) * w2)  # m(g + h″θ̇²)
        # rolling resistance: a couple −c N while the rocking slips (c = μ_roll times its
        # held sense), which adds c to the lever arm h′ of N; a stuck one holds θ̈ = 0
        mu_roll = W[at(OFF_P, MU_ROLL, j)] if slip_possible == COUPLES else 0.0
        # (without rolling resistance there is nothing to stick)
        roll_slips = (W[at(OFF_S, S_ROLL, j)] > 0.5) | (mu_roll == 0.0)
        c = mu_roll * W[at(OFF_S, S_ROLL_SENSE, j)] if roll_slips else 0.0
        if slip:
            k = hp + mu * sgn * h
            alpha = -k * n_free / (inertia + m * hp * k)
            with_couple = -(k + c) * n_free / (inertia + m * hp * (k + c))
        else:
            alpha = -m * hp * (g + rho * w2) / (inertia + m * (h * h + hp * hp))
            with_couple = -(m * hp * (g + rho * w2) + c * n_free) / (
                inertia + m * (h * h + hp * hp) + m * hp * c
            )
        alpha = alpha if c == 0.0 else with_couple
        alpha = alpha if roll_slips else 0.0
        normal = n_free + m * hp * alpha
        if slip:
            force = -mu * sgn * normal
        else:
            force = -m * (alpha * h + hp * w2)  # keeps u̇ = ẍ_G + θ̈ h + θ̇² h′ = 0
        # the couple: −c N while slipping; while stuck, what I θ̈ = 0 needs
        couple = -c * normal if roll_slips else hp * normal - h * force
        if first_stage(stage):
            u = vx + rate * h
            W[at(OFF_X, X_N, j)] = normal
            W[at(OFF_X, X_FX, j)] = force
            W[at(OFF_X, X_FY, j)] = 0.0
            W[at(OFF_X, X_UX, j)] = u
            W[at(OFF_X, X_UY, j)] = 0.0
            # u̇ = ẍ_G + θ̈ h + θ̇² h′ (zero while sticking)
            du = force / m + alpha * h + w2 * hp if slip else 0.0
            W[at(OFF_X, X_TSTOP, j)] = stop_time(
                u, 0.0, du, 0.0, sgn, 0.0, W[at(OFF_P, EPS_U, j)]
            )
            if slip_possible == COUPLES:
                event = (
                    W[at(OFF_S, S_ROLL_SENSE, j)] * rate
                    if roll_slips
                    else mu_roll * normal - abs(couple)
                )
                W[at(OFF_X, X_ROLL_EVENT, j)] = event if mu_roll > 0.0 else math.inf
                W[at(OFF_X, X_ROLL_COUPLE, j)] = couple
                W[at(OFF_X, X_SPIN_EVENT, j)] = math.inf
                W[at(OFF_X, X_SPIN_COUPLE, j)] = 0.0
        put_derivative(
            W, j, THETA * BLOCK + j, stage, rate, True, OFF_Y, OFF_T, OFF_A, OFF_B
        )
        put_derivative(
            W, j, RATE * BLOCK + j, stage, alpha, True, OFF_Y, OFF_T, OFF_A, OFF_B
        )
        put_derivative(W, j, XG * BLOCK + j, stage, vx, False, OFF_Y, OFF_T, OFF_A, OFF_B)
        put_derivative(
            W, j, VXG * BLOCK + j, stage, force / m, True, OFF_Y, OFF_T, OFF_A, OFF_B
        )
