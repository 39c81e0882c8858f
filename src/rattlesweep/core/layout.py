"""Row indices of the structure-of-arrays blocks the kernel works on.

Every per-trajectory array the kernel sees has shape ``(n_blocks, n_rows, BLOCK)``: the
last axis runs over the ``BLOCK`` lanes (trajectories) of a block, so each row is a
contiguous vector the compiler steps with SIMD instructions. ``BLOCK`` is a
compile-time constant, which gives the lane loops a known trip count (no scalar
remainder loop) and makes a lane's arithmetic independent of its position in the batch.
"""

from __future__ import annotations

BLOCK = 32
"""Lanes per block. A multiple of the SIMD width (4 doubles for AVX2, 8 for AVX-512)."""

# --- integrated state, rows of Y ---------------------------------------------------
Q0, Q1, Q2, Q3 = 0, 1, 2, 3  # orientation quaternion (w, x, y, z), body -> world
W0, W1, W2 = 4, 5, 6  # angular velocity, body components, rad/s
PX, PY = 7, 8  # horizontal position of G, world, m
VX, VY = 9, 10  # horizontal velocity of G, world, m/s
N_STATE = 11

# --- per-trajectory parameters, rows of P --------------------------------------------
A2, B2, C2 = 0, 1, 2  # squared semi-axes, m^2
MASS = 3  # kg
GX, GY, GZ = 4, 5, 6  # centre of mass from C, body components, m
IXX, IYY, IZZ, IXY, IXZ, IYZ = 7, 8, 9, 10, 11, 12  # inertia about G, kg m^2
MU_K, MU_S = 13, 14  # kinetic / static friction coefficients (may be inf)
DAMP = 15  # viscous torque coefficient c_v, N m s
GRAV = 16  # m/s^2
DT = 17  # time step, s
FULL = 18  # 1.0 for a full ellipsoid (no rim, never capsizes), else 0.0
EPS_U = 19  # slip speed below which the stored slip direction is used, m/s
N_PARAM = 20

# --- per-trajectory parameters derived once per block, rows of region E --------------
# The right-hand side works per unit mass: the inertia and damping divided by the mass;
# the RK4 stages use fractions of the time step.
E_JXX, E_JYY, E_JZZ, E_JXY, E_JXZ, E_JYZ = 0, 1, 2, 3, 4, 5  # inertia about G / mass, m^2
E_CVM = 6  # damping / mass, m^2/s
E_HALF_DT = 7  # dt / 2, s
E_SIXTH_DT = 8  # dt / 6, s (a division the last RK4 stage would otherwise take every step)
N_DERIVED = 9

# --- auxiliary outputs of one right-hand-side evaluation, rows of X -----------------
X_N = 0  # normal force, N
X_FX, X_FY = 1, 2  # horizontal friction force, world, N
X_UX, X_UY = 3, 4  # horizontal slip velocity of the material contact point, world, m/s
N_AUX = 5

# --- intermediate results of one right-hand-side evaluation, rows of region G ---------
# The evaluation runs as several loops over the lanes (geometry, dynamics, derivative),
# handing these rows from one to the next: short loop bodies let the processor overlap
# the long dependency chains (a square root and two divisions) of neighbouring lanes.
G_R0, G_R1, G_R2 = 0, 1, 2  # ρ, from G to the contact point, body, m
G_WW0, G_WW1, G_WW2 = 3, 4, 5  # w = ω × (ω × ρ + ṡ_P), body, m/s^2
G_U0, G_U1, G_U2 = 6, 7, 8  # world up-vector in body components, times |q|^2
G_INV_Q = 9  # 1/|q|^2
G_UX, G_UY = 10, 11  # slip velocity of the material contact point, world, m/s
G_UHX, G_UHY = 12, 13  # slip direction used for friction, world
G_X0, G_X1, G_X2 = 14, 15, 16  # angular acceleration, rad/s^2 (first times G_DET)
G_DET = 17  # determinant of the 3×3 system for the angular acceleration
G_N0 = 18  # N/m, normal force per unit mass, m/s^2
G_INV_S = 19  # 1/σ̃, 1/m
N_SCRATCH = 20

# --- per-lane switching state, rows of S ---------------------------------------------
S_MODE = 0  # 0.0 stick, 1.0 slip
S_UHX, S_UHY = 1, 2  # last known slip direction (unit, world)
S_USX, S_USY = 3, 4  # slip velocity at the start of the current step
S_UPREV = 5  # |u| at the end of the previous step
S_JX, S_JY = 6, 7  # re-stick friction impulses since the last recorded sample, world, N s
N_SWITCH = 8

# --- per-lane bookkeeping of the time loop, rows of region K -------------------------
# Kept as float rows of the workspace, not as separate arrays, so the once-per-step
# passes over them vectorise like the right-hand side.
K_RUN = 0  # 1.0 while the lane is stepped (status ok and its last step not reached)
K_OPEN = 1  # 1.0 until the lane's final state and observables are written out
K_STOP = 2  # last step index with a valid state
K_WIN0 = 3  # first step index whose new state counts in the final-spin window
K_BAND = 4  # reversal band as a spin, rad/s: band * |spin(0)|
K_SIDE = 5  # sign of the spin's current side (0: no reversal tracking)
K_T_CROSS = 6  # s, last zero crossing of the spin
K_T_CAND = 7  # s, scratch: the crossing instant if the spin crossed zero in this step
K_SPIN_PREV = 8  # rad/s, spin after the previous step
K_N_REV = 9
K_FIRST_REV = 10  # s, NaN when none
K_WIN_SUM = 11  # rad/s
K_WIN_CNT = 12
K_MIN_UP = 13  # smallest vertical component of the body's up-axis so far
K_SLIP_STEPS = 14
K_FLAG = 15  # scratch: non-zero where a lane needs scalar work after a vector pass
N_BOOK = 16

# --- the per-block workspace ---------------------------------------------------------
# Inside the time loop a block's arrays live in one flat float64 workspace W of
# N_WORK * BLOCK elements; row r of region OFF_x starts at (OFF_x + r) * BLOCK. With one
# base pointer and compile-time offsets LLVM can prove that a store never aliases a later
# load of another row, so the lane loops vectorise without runtime alias checks (separate
# arrays would each need such checks, and LLVM gives up past a handful).
OFF_P = 0  # parameters (N_PARAM rows)
OFF_E = OFF_P + N_PARAM  # derived parameters (N_DERIVED rows)
OFF_Y = OFF_E + N_DERIVED  # state at the start of the step (N_STATE rows)
OFF_T = OFF_Y + N_STATE  # stage state of the inner RK4 stages (no position rows used)
OFF_A = OFF_T + N_STATE  # RK4 accumulator of the stage derivatives
OFF_X = OFF_A + N_STATE  # auxiliary outputs (N_AUX rows)
OFF_G = OFF_X + N_AUX  # right-hand-side intermediates (N_SCRATCH rows)
OFF_S = OFF_G + N_SCRATCH  # switching state (N_SWITCH rows)
OFF_K = OFF_S + N_SWITCH  # time-loop bookkeeping (N_BOOK rows)
N_WORK = OFF_K + N_BOOK

# --- status codes --------------------------------------------------------------------
OK = 0
CAPSIZED = 1
LIFTED_OFF = 2
NON_FINITE = 3
STATUS_NAMES = ("ok", "capsized", "lifted_off", "non_finite")

# --- per-run observables, rows of O --------------------------------------------------
O_FIRST_REV = 0  # s, NaN when none
O_N_REV = 1
O_FINAL_SPIN = 2  # rad/s
O_MEAN_FINAL_SPIN = 3  # rad/s, over the last 10 % of the run
O_MAX_TILT = 4  # rad
O_E0 = 5  # J
O_E_END = 6  # J
O_SLIP_FRAC = 7
O_STATUS = 8
O_T_END = 9  # s, time reached (earlier than t_end when frozen)
O_SPIN0 = 10  # rad/s
O_STEPS = 11  # steps taken
N_OBS = 12

# --- recorded time series, rows of the record array -----------------------------------
R_Q0, R_Q1, R_Q2, R_Q3 = 0, 1, 2, 3
R_W0, R_W1, R_W2 = 4, 5, 6
R_PX, R_PY, R_PZ = 7, 8, 9
R_VX, R_VY, R_VZ = 10, 11, 12
R_SPIN = 13
R_TILT = 14
R_ENERGY = 15
R_N = 16
R_FX, R_FY = 17, 18
R_UX, R_UY = 19, 20
R_SLIP = 21
R_JX, R_JY = 22, 23  # re-stick friction impulse since the previous sample, N s
N_REC = 24
