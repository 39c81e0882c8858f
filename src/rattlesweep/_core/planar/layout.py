"""Rows of the planar rocking semi-ellipse (docs/model.md: the planar rocking semi-ellipse):
its parameters, state, recorded series and observables, and where its regions sit in the
block workspace.

Each table is the single source of truth for its rows, as in :mod:`..rattleback.layout`.
"""

from __future__ import annotations

from ..rows import Row, Rows, check_regions, input_row
from ...inputs import PLANAR
from ..workspace import COMMON_PARAMS, N_SHARED, N_SHARED_OBS, OFF_P

__all__ = ["PARAMS", "STATE", "RECORD", "OBSERVABLES"]

# --- per-trajectory parameters, rows of P (after the shared ones) --------------------
PARAMS = Rows(
    "planar parameters",
    *COMMON_PARAMS,
    Row("a2", "m2", "squared semi-axis along the flat edge", pack=lambda f: f["a"] ** 2),
    Row(
        "b2", "m2", "squared semi-axis normal to the flat edge", pack=lambda f: f["b"] ** 2
    ),
    Row("ab2", "m4", "a² b²", pack=lambda f: f["a"] * f["a"] * f["b"] * f["b"]),
    input_row(PLANAR["com_depth"]),
    input_row(PLANAR["mass"]),
    input_row(PLANAR["inertia"]),
)
A2 = PARAMS.start("a2")
B2 = PARAMS.start("b2")
AB2 = PARAMS.start("ab2")
DEPTH = PARAMS.start("com_depth")
MASS = PARAMS.start("mass")
INERTIA = PARAMS.start("inertia")
N_PARAM = PARAMS.size

# --- integrated state, rows of Y -------------------------------------------------------
STATE = Rows(
    "planar state",
    Row("angle", "rad", "rocking angle theta, counter-clockwise"),
    Row("rate", "rad s-1", "rocking rate d(theta)/dt"),
    Row("x_G", "m", "horizontal position of the centre of mass"),
    Row("velocity_x", "m s-1", "horizontal velocity of the centre of mass"),
)
THETA = STATE.start("angle")
RATE = STATE.start("rate")
XG = STATE.start("x_G")
VXG = STATE.start("velocity_x")
N_STATE = STATE.size

# --- the block workspace: the shared regions, then this model's ------------------------
OFF_Y = OFF_P + N_PARAM  # state at the start of the step; the new state after it
OFF_T = OFF_Y + N_STATE  # stage state of the inner RK4 stages
OFF_A = OFF_T + N_STATE  # RK4 accumulator; the first-stage derivative between steps
OFF_B = OFF_A + N_STATE  # the state at the start of the last step
N_WORK = OFF_B + N_STATE
check_regions(
    "planar workspace",
    {
        "shared": (0, N_SHARED),
        "model parameters": (N_SHARED, N_PARAM - COMMON_PARAMS.size),
        "Y": (OFF_Y, N_STATE),
        "T": (OFF_T, N_STATE),
        "A": (OFF_A, N_STATE),
        "B": (OFF_B, N_STATE),
    },
    N_WORK,
)

# --- recorded time series, rows of the record array ------------------------------------
RECORD = Rows(
    "planar record",
    Row("angle", "rad", "rocking angle theta, counter-clockwise"),
    Row("rate", "rad s-1", "rocking rate d(theta)/dt"),
    Row("x_G", "m", "horizontal position of the centre of mass"),
    Row("y_G", "m", "height of the centre of mass above the floor, h(theta)"),
    Row("velocity_x", "m s-1", "horizontal velocity of the centre of mass"),
    Row(
        "velocity_y",
        "m s-1",
        "vertical velocity of the centre of mass, h'(theta) d(theta)/dt",
    ),
    Row("slip_velocity", "m s-1", "horizontal velocity of the material contact point"),
    Row("normal_force", "N", "normal contact force"),
    Row("friction_force", "N", "horizontal friction force on the body"),
    Row("energy", "J", "mechanical energy (floor at zero potential)"),
    Row("slipping", "1", "1 while the contact slips, 0 while it sticks"),
)
R_ANGLE = RECORD.start("angle")
R_RATE = RECORD.start("rate")
R_XG = RECORD.start("x_G")
R_YG = RECORD.start("y_G")
R_VX = RECORD.start("velocity_x")
R_VY = RECORD.start("velocity_y")
R_U = RECORD.start("slip_velocity")
R_N = RECORD.start("normal_force")
R_F = RECORD.start("friction_force")
R_ENERGY = RECORD.start("energy")
R_SLIP = RECORD.start("slipping")
N_REC = RECORD.size

# --- observables of this model, rows of O after the shared ones ------------------------
OBSERVABLES = Rows(
    "planar observables",
    Row("max_angle", "rad", "largest |rocking angle|"),
    Row("final_angle", "rad", "rocking angle at the end of the run"),
    Row("final_rate", "rad s-1", "rocking rate at the end of the run"),
)
O_MAX_ANGLE = N_SHARED_OBS + OBSERVABLES.start("max_angle")
O_FINAL_ANGLE = N_SHARED_OBS + OBSERVABLES.start("final_angle")
O_FINAL_RATE = N_SHARED_OBS + OBSERVABLES.start("final_rate")
N_OBS = N_SHARED_OBS + OBSERVABLES.size
