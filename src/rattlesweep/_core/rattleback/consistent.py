"""The consistent slip direction d* of a slow slip (docs/model.md: dynamics), solved for by
:func:`.slip.slip_direction`: one lane at a time (:func:`consistent_direction`), or every
lane of the block in one branch-free pass (:func:`block_directions`) where enough of
them slip slowly for the vector arithmetic to pay. Both forms run the same operations on
each lane, so a lane's d* does not depend on which one solved it, nor on its neighbours.

With friction −μ N d (d a horizontal unit vector, world), the contact point's
acceleration is u̇ = A_h + N (K_hz − μ K_hh d), N = −A_z / (K_zz − μ K_zh · d), where A is
its acceleration without contact force and K (per unit mass, 𝟙 + [ρ]ᵀ J⁻¹ [ρ]) its
response to one, both in the world axes. d* is the direction along which the slip speed
grows or shrinks without turning, u̇ ∥ d*: the root of f(φ) = V(d) × d, V = u̇ / N, in
the angle φ of d, taken only within 60° of the slip's direction and only where f rises
(where d* attracts the slip's direction). f is a trigonometric polynomial of degree two,
so f′ and f″ are a few products more than f: Halley's iteration, from the last step
start's d* turned on at its measured rate, converges in one or two steps.
"""

from __future__ import annotations

import math

from ..jit import inline_kernel, kernel
from ..workspace import (
    DT,
    GRAV,
    MU_K,
    OFF_P,
    OFF_S,
    S_DCX,
    S_DCY,
    S_DPX,
    S_DPY,
    S_TURN,
    S_TURN_BEFORE,
    S_UHX,
    S_UHY,
    at,
    BLOCK,
)
from .contact import horizontal_rows
from .geometry import cross
from .layout import (
    DAMPING_PM,
    DSTAR_SLOPE,
    DSTAR_X,
    DSTAR_Y,
    INV_QQ,
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
    SLIP_X,
    SLIP_Y,
    UP_X,
    UP_Y,
    UP_Z,
    WW_X,
    WW_Y,
    WW_Z,
)

__all__ = [
    "RELAX_STEPS",
    "block_directions",
    "consistent_direction",
    "solve_inputs",
]

RELAX_STEPS = 2.0
"""A slip whose direction relaxes within fewer than ``1 / RELAX_STEPS`` steps is steered
(:func:`.slip.slip_direction`): its relaxation is slowed to this many per step, inside the
interval (−2.79, 0) of the real axis on which classic RK4 is stable."""

ITERATIONS = 5
"""Bound on the iterations for d*; from the guess they stop after one or two."""

assert ITERATIONS >= 2  # block_directions' two steps are the first two of the solve

TOLERANCE = 1e-6
"""The iteration stops after a step (rad) below this: Halley's method converges at third
order, so the error left is of order its cube."""

BOUND_SLACK = 1.0 + 1e-9
"""Margin on :func:`needless`' bound on s for the rounding of its terms."""

SERIES_TURN = 1e-2
"""Below this turn (its tangent a), :func:`turned` normalises by the series of
(x² + y²)^(−1/2) about 1 to its third term (truncation below 1e-16), which spares the
iteration's chain a square root and a division."""


@inline_kernel
def turned(ex, ey, a):
    """The unit vector (ex, ey) turned by the angle arctan(a): (e + a e⊥) / |e + a e⊥|."""
    x = ex - a * ey
    y = ey + a * ex
    if a * a < SERIES_TURN * SERIES_TURN:
        r = x * x + y * y - 1.0  # a² for a unit e, and whatever |e| lost to rounding
        norm = 1.0 - r * (0.5 - r * (0.375 - r * 0.3125))
    else:
        norm = 1.0 / math.sqrt(x * x + y * y)
    return x * norm, y * norm


@inline_kernel
def consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey):
    """(f, f′, f″, D) at the direction (ex, ey): V(d) = a D(d) + K_hz − μ K_hh d with D =
    K_zz − μ K_zh · d (a the free horizontal acceleration over what the normal force
    holds up), f = V × d, and f′, f″ its derivatives along the angle of d (d′ = d⊥ =
    (−e_y, e_x), d″ = −d)."""
    dd = k_zz - mu * (k_xz * ex + k_yz * ey)
    vx = ax * dd + k_xz - mu * (k_xx * ex + k_xy * ey)
    vy = ay * dd + k_yz - mu * (k_xy * ex + k_yy * ey)
    ddd = -mu * (k_yz * ex - k_xz * ey)
    dvx = ax * ddd - mu * (k_xy * ex - k_xx * ey)
    dvy = ay * ddd - mu * (k_yy * ex - k_xy * ey)
    d2d = k_zz - dd
    d2vx = ax * d2d + mu * (k_xx * ex + k_xy * ey)
    d2vy = ay * d2d + mu * (k_xy * ex + k_yy * ey)
    f = vx * ey - vy * ex
    return (
        f,
        (dvx * ey - dvy * ex) + (vx * ex + vy * ey),
        (d2vx * ey - d2vy * ex) + 2.0 * (dvx * ex + dvy * ey) - f,
        dd,
    )


@inline_kernel
def response(W, j, state):
    """Lane j's contact response K (its six entries, per unit mass: 1/kg times kg) and
    free horizontal acceleration over what the normal force holds up, a (two entries,
    dimensionless), at its state in the region at ``state``; and press = −A_z (m/s²), the
    free acceleration the normal force must hold up."""
    q0 = W[at(state, Q0, j)]
    q1 = W[at(state, Q1, j)]
    q2 = W[at(state, Q2, j)]
    q3 = W[at(state, Q3, j)]
    inv_q = W[at(OFF_G, INV_QQ, j)]
    e00, e01, e02, e10, e11, e12 = horizontal_rows(q0, q1, q2, q3)
    x0 = e00 * inv_q  # world x, y and up in body components
    x1 = e01 * inv_q
    x2 = e02 * inv_q
    y0 = e10 * inv_q
    y1 = e11 * inv_q
    y2 = e12 * inv_q
    n0 = W[at(OFF_G, UP_X, j)] * inv_q
    n1 = W[at(OFF_G, UP_Y, j)] * inv_q
    n2 = W[at(OFF_G, UP_Z, j)] * inv_q
    r0 = W[at(OFF_G, RHO_X, j)]
    r1 = W[at(OFF_G, RHO_Y, j)]
    r2 = W[at(OFF_G, RHO_Z, j)]
    kxx = W[at(OFF_E, JI_XX, j)]
    kyy = W[at(OFF_E, JI_YY, j)]
    kzz = W[at(OFF_E, JI_ZZ, j)]
    kxy = W[at(OFF_E, JI_XY, j)]
    kxz = W[at(OFF_E, JI_XZ, j)]
    kyz = W[at(OFF_E, JI_YZ, j)]
    px0, px1, px2 = cross(r0, r1, r2, x0, x1, x2)
    py0, py1, py2 = cross(r0, r1, r2, y0, y1, y2)
    pn0, pn1, pn2 = cross(r0, r1, r2, n0, n1, n2)
    jn0 = kxx * pn0 + kxy * pn1 + kxz * pn2
    jn1 = kxy * pn0 + kyy * pn1 + kyz * pn2
    jn2 = kxz * pn0 + kyz * pn1 + kzz * pn2
    jy0 = kxx * py0 + kxy * py1 + kxz * py2
    jy1 = kxy * py0 + kyy * py1 + kyz * py2
    jy2 = kxz * py0 + kyz * py1 + kzz * py2
    k_xx = 1.0 + (
        px0 * (kxx * px0 + kxy * px1 + kxz * px2)
        + px1 * (kxy * px0 + kyy * px1 + kyz * px2)
        + px2 * (kxz * px0 + kyz * px1 + kzz * px2)
    )
    k_yy = 1.0 + (py0 * jy0 + py1 * jy1 + py2 * jy2)
    k_zz = 1.0 + (pn0 * jn0 + pn1 * jn1 + pn2 * jn2)
    k_xy = px0 * jy0 + px1 * jy1 + px2 * jy2
    k_xz = px0 * jn0 + px1 * jn1 + px2 * jn2
    k_yz = py0 * jn0 + py1 * jn1 + py2 * jn2
    # acceleration of the contact point without contact force: −g n̂ + α₀ × ρ + w, with
    # α₀ = J⁻¹(−ω × Jω − (c_v/m) ω)
    w0 = W[at(state, OMEGA_X, j)]
    w1 = W[at(state, OMEGA_Y, j)]
    w2 = W[at(state, OMEGA_Z, j)]
    jxx = W[at(OFF_E, J_XX, j)]
    jyy = W[at(OFF_E, J_YY, j)]
    jzz = W[at(OFF_E, J_ZZ, j)]
    jxy = W[at(OFF_E, J_XY, j)]
    jxz = W[at(OFF_E, J_XZ, j)]
    jyz = W[at(OFF_E, J_YZ, j)]
    cvm = W[at(OFF_E, DAMPING_PM, j)]
    g0, g1, g2 = cross(
        w0,
        w1,
        w2,
        jxx * w0 + jxy * w1 + jxz * w2,
        jxy * w0 + jyy * w1 + jyz * w2,
        jxz * w0 + jyz * w1 + jzz * w2,
    )
    g0 = -g0 - cvm * w0
    g1 = -g1 - cvm * w1
    g2 = -g2 - cvm * w2
    a0, a1, a2 = cross(
        kxx * g0 + kxy * g1 + kxz * g2,
        kxy * g0 + kyy * g1 + kyz * g2,
        kxz * g0 + kyz * g1 + kzz * g2,
        r0,
        r1,
        r2,
    )
    g = W[at(OFF_P, GRAV, j)]
    a0 += W[at(OFF_G, WW_X, j)] - g * n0
    a1 += W[at(OFF_G, WW_Y, j)] - g * n1
    a2 += W[at(OFF_G, WW_Z, j)] - g * n2
    press = -(a0 * n0 + a1 * n1 + a2 * n2)
    ax = (a0 * x0 + a1 * x1 + a2 * x2) / press
    ay = (a0 * y0 + a1 * y1 + a2 * y2) / press
    return k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press


@inline_kernel
def needless(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, wanted):
    """Whether no direction can give an attraction s above ``wanted`` (m/s²): over every
    direction N ≤ press / (K_zz − μ |K_zh|) and |f′| ≤ |V| + |V′|, so then neither can
    the root. ``wanted`` = 0 (d* itself is wanted) never is."""
    k_zh = math.sqrt(k_xz * k_xz + k_yz * k_yz)
    k_hh = math.sqrt(k_xx * k_xx + 2.0 * k_xy * k_xy + k_yy * k_yy)
    lowest = k_zz - mu * k_zh
    bound = (
        press
        / lowest
        * (math.sqrt(ax * ax + ay * ay) * (k_zz + 2.0 * mu * k_zh) + k_zh + 2.0 * mu * k_hh)
    )
    return (wanted > 0.0) & (press > 0.0) & (lowest > 0.0) & (bound * BOUND_SLACK <= wanted)


@inline_kernel
def iterate(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy):
    """One step of the iteration from (ex, ey): the new direction and whether it is the
    last (converged, or out of the cone searched around the slip's direction (dx, dy),
    where no root is taken)."""
    f, df, d2f, _ = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
    # the direction of u turns at a rate ∝ −f: only roots where f rises attract it.
    # Halley's method towards those (Newton's where its correction is large, far from
    # the root); elsewhere the largest step along the turn
    halley = 2.0 * df * df - f * d2f
    use_halley = (df > 0.0) & (halley > df * df) & (halley < 3.0 * df * df)
    # one division for every case
    over = halley if use_halley else (df if df > 0.0 else 1.0)
    step = (
        -2.0 * f * df if use_halley else (-f if df > 0.0 else -0.5 if f > 0.0 else 0.5)
    ) / over
    step = min(max(step, -0.5), 0.5)
    ex, ey = turned(ex, ey, step)
    return ex, ey, (abs(step) < TOLERANCE) | (ex * dx + ey * dy <= 0.5)


@inline_kernel
def settle(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, ex, ey, dx, dy):
    """(d*_x, d*_y, s) at the direction (ex, ey) the iteration reached: s (m/s²) such
    that u's direction relaxes onto d* at the rate s / |u|, N f′(φ*) (the angle φ of u
    turns at the rate −N f(φ) / |u|); (dx, dy, −1) where d* does not attract the slip or
    no consistent slip exists."""
    _, df, _, dd = consistency(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey)
    slope = press / dd * df
    found = (press > 0.0) & (dd > 0.0) & (slope > 0.0) & (ex * dx + ey * dy > 0.5)
    return (ex if found else dx), (ey if found else dy), (slope if found else -1.0)


@inline_kernel
def solve_inputs(W, j, history, ahead):
    """What lane j's solve starts from: (μ, the guess, the slip's direction (dx, dy),
    the attraction wanted, m/s²). The guess is the last step start's d* (at this step's
    start, where the block may be evaluated again, the one before, so that each
    evaluation solves alike), turned on at its turn rate then by ``ahead`` steps; where
    there is none yet (the launch's step), the slip's direction. A step-start
    evaluation (``history``) wants d* itself; any other only an attraction that steers
    (:func:`.slip.slip_direction`)."""
    h = W[at(OFF_P, DT, j)]
    rate = W[at(OFF_S, S_TURN_BEFORE, j)] if history else W[at(OFF_S, S_TURN, j)]
    px = W[at(OFF_S, S_DPX, j)] if history else W[at(OFF_S, S_DCX, j)]
    py = W[at(OFF_S, S_DPY, j)] if history else W[at(OFF_S, S_DCY, j)]
    gx, gy = turned(px, py, min(max(rate * ahead * h, -0.5), 0.5))
    dx = W[at(OFF_S, S_UHX, j)]
    dy = W[at(OFF_S, S_UHY, j)]
    none = px * px + py * py < 0.5
    ux = W[at(OFF_G, SLIP_X, j)]
    uy = W[at(OFF_G, SLIP_Y, j)]
    wanted = 0.0 if history else RELAX_STEPS * math.sqrt(ux * ux + uy * uy) / h
    return (
        W[at(OFF_P, MU_K, j)],
        dx if none else gx,
        dy if none else gy,
        dx,
        dy,
        wanted,
    )


@kernel
def consistent_direction(W, j, state, mu, gx, gy, dx, dy, wanted):
    """Lane j's consistent slip direction at its state in the region at ``state``, from
    the inputs :func:`solve_inputs` gives (taken by value, so that one compiled variant
    serves every evaluation of a state region): (d*_x, d*_y, s) as :func:`settle` gives
    them, or (dx, dy, −1) where the attraction cannot steer and d* is not wanted
    (:func:`needless`)."""
    k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press = response(W, j, state)
    if needless(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, wanted):
        return dx, dy, -1.0
    ex = gx
    ey = gy
    for _ in range(ITERATIONS):
        ex, ey, last = iterate(
            k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy
        )
        if last:
            break
    return settle(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, ex, ey, dx, dy)


@inline_kernel
def masked(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy, done):
    """:func:`iterate` where the lane's iteration has not ended (``done``), else
    nothing: the step of :func:`block_directions`."""
    nx, ny, last = iterate(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy)
    return (ex if done else nx), (ey if done else ny), done | last


@kernel
def block_directions(W, state, history, ahead):
    """:func:`consistent_direction` for every lane of the block, into the rows DSTAR_X,
    DSTAR_Y and DSTAR_SLOPE (meaningless for a lane that does not slip slowly): the
    same operations, with the first two steps written out and each lane's iteration
    ended by a mask rather than a branch, so that LLVM vectorises the pass. A lane whose
    iteration has not ended by then gets DSTAR_SLOPE NaN: its caller solves for it
    alone, as it would have without the pass."""
    for j in range(BLOCK):
        mu, ex, ey, dx, dy, wanted = solve_inputs(W, j, history, ahead)
        k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press = response(W, j, state)
        skip = needless(k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, wanted)
        ex, ey, done = masked(
            k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy, skip
        )
        ex, ey, done = masked(
            k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, mu, ex, ey, dx, dy, done
        )
        cx, cy, slope = settle(
            k_xx, k_yy, k_zz, k_xy, k_xz, k_yz, ax, ay, press, mu, ex, ey, dx, dy
        )
        W[at(OFF_G, DSTAR_X, j)] = dx if skip else cx
        W[at(OFF_G, DSTAR_Y, j)] = dy if skip else cy
        W[at(OFF_G, DSTAR_SLOPE, j)] = -1.0 if skip else (slope if done else math.nan)
