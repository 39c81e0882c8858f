"""The block workspace: the rows every model shares, and how kernels address them.

Every per-trajectory array the kernel sees has shape ``(n_blocks, n_rows, BLOCK)``: the
last axis runs over the ``BLOCK`` lanes (trajectories) of a block, so each row is a
contiguous vector the compiler steps with SIMD instructions. ``BLOCK`` is a compile-time
constant, which gives the lane loops a known trip count (no scalar remainder loop) and
makes a lane's arithmetic independent of its position in the batch.

Inside the time loop a block lives in one flat float64 workspace ``W`` of
``n_work * BLOCK`` elements; row ``r`` of the region at offset ``OFF`` starts at
``(OFF + r) * BLOCK``. With one base pointer and compile-time offsets LLVM can prove that
a store never aliases a later load of another row, so the lane loops vectorise without
runtime alias checks (separate arrays would each need such checks, and LLVM gives up
past a handful). Every kernel addresses the workspace one way: ``W[at(OFF, row, j)]``.

The regions at the start of the workspace have the same rows and offsets in every
model, so that the stepper (:mod:`.stepper`) and the switching rules
(:mod:`.switching`) are written once: contact outputs (X), switching state (S),
time-loop bookkeeping (K), step fractions (H) and the first rows of the parameters (P).
Each model's layout appends its own parameter rows and its regions for derived
parameters, state, stage state, the RK4 accumulator and scratch.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import types
from numba.extending import overload

from .jit import OVERLOAD_OPTIONS
from .rows import Row, Rows, input_row
from ..inputs import INPUTS

__all__ = [
    "BLOCK",
    "at",
    "lane_range",
    "STATUS_NAMES",
    "OK",
    "CAPSIZED",
    "LIFTED_OFF",
    "NON_FINITE",
    "RK4",
    "EULER",
    "METHODS",
    "ROLLING",
    "SLIDING",
    "COUPLES",
    "LEVEL_NAMES",
    "friction_level",
]

BLOCK = 32
"""Lanes per block. A multiple of the SIMD width (4 doubles for AVX2, 8 for AVX-512)."""


def at(region, row, j):
    """Index into the workspace of lane ``j`` of row ``row`` of the region at ``region``."""
    return (region + row) * BLOCK + j


# An overload, not a kernel: a kernel called with constant arguments is compiled once per
# combination of their values (hundreds here), an overload once per argument type.
overload(at, jit_options=OVERLOAD_OPTIONS)(lambda region, row, j: at)


def lane_range(one_lane, lane):
    """(first, stop) of the lanes a pass runs over: every lane of the block, or, when
    ``one_lane`` (a literal), lane ``lane`` alone (the scalar path of a lane whose contact
    mode changes inside a step)."""
    return (lane, lane + 1) if one_lane else (0, BLOCK)


@overload(lane_range, prefer_literal=True, inline="always", jit_options=OVERLOAD_OPTIONS)
def _lane_range(one_lane, lane):
    # chosen while typing, so that a block pass keeps the constant trip count BLOCK
    if isinstance(one_lane, types.BooleanLiteral) and not one_lane.literal_value:
        return lambda one_lane, lane: (0, BLOCK)
    return lambda one_lane, lane: (lane, lane + 1)


# --- statuses and methods ---------------------------------------------------------------
STATUS_NAMES = ("ok", "capsized", "lifted_off", "non_finite")
OK, CAPSIZED, LIFTED_OFF, NON_FINITE = range(4)

METHODS = ("rk4", "euler")
RK4, EULER = range(2)

# --- the RK4 stages of one right-hand-side evaluation (see stages.put_derivative) ------
STAGE_START = 0  # step-start state, every contact output
STAGE_FIRST = 1  # step-start state, the normal force only
STAGE_MID = 2  # the second or third stage: the stage state's fraction of dt in H_STAGE_DT
STAGE_4 = 3

# --- friction levels -------------------------------------------------------------------
# The contact work an evaluation does, as its literal ``slip_possible`` flag; and, as a
# literal argument of the stepper's entry points, the most a batch needs: only the
# variants up to it are compiled.
ROLLING = 0
"""Every lane rolls (sticks): no slip work, no switching (infinite static friction)."""
SLIDING = 1
"""Coulomb stick/slip of the contact point (finite static friction)."""
COUPLES = 2
"""Stick/slip plus the spin and rolling couples (docs/model.md: dynamics, the couples)."""
LEVEL_NAMES = ("rolling", "sliding", "couples")


def friction_level(mu_static: Any, mu_spin: Any, mu_roll: Any) -> int:
    """The friction level a batch of launches with these coefficients needs (arrays or
    numbers): COUPLES where some launch has a couple, SLIDING where some static friction
    is finite (or not a number), else ROLLING."""
    if np.any(np.asarray(mu_spin) > 0.0) or np.any(np.asarray(mu_roll) > 0.0):
        return COUPLES
    return SLIDING if np.any(~(np.asarray(mu_static) == math.inf)) else ROLLING


# --- contact outputs of an evaluation at the step-start state, rows of region X --------
# Horizontal vectors are world (X, Y); a planar model leaves the Y components zero.
CONTACT = Rows(
    "contact outputs",
    Row("normal_force", "N", "normal contact force"),
    Row("friction_force", "N", "horizontal friction force on the body", 2, "horizontal"),
    Row(
        "slip_velocity",
        "m s-1",
        "horizontal velocity of the material contact point",
        2,
        "horizontal",
    ),
    Row(
        "stop_time",
        "s",
        "time until a slip stops at its present deceleration (inf when "
        "it does not decelerate, or sticks)",
    ),
    Row(
        "spin_event",
        "1",
        "switching function of the spin couple: its sense times the "
        "spin about the normal while it slips (rad/s), mu_spin N less the couple's "
        "magnitude while it sticks (N m); inf without spin friction",
    ),
    Row("roll_event", "1", "switching function of the rolling couple, as spin_event"),
    Row("spin_couple", "N m", "spin friction couple about the contact normal"),
    Row(
        "roll_couple",
        "N m",
        "rolling resistance couple (planar: about the axis of rocking)",
    ),
    Row(
        "consistent_direction_now",
        "1",
        "a slipping lane's consistent slip direction "
        "at the evaluated state (unit; 3-D model, step-start evaluations of the block)",
        2,
        "horizontal",
    ),
    Row(
        "consistent_turn_now",
        "rad s-1",
        "the rate at which it turned since the step "
        "before (3-D model, as consistent_direction_now)",
    ),
)
X_N = CONTACT.start("normal_force")
X_FX = CONTACT.start("friction_force")
X_FY = X_FX + 1
X_UX = CONTACT.start("slip_velocity")
X_UY = X_UX + 1
X_TSTOP = CONTACT.start("stop_time")
X_SPIN_EVENT = CONTACT.start("spin_event")
X_ROLL_EVENT = CONTACT.start("roll_event")
X_SPIN_COUPLE = CONTACT.start("spin_couple")
X_ROLL_COUPLE = CONTACT.start("roll_couple")
X_DCX = CONTACT.start("consistent_direction_now")
X_DCY = X_DCX + 1
X_TURN = CONTACT.start("consistent_turn_now")

# --- switching state of each lane, rows of region S ----------------------------------
SWITCH = Rows(
    "switching state",
    Row("slipping", "1", "contact mode: 0 stick, 1 slip"),
    Row("slip_direction", "1", "last known slip direction (unit)", 2, "horizontal"),
    Row(
        "step_slip_velocity",
        "m s-1",
        "slip velocity at the start of the step",
        2,
        "horizontal",
    ),
    Row("step_stop_time", "s", "stop_time at the start of the step"),
    Row(
        "impulse_tally",
        "N s",
        "re-stick friction impulses since the last sample",
        2,
        "horizontal",
    ),
    Row(
        "consistent_direction",
        "1",
        "consistent slip direction at the start of the step (unit; 3-D model)",
        2,
        "horizontal",
    ),
    Row(
        "consistent_direction_before",
        "1",
        "consistent slip direction at the start of "
        "the step before (unit; 0 before the first; 3-D model)",
        2,
        "horizontal",
    ),
    Row(
        "consistent_turn_rate",
        "rad s-1",
        "rate at which the consistent slip direction turns, over the last step (3-D model)",
    ),
    Row(
        "consistent_turn_rate_before",
        "rad s-1",
        "rate at which the consistent slip direction turns, measured at the start of "
        "the step before (3-D model)",
    ),
    Row(
        "spin_slipping",
        "1",
        "spin couple mode: 0 stuck (no spin about the normal), 1 slipping",
    ),
    Row(
        "spin_sense",
        "1",
        "sense (+1, -1) of the spin about the normal, held while it slips",
    ),
    Row("roll_slipping", "1", "rolling couple mode: 0 stuck, 1 slipping"),
    Row("roll_sense", "1", "sense of the rocking rate, held while it slips (planar)"),
)
S_MODE = SWITCH.start("slipping")
S_UHX = SWITCH.start("slip_direction")
S_UHY = S_UHX + 1
S_USX = SWITCH.start("step_slip_velocity")
S_USY = S_USX + 1
S_TSTOP = SWITCH.start("step_stop_time")
S_JX = SWITCH.start("impulse_tally")
S_JY = S_JX + 1
S_DCX = SWITCH.start("consistent_direction")
S_DCY = S_DCX + 1
S_DPX = SWITCH.start("consistent_direction_before")
S_DPY = S_DPX + 1
S_TURN = SWITCH.start("consistent_turn_rate")
S_TURN_BEFORE = SWITCH.start("consistent_turn_rate_before")
S_SPIN = SWITCH.start("spin_slipping")
S_SPIN_SENSE = SWITCH.start("spin_sense")
S_ROLL = SWITCH.start("roll_slipping")
S_ROLL_SENSE = SWITCH.start("roll_sense")

# --- time-loop bookkeeping of each lane, rows of region K ----------------------------
# Float rows of the workspace rather than separate arrays, so the once-per-step passes
# over them vectorise like the right-hand side. Each kind of pass that selects lanes for
# scalar work marks them in a row of its own (the mark rows; 0.0: not selected), with
# the named values below. One row per kind, not one per value: each extra row written
# in the once-per-step passes costs measurably.
BOOK = Rows(
    "bookkeeping",
    Row("running", "1", "1 while the lane is stepped"),
    Row("open", "1", "1 until the lane's results are written out"),
    Row("stop", "1", "last step index with a valid state"),
    Row("window_start", "1", "first step whose new state counts in the final-spin window"),
    Row("band", "rad s-1", "reversal band as a spin: band * |spin(0)|"),
    Row("side", "1", "sign of the spin's current side (0: no reversal tracking)"),
    Row("t_cross", "s", "last zero crossing of the spin"),
    Row("t_candidate", "s", "crossing instant if the spin crossed zero in this step"),
    Row("spin_previous", "rad s-1", "spin after the previous step"),
    Row("n_reversals", "1", "heading reversals so far"),
    Row("first_reversal", "s", "first reversal time, NaN while none"),
    Row("window_sum", "rad s-1", "sum of the spin over the final window"),
    Row("window_count", "1", "steps in the final window so far"),
    Row("watch_low", "1", "smallest value so far of the model's watched quantity"),
    Row("slip_steps", "1", "steps taken slipping"),
    Row(
        "mark_switch",
        "1",
        "marked by a switching pass: the sum of SWITCHES, "
        "SPIN_SWITCHES and ROLL_SWITCHES for the contact's modes that change",
    ),
    Row("mark_end", "1", "how the run ends at this step: ENDS_AS_IS or a status code"),
    Row(
        "mark_reversal",
        "1",
        "the sum of CROSSED, BEYOND and TURNED_BACK for what happened in this step",
    ),
    Row(
        "heading_turns",
        "1",
        "signed whole turns of heading_extreme's direction across the cut of atan2 at +-pi",
    ),
    Row(
        "heading_extreme",
        "1",
        "the long axis' horizontal projection where the heading "
        "turned furthest in its present sense (world; not normalised; within "
        "HEADING_BAND of the present heading)",
        2,
        "horizontal",
    ),
    Row(
        "heading_sense",
        "1",
        "present sense of turning of the heading (+1, -1; 0: no reversal tracking)",
    ),
    Row(
        "reversal_pending",
        "1",
        "1 from the first reversal time on, while the heading "
        "has not reversed and the spin has not crossed back to its launch side",
    ),
    Row(
        "lyapunov_log",
        "1",
        "sum of the logarithms of the shadow lane's growth over the renormalisation "
        "intervals so far (NaN once the shadow is lost; lyapunov.py)",
    ),
)
K_RUN = BOOK.start("running")
K_OPEN = BOOK.start("open")
K_STOP = BOOK.start("stop")
K_WIN0 = BOOK.start("window_start")
K_BAND = BOOK.start("band")
K_SIDE = BOOK.start("side")
K_T_CROSS = BOOK.start("t_cross")
K_T_CAND = BOOK.start("t_candidate")
K_SPIN_PREV = BOOK.start("spin_previous")
K_N_REV = BOOK.start("n_reversals")
K_FIRST_REV = BOOK.start("first_reversal")
K_WIN_SUM = BOOK.start("window_sum")
K_WIN_CNT = BOOK.start("window_count")
K_WATCH_LOW = BOOK.start("watch_low")
K_SLIP_STEPS = BOOK.start("slip_steps")
K_MARK_SWITCH = BOOK.start("mark_switch")
K_MARK_END = BOOK.start("mark_end")
K_MARK_REVERSAL = BOOK.start("mark_reversal")
K_HEAD_TURNS = BOOK.start("heading_turns")
K_HEAD_EXT_X = BOOK.start("heading_extreme")
K_HEAD_EXT_Y = K_HEAD_EXT_X + 1
K_HEAD_SENSE = BOOK.start("heading_sense")
K_PENDING = BOOK.start("reversal_pending")
K_LYAP_LOG = BOOK.start("lyapunov_log")

NOT_MARKED = 0.0
SWITCHES = 1.0  # K_MARK_SWITCH: the lane's sliding mode changes
SPIN_SWITCHES = 2.0  # K_MARK_SWITCH: its spin couple's mode changes
ROLL_SWITCHES = 4.0  # K_MARK_SWITCH: its rolling couple's mode changes
ENDS_AS_IS = -1.0  # K_MARK_END: the run ends with its status unchanged (the status codes
# CAPSIZED, LIFTED_OFF and NON_FINITE, all > 0, mark a run that ends with that status)
CROSSED = 1  # K_MARK_REVERSAL: the spin crossed zero
BEYOND = 2  # K_MARK_REVERSAL: the spin went beyond the band on the other side
TURNED_BACK = 4  # K_MARK_REVERSAL: the heading turned back by HEADING_BAND

HEADING_BAND = 0.1
"""rad: a heading reversal is counted when the heading, having turned one way, turns back
by more than this from the furthest it reached (:func:`.reversals.observe`). Rocking turns
the heading back and forth by a few hundredths of a radian at most, even at tilts of a
radian; a reversal turns it back by far more."""
COS2_HEADING_BAND = math.cos(HEADING_BAND) ** 2

# --- fractions of the time step, rows of region H (set from DT in the block set-up) ---
H_HALF_DT = 0  # dt / 2, s
H_SIXTH_DT = 1  # dt / 6, s (a division the last RK4 stage would otherwise take every step)
H_STAGE_DT = 2  # the stage state's step in the STAGE_MID under way: dt / 2 or dt, s
N_FRACTIONS = 3

# --- the parameter rows every model starts its parameters with, rows of region P -----
COMMON_PARAMS = Rows(
    "common parameters",
    input_row(INPUTS["dt"]),
    input_row(INPUTS["mu"]),
    input_row(INPUTS["mu_static"]),
    input_row(INPUTS["g"]),
    input_row(INPUTS["mu_spin"]),
    input_row(INPUTS["mu_roll"]),
    Row(
        "slip_speed_floor",
        "m s-1",
        "slip speed below which the stored slip direction is used",
        pack=lambda f: 1e-6 * f["g"] * f["dt"],
    ),
    Row(
        "stop_rule",
        "1",
        "when the run ends: 0 at its last step, 1 at its first "
        "reversal (of the spin and of the heading) when that comes sooner",
        pack=lambda f: f.get("stop_rule", 0.0 * f["dt"]),
    ),
    Row(
        "lyapunov_steps",
        "1",
        "steps between renormalisations of the lane's shadow, the lane BLOCK/2 above it "
        "(lyapunov.py); 0: no Lyapunov exponent",
        pack=lambda f: f.get("lyapunov_steps", 0.0 * f["dt"]),
    ),
)
DT = COMMON_PARAMS.start("dt")
MU_K = COMMON_PARAMS.start("mu")
MU_S = COMMON_PARAMS.start("mu_static")
GRAV = COMMON_PARAMS.start("g")
MU_SPIN = COMMON_PARAMS.start("mu_spin")
MU_ROLL = COMMON_PARAMS.start("mu_roll")
EPS_U = COMMON_PARAMS.start("slip_speed_floor")
STOP_RULE = COMMON_PARAMS.start("stop_rule")
LYAP_STEPS = COMMON_PARAMS.start("lyapunov_steps")

# --- values of the stop_rule row -------------------------------------------------------
# A parameter row rather than a literal argument: the rule costs no compiled variant.
RUN_TO_END = 0.0
STOP_AT_REVERSAL = 1.0
STOP_RULES = {None: RUN_TO_END, "first_reversal": STOP_AT_REVERSAL}
"""The ``stop`` argument of the batch layer and the row value it packs to."""

OFF_X = 0
OFF_S = OFF_X + CONTACT.size
OFF_K = OFF_S + SWITCH.size
OFF_H = OFF_K + BOOK.size
OFF_P = OFF_H + N_FRACTIONS
N_SHARED = OFF_P + COMMON_PARAMS.size
"""Rows of the shared regions; a model's own rows follow."""

# --- per-run observables every model reports, rows of O (a model may append more) -----
OBSERVABLES = Rows(
    "observables",
    Row("status", "1", "trajectory status"),
    Row("steps", "1", "number of steps taken"),
    Row("t_final", "s", "time reached (earlier than t_end when the trajectory stopped)"),
    Row("energy_initial", "J", "mechanical energy at t = 0"),
    Row("energy_final", "J", "mechanical energy at the end of the run"),
    Row("slip_fraction", "1", "fraction of steps spent slipping"),
    Row("initial_spin", "rad s-1", "vertical angular velocity at t = 0"),
    Row("final_spin", "rad s-1", "vertical angular velocity at the end of the run"),
    Row(
        "mean_final_spin",
        "rad s-1",
        "mean vertical angular velocity over the last 10% of the run",
    ),
    Row("first_reversal_time", "s", "time of the first spin reversal (NaN when none)"),
    Row(
        "n_reversals",
        "1",
        "number of heading reversals: changes of the long axis' sense "
        "of turning seen from above, each a turn back by more than 0.1 rad",
    ),
    Row(
        "lyapunov",
        "s-1",
        "largest finite-time Lyapunov exponent",
    ),
)
O_STATUS = OBSERVABLES.start("status")
O_STEPS = OBSERVABLES.start("steps")
O_T_END = OBSERVABLES.start("t_final")
O_E0 = OBSERVABLES.start("energy_initial")
O_E_END = OBSERVABLES.start("energy_final")
O_SLIP_FRAC = OBSERVABLES.start("slip_fraction")
O_SPIN0 = OBSERVABLES.start("initial_spin")
O_FINAL_SPIN = OBSERVABLES.start("final_spin")
O_MEAN_FINAL_SPIN = OBSERVABLES.start("mean_final_spin")
O_FIRST_REV = OBSERVABLES.start("first_reversal_time")
O_N_REV = OBSERVABLES.start("n_reversals")
O_LYAPUNOV = OBSERVABLES.start("lyapunov")
N_SHARED_OBS = OBSERVABLES.size
