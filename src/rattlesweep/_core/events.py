"""Stick/slip switches located inside the step (docs/model.md: dynamics): the scalar path of
the few lanes whose contact mode changes.

The vector RK4 step holds every lane's mode through the step; afterwards
:func:`.switching.flag_switches` marks the lanes that may have switched inside it, and
:func:`locate_marked` redoes each marked lane's step alone, from the state before it
(region B), locating every switch:

* scalar events: a sticking contact's friction leaving the cone, and each couple's
  switch (docs/model.md: dynamics, the couples: a slipping couple's held sense times its
  rate reaching zero, a stuck couple's demand reaching its bound). Each motion is smooth
  through its switching instant, so a piece of the step integrated in the present modes is a
  smooth continuation of it. The cubic Hermite interpolant of the piece (its end
  states and derivatives) is accurate to O(h⁴), one order below RK4's local error; the
  first root of the smallest switching function along it (:func:`event_margin`),
  found by the Illinois variant of regula falsi (one evaluation per iterate, to a step
  fraction of ``THETA_TOL``) and taken just past the crossing, is the switching instant
  of the event whose function that is;
* slip → stick: a slip stops where the 2-vector u reaches zero; past that instant a 3-D
  held step is no continuation of the slip (the friction turns with u), so the slip is
  integrated forward to its stop instead, in either model, from the slipping side: the
  first step is the predicted time to stop, |u|² / (−u · u̇) (Newton's method on the
  slip speed), the later ones the secant of the predictions towards their zero
  (:func:`stop_step`: a slip that fades out at the edge of the friction cone has a
  multiple zero, at which Newton's method converges only linearly), until the
  prediction is below ``STOP_TOL`` of the step, or the slip creeps
  (:func:`creeps`). The plastic impulse then removes the residual slip (what the
  located instant leaves: it is reported in the record), and the cone is checked at
  once.

The step is integrated as pieces in time order (an RK4 step to the predicted stop of
a slip that stops inside the step, else to the step's end); after each switch the rest
of the step continues in the new modes, and further switches are located the same way,
up to ``MAX_SWITCHES`` per step. Every evaluation runs the models'
right-hand side on the one lane (``one_lane``), from the same source as the vector
passes. The lane's fraction of the step spent slipping goes into its slip tally. Should
the located state be unusable (not finite, or capsized), the lane keeps the held step.
"""

from __future__ import annotations

import math

import numba
from numba import types
from numba.extending import overload

from . import models
from .jit import OVERLOAD_OPTIONS, inline_kernel, kernel
from .stages import set_mid_stage, set_step_fractions
from .switching import cone_margin, couple_margin, note_slip, start_slip, switch_couples
from .workspace import (
    BLOCK,
    DT,
    EPS_U,
    H_HALF_DT,
    K_MARK_SWITCH,
    K_SLIP_STEPS,
    NOT_MARKED,
    OFF_H,
    OFF_K,
    OFF_P,
    OFF_S,
    OFF_X,
    ROLL_SWITCHES,
    S_JX,
    S_JY,
    S_MODE,
    S_ROLL,
    S_ROLL_SENSE,
    S_SPIN,
    S_SPIN_SENSE,
    SPIN_SWITCHES,
    STAGE_4,
    STAGE_MID,
    STAGE_START,
    SWITCHES,
    X_N,
    X_ROLL_EVENT,
    X_SPIN_EVENT,
    X_TSTOP,
    X_UX,
    X_UY,
    at,
)

__all__ = [
    "LOCATE_ROWS",
    "MAX_SWITCHES",
    "STOP_TOL",
    "THETA_TOL",
    "locate_marked",
    "locate_where_located",
    "located",
    "stick_lane",
    "switch_marked",
]

THETA_TOL = 1e-10
"""Convergence of the located instant, as a fraction of the (rest of the) step."""

STOP_TOL = 1e-10
"""A slip predicted to stop within this fraction of the step has stopped: the plastic
impulse removes the slip velocity left, of order this fraction times dt |u̇|."""

MAX_ITERATIONS = 40
"""Bound on the iterations locating one switch (they converge in a handful)."""

CREEP_SPEED = 100.0
"""A slip slower than this many slip speed floors (``EPS_U``, 1e-6 g dt) whose predicted
stop stops coming closer has stopped (:func:`creeps`)."""

MAX_ORDER = 4.0
"""Largest order p of a slip speed's zero, ∝ (t* − t)^p, that :func:`stop_step` assumes."""

MAX_SWITCHES = 4
"""Switches located inside one step of one lane; a further one waits for the step end."""

MAX_PIECES = MAX_ITERATIONS * (MAX_SWITCHES + 1)
"""Bound on the pieces (RK4 steps between switches or towards a stop) of one step."""

Y0, F0, Y1, F1, HELD = range(5)
LOCATE_ROWS = 5
"""Rows of the per-block scratch array of :func:`locate_marked` (each ``n_state`` long):
the ends of an interval and their derivatives, and the held step's result."""


@kernel
def evaluate_lane(W, model, level, j):
    """Evaluate lane j alone at its state Y in its current mode, at the friction level
    ``level`` (a literal): derivative in A, contact outputs in X."""
    numba.literally(model)
    numba.literally(level)
    models.evaluate(W, model, level, STAGE_START, True, j)


@kernel
def rk4_lane(W, model, level, j):
    """The three inner RK4 stages of lane j alone, after :func:`evaluate_lane`: Y becomes
    the state one (lane) step later, B the state before."""
    numba.literally(model)
    numba.literally(level)
    set_mid_stage(W, False, True, j)
    models.evaluate(W, model, level, STAGE_MID, True, j)
    set_mid_stage(W, True, True, j)
    models.evaluate(W, model, level, STAGE_MID, True, j)
    models.evaluate(W, model, level, STAGE_4, True, j)


@kernel
def set_lane_step(W, j, h):
    """Lane j's time step (and its fractions) set to h, s."""
    W[at(OFF_P, DT, j)] = h
    set_step_fractions(W, j)


@kernel
def interpolate(W, model, j, buf, theta, h):
    """Lane j's state Y at the fraction θ of an interval of length h (s), from the cubic
    Hermite interpolant of its ends and derivatives in ``buf``."""
    numba.literally(model)
    off_y, _, _, _, n_state, _ = models.state_regions(model)
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = (t3 - 2.0 * t2 + theta) * h
    h01 = 3.0 * t2 - 2.0 * t3
    h11 = (t3 - t2) * h
    for k in range(n_state):
        W[at(off_y, k, j)] = (
            h00 * buf[Y0, k] + h10 * buf[F0, k] + h01 * buf[Y1, k] + h11 * buf[F1, k]
        )


@kernel
def copy_state(W, model, j, buf, row, off):
    """buf[row] = lane j's state rows of the region at ``off``."""
    numba.literally(model)
    n_state = models.state_regions(model)[4]
    for k in range(n_state):
        buf[row, k] = W[at(off, k, j)]


@kernel
def load_state(W, model, j, buf, row, off):
    """Lane j's state rows of the region at ``off`` = buf[row] (:func:`copy_state`
    undone)."""
    numba.literally(model)
    n_state = models.state_regions(model)[4]
    for k in range(n_state):
        W[at(off, k, j)] = buf[row, k]


@kernel
def begin_lane_step(W, model, j, h):
    """Make lane j, evaluated at its state (derivative in A), ready for the inner RK4
    stages of a step of length h (s): its step fractions and first stage state."""
    numba.literally(model)
    off_y, off_t, off_a, _, n_state, _ = models.state_regions(model)
    set_lane_step(W, j, h)
    for k in range(n_state):
        W[at(off_t, k, j)] = (
            W[at(off_y, k, j)] + W[at(OFF_H, H_HALF_DT, j)] * W[at(off_a, k, j)]
        )


@kernel
def lane_step(W, model, level, j, h):
    """One RK4 step of length h (s) of lane j alone, in its mode, from its evaluated
    state; leaves the new state evaluated (with the step fractions of h)."""
    numba.literally(model)
    numba.literally(level)
    begin_lane_step(W, model, j, h)
    rk4_lane(W, model, level, j)
    evaluate_lane(W, model, level, j)


@kernel
def event_margin(W, j):
    """The smallest switching function of lane j's scalar events, from an evaluation at
    its state: the cone margin of a sticking contact (N ≥ 0) and each couple's
    (:func:`.switching.couple_margin`); inf when none applies. Its first root in a step
    is the first of their switches."""
    sticks = (W[at(OFF_S, S_MODE, j)] < 0.5) & (W[at(OFF_X, X_N, j)] >= 0.0)
    return min(cone_margin(W, j) if sticks else math.inf, couple_margin(W, j))


@kernel
def switch_event(W, j):
    """At a root of :func:`event_margin`, switch the event whose function is the
    smallest: the one that crossed zero."""
    sticks = (W[at(OFF_S, S_MODE, j)] < 0.5) & (W[at(OFF_X, X_N, j)] >= 0.0)
    cone = cone_margin(W, j) if sticks else math.inf
    spin = W[at(OFF_X, X_SPIN_EVENT, j)]
    roll = W[at(OFF_X, X_ROLL_EVENT, j)]
    if cone <= spin and cone <= roll:
        start_slip(W, j)
    elif spin <= roll:
        switch_couples(W, j, SPIN_SWITCHES)
    else:
        switch_couples(W, j, ROLL_SWITCHES)


@kernel
def event_root(W, model, level, j, buf, h, g0, g1):
    """The fraction θ* of the interval (length h, s) in ``buf`` at which lane j's
    :func:`event_margin`, g0 at its start and g1 < 0 at its end, crosses zero, taken
    just past the crossing (by ``2 THETA_TOL`` where the last iterate fell short); leaves
    the lane at y(θ*), evaluated. θ* = 0 when the margin is not positive at the start."""
    numba.literally(model)
    numba.literally(level)
    if not g0 > 0.0:
        interpolate(W, model, j, buf, 0.0, h)
        evaluate_lane(W, model, level, j)
        return 0.0
    lo, g_lo, hi, g_hi = 0.0, g0, 1.0, g1
    theta = 1.0
    side = 0
    for _ in range(MAX_ITERATIONS):
        previous = theta
        theta = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        interpolate(W, model, j, buf, theta, h)
        evaluate_lane(W, model, level, j)
        g = event_margin(W, j)
        if g >= 0.0:
            lo, g_lo = theta, g
            if side == 1:  # Illinois: halve the stale end's value
                g_hi *= 0.5
            side = 1
        else:
            hi, g_hi = theta, g
            if side == -1:
                g_lo *= 0.5
            side = -1
        if abs(theta - previous) <= THETA_TOL or hi - lo <= THETA_TOL:
            break
    if side == 1:  # switch just past the crossing, where the new mode is the consistent one
        theta = min(hi, theta + 2.0 * THETA_TOL)
        interpolate(W, model, j, buf, theta, h)
        evaluate_lane(W, model, level, j)
    return theta


@kernel
def forward_to_stop(W, model, level, j, buf, t_stop, step, dt):
    """Step slipping lane j, evaluated, forward by ``step`` (s) towards its stop, which
    its evaluation predicts t_stop (s) ahead (:func:`stop_step`). Past the stop (the
    slip velocity turned against its value before), the step is taken again, shortened
    to where the slip velocity's component along its value before crosses zero (linear
    in between). Returns (whether the slip has stopped, the step taken, s); a slip
    predicted to stop within ``STOP_TOL`` of the lane's step dt (s) has stopped, without
    a step."""
    numba.literally(model)
    numba.literally(level)
    if t_stop <= STOP_TOL * dt:  # stopped: the plastic impulse removes what is left
        return True, 0.0
    off_y, _, off_a, _, _, _ = models.state_regions(model)
    copy_state(W, model, j, buf, Y0, off_y)
    copy_state(W, model, j, buf, F0, off_a)
    ux = W[at(OFF_X, X_UX, j)]
    uy = W[at(OFF_X, X_UY, j)]
    lane_step(W, model, level, j, step)
    g_before = ux * ux + uy * uy
    g_after = W[at(OFF_X, X_UX, j)] * ux + W[at(OFF_X, X_UY, j)] * uy
    if g_after >= 0.0:
        return False, step
    step = step * g_before / (g_before - g_after)
    load_state(W, model, j, buf, Y0, off_y)
    load_state(W, model, j, buf, F0, off_a)
    lane_step(W, model, level, j, step)
    return True, step


@inline_kernel
def stop_step(t, t_stop, t_seen, t_stop_seen, rest):
    """The step (s) towards a slip's stop from the time t (s) into the step at which it
    is predicted t_stop (s) ahead, given the prediction t_stop_seen at the time t_seen of
    the last step towards it (t_seen < 0: none), at most the rest of the step.

    The prediction |u|² / (−u · u̇) is exact for a slip speed linear in the time to its
    stop, but only the share 1/p of it for a speed ∝ (t* − t)^p, as where the slip fades
    out at the edge of the friction cone (p near 2): Newton's method at a multiple root,
    whose steps shrink by the ratio 1 − 1/p only. The prediction itself falls linearly
    to zero, as (t* − t)/p, so the step is the secant of the last two towards its zero:
    p t_stop with p = (t − t_seen)/(t_stop_seen − t_stop) between 1 and ``MAX_ORDER``."""
    order = 1.0
    if t_seen >= 0.0 and t_stop_seen > t_stop:
        order = min(max((t - t_seen) / (t_stop_seen - t_stop), 1.0), MAX_ORDER)
    return min(order * t_stop, rest)


@inline_kernel
def creeps(W, j, t_stop_before):
    """Whether slipping lane j, after a step towards its stop predicted t_stop_before (s)
    ahead, creeps: slower than ``CREEP_SPEED`` slip speed floors and still decelerating,
    but its predicted stop did not come at least twice as close. Such a slip is at the
    edge of the friction cone, where the slip acceleration vanishes with the speed, and
    would take ever shorter steps without reaching zero; it has stopped (the cone check
    that follows a stop restarts it at once if the cone cannot hold it)."""
    ux = W[at(OFF_X, X_UX, j)]
    uy = W[at(OFF_X, X_UY, j)]
    t_stop = W[at(OFF_X, X_TSTOP, j)]
    slow = ux * ux + uy * uy <= (CREEP_SPEED * W[at(OFF_P, EPS_U, j)]) ** 2
    return slow & (t_stop < math.inf) & (t_stop > 0.5 * t_stop_before)


@kernel
def stick_lane(W, model, j):
    """Slip → stick: a plastic contact impulse brings lane j's contact point to rest (from
    the slip velocity in region X). The impulse is friction too, and is kept for the
    record."""
    numba.literally(model)
    W[at(OFF_S, S_MODE, j)] = 0.0
    jx, jy = models.stick_impulse(W, model, j)
    W[at(OFF_S, S_JX, j)] += jx
    W[at(OFF_S, S_JY, j)] += jy


@kernel
def switch_marked(W, model):
    """Change the modes of every marked lane at the step start: for its sliding, a
    slipping lane sticks (:func:`stick_lane`) and a sticking one starts to slip
    (:func:`.switching.start_slip`); its marked couples switch
    (:func:`.switching.switch_couples`)."""
    numba.literally(model)
    for j in range(BLOCK):
        mark = W[at(OFF_K, K_MARK_SWITCH, j)]
        if mark != NOT_MARKED:
            if mark % SPIN_SWITCHES == SWITCHES:
                if W[at(OFF_S, S_MODE, j)] > 0.5:
                    stick_lane(W, model, j)
                else:
                    start_slip(W, j)
            switch_couples(W, j, mark - mark % SPIN_SWITCHES)
            if mark >= SPIN_SWITCHES:
                models.stick_couples(W, model, j)


@kernel
def locate_lane(W, model, level, j, buf, dt):
    """Redo lane j's last step (length dt, s) with its switches located (see the module
    docstring). On entry: the state before the step in B, the held step's state in Y,
    its first stage for the next step in A and contact outputs in X; on exit the same
    for the located step."""
    numba.literally(model)
    numba.literally(level)
    off_y, _, off_a, off_b, _, _ = models.state_regions(model)
    modes = (
        W[at(OFF_S, S_MODE, j)],
        W[at(OFF_S, S_SPIN, j)],
        W[at(OFF_S, S_SPIN_SENSE, j)],
        W[at(OFF_S, S_ROLL, j)],
        W[at(OFF_S, S_ROLL_SENSE, j)],
    )
    copy_state(W, model, j, buf, HELD, off_y)
    copy_state(W, model, j, buf, Y0, off_b)
    load_state(W, model, j, buf, Y0, off_y)  # back to the step start
    evaluate_lane(W, model, level, j)

    t = 0.0  # time into the step, s
    slip_time = 0.0  # time spent slipping, s
    switches = 0
    t_seen = -1.0  # time of the last step towards the present slip's stop, s (-1: none)
    t_stop_seen = 0.0  # its predicted stop then, s
    for _ in range(MAX_PIECES):
        rest = dt - t
        if not rest > THETA_TOL * dt:
            break
        slipping = W[at(OFF_S, S_MODE, j)] > 0.5
        # the next piece: to the predicted stop of a slip that stops in the step, else to
        # the step's end
        copy_state(W, model, j, buf, Y0, off_y)
        copy_state(W, model, j, buf, F0, off_a)
        g0 = event_margin(W, j)
        stops = False
        t_stop = W[at(OFF_X, X_TSTOP, j)]
        if switches < MAX_SWITCHES and slipping and t_stop < rest:
            stops, step = forward_to_stop(
                W,
                model,
                level,
                j,
                buf,
                t_stop,
                stop_step(t, t_stop, t_seen, t_stop_seen, rest),
                dt,
            )
            stops = stops or creeps(W, j, t_stop)
            t_seen = t
            t_stop_seen = t_stop
        else:
            lane_step(W, model, level, j, rest)
            step = rest
        g1 = event_margin(W, j)
        if (
            switches < MAX_SWITCHES and g1 < 0.0
        ):  # a stick → slip or a couple switched first
            copy_state(W, model, j, buf, Y1, off_y)
            copy_state(W, model, j, buf, F1, off_a)
            theta = event_root(W, model, level, j, buf, step, g0, g1)
            t += theta * step
            slip_time += theta * step if slipping else 0.0
            roll = W[at(OFF_S, S_ROLL, j)]
            spin = W[at(OFF_S, S_SPIN, j)]
            switch_event(W, j)
            if W[at(OFF_S, S_ROLL, j)] != roll or W[at(OFF_S, S_SPIN, j)] != spin:
                models.stick_couples(W, model, j)
            evaluate_lane(W, model, level, j)
            switches += 1
            t_seen = -1.0
            continue
        t += step
        slip_time += step if slipping else 0.0
        if stops:
            t_seen = -1.0
            stick_lane(W, model, j)
            evaluate_lane(W, model, level, j)
            switches += 1
            if cone_margin(W, j) < 0.0:  # slips on at once, in the new direction
                start_slip(W, j)
                evaluate_lane(W, model, level, j)
    if t < dt and dt - t > THETA_TOL * dt:  # out of pieces: the rest in the present modes
        slip_time += (dt - t) * W[at(OFF_S, S_MODE, j)]
        lane_step(W, model, level, j, dt - t)

    bad_value, capsized = models.check_step(W, model, j)  # renormalises the quaternion
    if bad_value or capsized:  # keep the held step
        load_state(W, model, j, buf, HELD, off_y)
        W[at(OFF_S, S_MODE, j)] = modes[0]
        W[at(OFF_S, S_SPIN, j)] = modes[1]
        W[at(OFF_S, S_SPIN_SENSE, j)] = modes[2]
        W[at(OFF_S, S_ROLL, j)] = modes[3]
        W[at(OFF_S, S_ROLL_SENSE, j)] = modes[4]
        slip_time = modes[0] * dt
        evaluate_lane(W, model, level, j)
    # ready for the next step: its first stage is the evaluation at the end of this one
    begin_lane_step(W, model, j, dt)
    if W[at(OFF_S, S_MODE, j)] > 0.5:
        note_slip(W, j)
    # the step's slipping fraction; the observation of the step adds the final mode
    W[at(OFF_K, K_SLIP_STEPS, j)] += slip_time / dt - W[at(OFF_S, S_MODE, j)]


@kernel
def locate_marked(W, model, level, buf):
    """Redo the last step of every lane marked by :func:`.switching.flag_switches`, with
    its switches located."""
    numba.literally(model)
    numba.literally(level)
    for j in range(BLOCK):
        if W[at(OFF_K, K_MARK_SWITCH, j)] != NOT_MARKED:
            locate_lane(W, model, level, j, buf, W[at(OFF_P, DT, j)])


def locate_where_located(W, model, level, buf):
    """:func:`locate_marked` for a model that locates its switches
    (:func:`.models.locates_switches`); for another, nothing, and nothing of this
    module is compiled into its stepper."""


@overload(locate_where_located, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _locate_where_located(W, model, level, buf):
    if isinstance(model, types.IntegerLiteral) and models.locates_switches(
        model.literal_value
    ):
        return lambda W, model, level, buf: locate_marked(W, model, level, buf)
    return lambda W, model, level, buf: None


def located(model):
    """:func:`.models.locates_switches` of a literal model, inside a kernel."""


@overload(located, prefer_literal=True, inline="always", jit_options=OVERLOAD_OPTIONS)
def _located(model):
    if not isinstance(model, types.IntegerLiteral):
        raise numba.core.errors.TypingError("the model must be a literal integer")
    if models.locates_switches(model.literal_value):
        return lambda model: True
    return lambda model: False
