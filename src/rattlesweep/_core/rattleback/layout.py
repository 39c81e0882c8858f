"""Rows of the rattleback model (docs/model.md: the body to the dynamics): its
parameters, state, scratch, recorded series and observables, and where its regions sit
in the block workspace.

Each table is the single source of truth for its rows' layout: the constants below are
read off it, and the batch layer (:mod:`rattlesweep.rattleback.batch`) packs each input
into its row by the input's name in :mod:`rattlesweep.inputs`, whose descriptions give
the units and long names that results carry.
"""

from __future__ import annotations

from ..rows import Row, Rows, check_regions, input_row
from ...inputs import RATTLEBACK
from ..workspace import COMMON_PARAMS, N_SHARED, N_SHARED_OBS, OFF_P

__all__ = ["PARAMS", "STATE", "RECORD", "OBSERVABLES"]

# --- per-trajectory parameters, rows of P (after the shared ones) --------------------
PARAMS = Rows(
    "rattleback parameters",
    *COMMON_PARAMS,
    Row("a2", "m2", "squared semi-axis along body x", pack=lambda f: f["a"] ** 2),
    Row("b2", "m2", "squared semi-axis along body y", pack=lambda f: f["b"] ** 2),
    Row("c2", "m2", "squared semi-axis along body z", pack=lambda f: f["c"] ** 2),
    input_row(RATTLEBACK["mass"]),
    input_row(RATTLEBACK["com"], 3, "body_axis"),
    input_row(RATTLEBACK["inertia_xx"]),
    input_row(RATTLEBACK["inertia_yy"]),
    input_row(RATTLEBACK["inertia_zz"]),
    input_row(RATTLEBACK["inertia_xy"]),
    input_row(RATTLEBACK["inertia_xz"]),
    input_row(RATTLEBACK["inertia_yz"]),
    input_row(RATTLEBACK["damping"]),
    input_row(RATTLEBACK["full_ellipsoid"]),
)
A2 = PARAMS.start("a2")
B2 = PARAMS.start("b2")
C2 = PARAMS.start("c2")
MASS = PARAMS.start("mass")
COM_X = PARAMS.start("com")
COM_Y = COM_X + 1
COM_Z = COM_X + 2
I_XX = PARAMS.start("inertia_xx")
I_YY = PARAMS.start("inertia_yy")
I_ZZ = PARAMS.start("inertia_zz")
I_XY = PARAMS.start("inertia_xy")
I_XZ = PARAMS.start("inertia_xz")
I_YZ = PARAMS.start("inertia_yz")
DAMPING = PARAMS.start("damping")
FULL = PARAMS.start("full_ellipsoid")
N_PARAM = PARAMS.size

# --- per-trajectory parameters derived in the block set-up, rows of E ----------------
# The right-hand side works per unit mass: the inertia and damping divided by the mass.
J_XX, J_YY, J_ZZ, J_XY, J_XZ, J_YZ = range(6)  # inertia about G / mass, m^2
DAMPING_PM = 6  # damping / mass, m^2/s
# (I/m)⁻¹, 1/m^2: the contact's response to a force, for the consistent slip direction
JI_XX, JI_YY, JI_ZZ, JI_XY, JI_XZ, JI_YZ = range(7, 13)
N_DERIVED = 13

# --- integrated state, rows of Y -------------------------------------------------------
STATE = Rows(
    "rattleback state",
    Row(
        "quaternion",
        "1",
        "orientation quaternion (w, x, y, z), body to world",
        4,
        "quaternion_component",
    ),
    Row("omega", "rad s-1", "angular velocity, body components", 3, "body_axis"),
    Row("position", "m", "horizontal position of G, world frame", 2, "horizontal"),
    Row("velocity", "m s-1", "horizontal velocity of G, world frame", 2, "horizontal"),
)
Q0 = STATE.start("quaternion")
Q1, Q2, Q3 = Q0 + 1, Q0 + 2, Q0 + 3
OMEGA_X = STATE.start("omega")
OMEGA_Y, OMEGA_Z = OMEGA_X + 1, OMEGA_X + 2
POS_X = STATE.start("position")
POS_Y = POS_X + 1
VEL_X = STATE.start("velocity")
VEL_Y = VEL_X + 1
N_STATE = STATE.size

# --- intermediate results of one right-hand-side evaluation, rows of G ------------------
# The evaluation runs as several loops over the lanes (geometry, dynamics, division,
# derivative), handing these rows from one to the next: short loop bodies let the
# processor overlap the long dependency chains (a square root and two divisions) of
# neighbouring lanes.
RHO_X, RHO_Y, RHO_Z = 0, 1, 2  # ρ, from G to the contact point, body, m
WW_X, WW_Y, WW_Z = 3, 4, 5  # w = ω × (ω × ρ + ṡ_P), body, m/s^2
UP_X, UP_Y, UP_Z = 6, 7, 8  # world up-vector in body components, times |q|^2
INV_QQ = 9  # 1/|q|^2
SLIP_X, SLIP_Y = 10, 11  # slip velocity of the material contact point, world, m/s
UHAT_X, UHAT_Y = 12, 13  # slip direction used for friction, world
ALPHA_X, ALPHA_Y, ALPHA_Z = 14, 15, 16  # angular acceleration, rad/s^2 (first times DET)
DET = 17  # determinant of the 3×3 system for the angular acceleration
NORMAL_PM = 18  # N/m, normal force per unit mass, m/s^2
INV_SIGMA = 19  # 1/σ̃, 1/m
SPIN_LAMBDA = 20  # couple about the normal holding a stuck spin, per unit mass, m^2/s^2
SPIN_RATE = 21  # ω · n̂, rad/s
ROLL_FRACTION = 22  # the rolling couple over its bound, |ω_h| / max(|ω_h|, floor)
ROLL_MARGIN = 23  # the rolling couple's switching function, rad/s or m^2/s^2 (dynamics)
SLIP_KIND = 24  # 0 sticking, FAST_SLIP or SLOW_SLIP (slip.slip_direction)
DSTAR_X, DSTAR_Y = 25, 26  # a slow slip's consistent direction d*, world (consistent.py)
DSTAR_SLOPE = 27  # its attraction s, m/s^2; -1: none; NaN: left to the lane's own solve
N_SCRATCH = 28

# --- the block workspace: the shared regions, then this model's ------------------------
OFF_E = OFF_P + N_PARAM  # derived parameters
OFF_Y = OFF_E + N_DERIVED  # state at the start of the step; the new state after it
OFF_T = OFF_Y + N_STATE  # stage state of the inner RK4 stages (no position rows used)
OFF_A = OFF_T + N_STATE  # RK4 accumulator; the first-stage derivative between steps
OFF_B = OFF_A + N_STATE  # the state at the start of the last step
OFF_G = OFF_B + N_STATE  # right-hand-side intermediates
N_WORK = OFF_G + N_SCRATCH
check_regions(
    "rattleback workspace",
    {
        "shared": (0, N_SHARED),
        "model parameters": (N_SHARED, N_PARAM - COMMON_PARAMS.size),
        "E": (OFF_E, N_DERIVED),
        "Y": (OFF_Y, N_STATE),
        "T": (OFF_T, N_STATE),
        "A": (OFF_A, N_STATE),
        "B": (OFF_B, N_STATE),
        "G": (OFF_G, N_SCRATCH),
    },
    N_WORK,
)

# --- recorded time series, rows of the record array ------------------------------------
RECORD = Rows(
    "rattleback record",
    Row(
        "quaternion",
        "1",
        "orientation quaternion (w, x, y, z), body to world",
        4,
        "quaternion_component",
    ),
    Row("omega", "rad s-1", "angular velocity, body components", 3, "body_axis"),
    Row("position", "m", "position of the centre of mass, world frame", 3, "axis"),
    Row("velocity", "m s-1", "velocity of the centre of mass, world frame", 3, "axis"),
    Row("spin", "rad s-1", "vertical angular velocity n = omega . Z"),
    Row("tilt", "rad", "tilt of the body z axis from the vertical"),
    # counter-clockwise from the world X axis, continuous over whole turns
    Row("heading", "rad", "heading of the long axis, seen from above (unwrapped)"),
    Row("energy", "J", "mechanical energy"),
    Row("normal_force", "N", "normal contact force"),
    Row(
        "friction_force",
        "N",
        "horizontal friction force on the body, world frame",
        2,
        "horizontal",
    ),
    Row(
        "slip_velocity",
        "m s-1",
        "horizontal velocity of the material contact point, world frame",
        2,
        "horizontal",
    ),
    Row("slipping", "1", "1 while the contact slips, 0 while it sticks"),
    Row(
        "friction_impulse",
        "N s",
        "horizontal friction impulse of re-sticking since the previous sample, world frame",
        2,
        "horizontal",
    ),
    Row("contact_point", "m", "contact point on the floor, world frame", 2, "horizontal"),
)
R_QUATERNION = RECORD.start("quaternion")
R_OMEGA = RECORD.start("omega")
R_POSITION = RECORD.start("position")
R_VELOCITY = RECORD.start("velocity")
R_SPIN = RECORD.start("spin")
R_TILT = RECORD.start("tilt")
R_HEADING = RECORD.start("heading")
R_ENERGY = RECORD.start("energy")
R_NORMAL = RECORD.start("normal_force")
R_FRICTION = RECORD.start("friction_force")
R_SLIP_VELOCITY = RECORD.start("slip_velocity")
R_SLIPPING = RECORD.start("slipping")
R_IMPULSE = RECORD.start("friction_impulse")
R_CONTACT = RECORD.start("contact_point")
N_REC = RECORD.size

# --- observables of this model, rows of O after the shared ones ------------------------
OBSERVABLES = Rows(
    "rattleback observables",
    Row("max_tilt", "rad", "largest tilt of the body z axis from the vertical"),
)
O_MAX_TILT = N_SHARED_OBS + OBSERVABLES.start("max_tilt")
N_OBS = N_SHARED_OBS + OBSERVABLES.size
