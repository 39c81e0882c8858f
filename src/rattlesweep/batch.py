"""Batches of launches through the kernel: broadcasting, validation, packing, results.

:func:`run_batch` is the array entry point. Every per-trajectory input (the body, the
launch, the friction, the numerics) may be an array; all are broadcast together and the
batch is flattened onto one ``trajectory`` dimension whose coordinates are the inputs.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
import xarray as xr

from . import __version__
from .body import Body, distinct_bodies
from .core import layout as L
from .core.stepper import (
    EULER, RK4, contact_slip_velocity, integrate_parallel, integrate_serial,
)
from .launch import check_unit_quaternion, quaternion_from_angles, tilt_limit_error, up_vector
from .metadata import attrs_for

METHODS = {"rk4": RK4, "euler": EULER}

_BODY_COORDS = ("a", "b", "c", "mass", "full_ellipsoid", "inertia_xx", "inertia_yy",
                "inertia_zz", "inertia_xy", "inertia_xz", "inertia_yz")


_FULL_COL = 13  # column of the full-ellipsoid flag in _body_row


def _body_row(b: Body) -> list[float]:
    """a, b, c, mass, com (3), I_xx, I_yy, I_zz, I_xy, I_xz, I_yz, full_ellipsoid."""
    i = b.inertia
    return [b.a, b.b, b.c, b.mass, *b.com, i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2],
            i[1, 2], float(b.full_ellipsoid)]


@dataclass(frozen=True)
class Prepared:
    """A validated batch packed into kernel blocks (see :mod:`rattlesweep.core.layout`)."""

    P: np.ndarray  # (n_blocks, N_PARAM, BLOCK)
    Y: np.ndarray  # (n_blocks, N_STATE, BLOCK)
    nsteps: np.ndarray  # (n_blocks, BLOCK) int64; 0 for padding lanes
    n: int  # trajectories
    shape: tuple[int, ...]  # broadcast shape of the inputs
    coords: dict[str, Any]  # name -> (dims, flat values)


def _fail(name: str, arr: np.ndarray, bad: np.ndarray, rule: str) -> None:
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f" at index {idx}" if arr.ndim else ""
        raise ValueError(f"{name} {rule}; got {arr[idx]!r}{where}")


def _as_float(name: str, value) -> np.ndarray:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or an array of numbers, got {value!r}") from None


def as_bodies(body, cls: type = Body) -> np.ndarray:
    """``body`` as an object array of ``cls`` instances (0-d for a single body)."""
    name = cls.__name__
    if isinstance(body, cls):
        arr = np.empty((), dtype=object)
        arr[()] = body
        return arr
    arr = np.asarray(body, dtype=object)
    if arr.size == 0:
        raise ValueError(f"body must be a {name} or a non-empty array of {name} objects")
    for item in arr.flat:
        if not isinstance(item, cls):
            raise ValueError(f"body must be a {name} or an array of {name} objects, "
                             f"got {item!r}")
    return arr


def prepare(
    body, *, spin=None, omega=None, roll=0.0, pitch=0.0, yaw=0.0, orientation=None,
    velocity=None, mu=math.inf, mu_static=None, damping=0.0, g=9.81, dt=None, t_end,
) -> Prepared:
    """Validate and broadcast launch inputs and pack them for the kernel.

    See :func:`run_batch` for the meaning and units of the arguments. Raises ValueError
    naming the parameter, the value and the rule for any invalid input. Non-finite launch
    values (spin, omega, angles, orientation, velocity) are not errors: those trajectories
    get the status ``non_finite``.
    """
    if spin is not None and omega is not None:
        raise ValueError("give either spin (about the vertical) or omega (body frame), not both")
    if orientation is not None and any(np.any(np.asarray(x) != 0) for x in (roll, pitch, yaw)):
        raise ValueError("give either orientation or roll/pitch/yaw, not both")
    if t_end is None:
        raise ValueError("t_end (s) is required")

    bodies = as_bodies(body)
    scalars = {
        "roll": roll, "pitch": pitch, "yaw": yaw, "mu": mu,
        "mu_static": mu if mu_static is None else mu_static,
        "damping": damping, "g": g, "t_end": t_end,
    }
    if omega is None:
        scalars["spin"] = 0.0 if spin is None else spin
    if dt is not None:
        scalars["dt"] = dt
    scalars = {k: _as_float(k, v) for k, v in scalars.items()}
    vectors = {}
    for name, value, width in (("omega", omega, 3), ("orientation", orientation, 4),
                               ("velocity", velocity, 2)):
        if value is not None:
            arr = _as_float(name, value)
            if arr.ndim == 0 or arr.shape[-1] != width:
                raise ValueError(f"{name} must have a last axis of length {width}, "
                                 f"got shape {arr.shape}")
            vectors[name] = arr
    try:
        shape = np.broadcast_shapes(bodies.shape, *(v.shape for v in scalars.values()),
                                    *(v.shape[:-1] for v in vectors.values()))
    except ValueError:
        shapes = {k: v.shape for k, v in {**scalars, **vectors}.items()}
        raise ValueError(f"inputs cannot be broadcast together: shapes {shapes}, "
                         f"body {bodies.shape}") from None

    # --- parameter rules (launch state may be non-finite: flagged, not refused) ------
    mu_k, mu_s = scalars["mu"], scalars["mu_static"]
    _fail("mu", mu_k, ~(mu_k >= 0), "must be >= 0 (inf for pure rolling)")
    _fail("mu_static", mu_s, ~(mu_s >= 0), "must be >= 0 (inf for pure rolling)")
    bad = np.broadcast_to(mu_s, np.broadcast_shapes(mu_s.shape, mu_k.shape)) < mu_k
    _fail("mu_static", np.broadcast_to(mu_s, bad.shape), bad, "must be >= mu")
    d = scalars["damping"]
    _fail("damping", d, ~(np.isfinite(d) & (d >= 0)), "must be finite and >= 0 (N m s)")
    for name in ("g", "t_end") + (("dt",) if "dt" in scalars else ()):
        v = scalars[name]
        _fail(name, v, ~(np.isfinite(v) & (v > 0)), "must be finite and > 0")

    n = int(np.prod(shape))
    flat = {k: np.broadcast_to(v, shape).reshape(n) for k, v in scalars.items()}
    flat_vec = {k: np.broadcast_to(v, shape + v.shape[-1:]).reshape(n, v.shape[-1])
                for k, v in vectors.items()}
    flat_bodies = np.broadcast_to(bodies, shape).reshape(n)

    # bodies: parameters per distinct body object
    table, index = distinct_bodies(flat_bodies)
    body_rows = np.array([_body_row(b) for b in table])[index]

    if "dt" not in flat:
        # one default per distinct (body, g), not per trajectory
        keys, inverse = np.unique(np.stack([index.astype(float), flat["g"]]), axis=1,
                                  return_inverse=True)
        per_key = np.array([table[int(i)].default_dt(float(gv)) for i, gv in keys.T])
        flat["dt"] = per_key[inverse.reshape(-1)]
    nsteps = np.ceil(flat["t_end"] / flat["dt"] * (1.0 - 1e-12)).astype(np.int64)
    nsteps = np.maximum(nsteps, 1)

    # --- initial state ------------------------------------------------------------------
    if "orientation" in flat_vec:
        q = flat_vec["orientation"].copy()
        check_unit_quaternion(q)
    else:
        q = quaternion_from_angles(flat["roll"], flat["pitch"], flat["yaw"])
    up = up_vector(q)
    tilt_limit_error(up[:, 2], body_rows[:, _FULL_COL] > 0.5)
    if "omega" in flat_vec:
        w = flat_vec["omega"]
    else:
        w = flat["spin"][:, None] * up  # rotation about the world vertical

    n_blocks = -(-n // L.BLOCK)
    n_pad = n_blocks * L.BLOCK
    P = np.empty((L.N_PARAM, n_pad))
    Y = np.zeros((L.N_STATE, n_pad))
    steps = np.zeros(n_pad, dtype=np.int64)

    def fill(arr, row, values):
        arr[row, :n] = values
        arr[row, n:] = values[0]  # padding lanes copy a valid trajectory and take 0 steps

    for row, col in ((L.A2, 0), (L.B2, 1), (L.C2, 2)):
        fill(P, row, body_rows[:, col] ** 2)
    for row, col in zip((L.MASS, L.GX, L.GY, L.GZ, L.IXX, L.IYY, L.IZZ, L.IXY, L.IXZ, L.IYZ,
                         L.FULL), range(3, _FULL_COL + 1)):
        fill(P, row, body_rows[:, col])
    fill(P, L.MU_K, flat["mu"])
    fill(P, L.MU_S, flat["mu_static"])
    fill(P, L.DAMP, flat["damping"])
    fill(P, L.GRAV, flat["g"])
    fill(P, L.DT, flat["dt"])
    fill(P, L.EPS_U, 1e-6 * flat["g"] * flat["dt"])
    for k in range(4):
        fill(Y, L.Q0 + k, q[:, k])
    for k in range(3):
        fill(Y, L.W0 + k, w[:, k])
    steps[:n] = nsteps

    blocked = lambda a: np.ascontiguousarray(a.reshape(a.shape[0], n_blocks, L.BLOCK)
                                             .transpose(1, 0, 2))
    P, Y = blocked(P), blocked(Y)
    # velocity of G: rolling (material contact point at rest) unless given
    U = np.zeros((n_blocks, 2, L.BLOCK))
    contact_slip_velocity(P, Y, U)
    rolling = -U.transpose(1, 0, 2).reshape(2, n_pad)[:, :n]
    if "velocity" in flat_vec:
        v = flat_vec["velocity"].T
        sliding = np.isfinite(v).all(axis=0) & np.any(v != rolling, axis=0)
        _fail("velocity", flat_vec["velocity"],
              sliding & np.isinf(flat["mu_static"]),
              "makes a sliding launch, which needs a finite mu_static")
    else:
        v = rolling
    Vrows = np.empty((2, n_pad))
    Vrows[:, :n] = v
    Vrows[:, n:] = v[:, :1]
    Y[:, L.VX, :] = Vrows[0].reshape(n_blocks, L.BLOCK)
    Y[:, L.VY, :] = Vrows[1].reshape(n_blocks, L.BLOCK)

    # --- coordinates: every input, per trajectory --------------------------------------
    dim = "trajectory"
    coords: dict[str, Any] = {}
    if "orientation" in flat_vec:
        coords["orientation"] = ((dim, "quaternion_component"), flat_vec["orientation"])
    else:
        for k in ("roll", "pitch", "yaw"):
            coords[k] = (dim, flat[k])
    if "omega" in flat_vec:
        coords["launch_omega"] = ((dim, "body_axis"), flat_vec["omega"])
    else:
        coords["launch_spin"] = (dim, flat["spin"])
    if "velocity" in flat_vec:
        coords["launch_velocity"] = ((dim, "horizontal"), flat_vec["velocity"])
    for k in ("mu", "mu_static", "damping", "g", "dt", "t_end"):
        coords[k] = (dim, flat[k])
    for k, col in zip(_BODY_COORDS, (0, 1, 2, 3, _FULL_COL, 7, 8, 9, 10, 11, 12)):
        coords[k] = (dim, body_rows[:, col])
    coords["com"] = ((dim, "body_axis"), body_rows[:, 4:7])
    coords["body_name"] = (dim, np.array([b.name for b in table])[index])
    return Prepared(P, Y, steps.reshape(n_blocks, L.BLOCK), n, tuple(shape), coords)


@contextlib.contextmanager
def _numba_threads(threads: int | None):
    if threads is None:
        yield
        return
    limit = numba.config.NUMBA_NUM_THREADS
    if not (isinstance(threads, (int, np.integer)) and 1 <= threads <= limit):
        raise ValueError(f"threads must be an integer from 1 to {limit}, got {threads!r}")
    old = numba.get_num_threads()
    numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def check_method(method: str) -> int:
    try:
        return METHODS[method]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}") from None


def check_record_every(record_every) -> int | None:
    if record_every is None:
        return None
    if not (isinstance(record_every, (int, np.integer)) and record_every >= 1):
        raise ValueError(f"record_every must be a positive integer or None, got {record_every!r}")
    return int(record_every)


def check_band(reversal_band) -> float:
    band = float(reversal_band)
    if not (0.0 <= band < 1.0):
        raise ValueError(f"reversal_band must be in [0, 1) (a fraction of |initial spin|), "
                         f"got {reversal_band!r}")
    return band


def execute(prep: Prepared, *, method: int, record_every: int | None, band: float,
            parallel: bool = True, threads: int | None = None):
    """Run a prepared batch. Returns (observables (N_OBS, n), records (n, n_rec, N_REC)
    or None, final state (N_STATE, n))."""
    n_blocks = prep.P.shape[0]
    n_rec = 0 if record_every is None else int(prep.nsteps.max()) // record_every + 1
    REC = np.empty((n_blocks, n_rec, L.N_REC, L.BLOCK))
    O = np.empty((n_blocks, L.N_OBS, L.BLOCK))
    Y = prep.Y.copy()
    entry = integrate_parallel if parallel else integrate_serial
    with _numba_threads(threads):
        entry(prep.P, Y, prep.nsteps, method, record_every or 1, band, O, REC)
    unblock = lambda a: a.transpose(1, 0, 2).reshape(a.shape[1], -1)[:, :prep.n]
    rec = None
    if n_rec:
        rec = REC.transpose(0, 3, 1, 2).reshape(n_blocks * L.BLOCK, n_rec, L.N_REC)[:prep.n]
    return unblock(O), rec, unblock(Y)


def observables_dataset(obs: np.ndarray, dim: str | None) -> dict[str, xr.DataArray]:
    """Per-run observables as labelled DataArrays over ``dim`` (or scalars for None)."""
    dims = (dim,) if dim else ()
    pick = (lambda row: obs[row]) if dim else (lambda row: obs[row, 0])
    out = {
        "first_reversal_time": pick(L.O_FIRST_REV),
        "n_reversals": pick(L.O_N_REV).astype(np.int64),
        "initial_spin": pick(L.O_SPIN0),
        "final_spin": pick(L.O_FINAL_SPIN),
        "mean_final_spin": pick(L.O_MEAN_FINAL_SPIN),
        "max_tilt": pick(L.O_MAX_TILT),
        "energy_initial": pick(L.O_E0),
        "energy_final": pick(L.O_E_END),
        "energy_lost": pick(L.O_E0) - pick(L.O_E_END),
        "slip_fraction": pick(L.O_SLIP_FRAC),
        "t_final": pick(L.O_T_END),
        "steps": pick(L.O_STEPS).astype(np.int64),
        "status": pick(L.O_STATUS).astype(np.int8),
    }
    return {k: xr.DataArray(v, dims=dims, attrs=attrs_for(k)) for k, v in out.items()}


def series_dataset(rec: np.ndarray, dims: tuple[str, ...]) -> dict[str, xr.DataArray]:
    """Recorded time series (..., n_rec, N_REC) as labelled DataArrays."""
    def var(name, values, extra=()):
        return xr.DataArray(values, dims=dims + extra, attrs=attrs_for(name))

    u = rec[..., [L.R_UX, L.R_UY]]
    return {
        "spin": var("spin", rec[..., L.R_SPIN]),
        "energy": var("energy", rec[..., L.R_ENERGY]),
        "tilt": var("tilt", rec[..., L.R_TILT]),
        "slipping": var("slipping", rec[..., L.R_SLIP]),
        "normal_force": var("normal_force", rec[..., L.R_N]),
        "slip_speed": var("slip_speed", np.hypot(u[..., 0], u[..., 1])),
        "slip_velocity": var("slip_velocity", u, ("horizontal",)),
        "friction_force": var("friction_force", rec[..., [L.R_FX, L.R_FY]], ("horizontal",)),
        "friction_impulse": var("friction_impulse", rec[..., [L.R_JX, L.R_JY]],
                                ("horizontal",)),
        "quaternion": var("quaternion", rec[..., L.R_Q0:L.R_Q0 + 4], ("quaternion_component",)),
        "omega": var("omega", rec[..., L.R_W0:L.R_W0 + 3], ("body_axis",)),
        "position": var("position", rec[..., L.R_PX:L.R_PX + 3], ("axis",)),
        "velocity": var("velocity", rec[..., L.R_VX:L.R_VX + 3], ("axis",)),
    }


VECTOR_COORDS = {
    "quaternion_component": ["w", "x", "y", "z"],
    "body_axis": ["x", "y", "z"],
    "axis": ["X", "Y", "Z"],
    "horizontal": ["X", "Y"],
}


def run_batch(
    body: Body | Any,
    *,
    spin=None, omega=None, roll=0.0, pitch=0.0, yaw=0.0, orientation=None, velocity=None,
    mu=math.inf, mu_static=None, damping=0.0, g=9.81, dt=None, t_end,
    method: str = "rk4", record_every: int | None = None, reversal_band: float = 0.05,
    parallel: bool = True, threads: int | None = None,
) -> xr.Dataset:
    """Integrate many launches at once; return per-trajectory observables.

    Every argument except ``method``, ``record_every``, ``reversal_band``, ``parallel`` and
    ``threads`` may be an array; all are broadcast together (vector inputs ``omega``,
    ``orientation`` and ``velocity`` broadcast on their leading axes) and flattened onto a
    ``trajectory`` dimension.

    Parameters
    ----------
    body : Body or array of Body
    spin : rad/s, rotation about the world vertical (positive counter-clockwise from above).
    omega : (..., 3) rad/s, body-frame angular velocity instead of ``spin``.
    roll, pitch, yaw : rad, initial orientation R = R_z(yaw) R_y(pitch) R_x(roll).
    orientation : (..., 4) unit quaternion (w, x, y, z) instead of the angles.
    velocity : (..., 2) m/s, horizontal velocity of G (a sliding launch); default rolling.
    mu, mu_static : kinetic and static Coulomb coefficients; ``inf`` rolls without slip,
        ``0`` is frictionless. ``mu_static`` defaults to ``mu`` and must be >= ``mu``.
    damping : N m s, viscous torque −damping·ω.
    g : m/s², gravitational acceleration.
    dt : s, time step; default 1/64 of the body's shortest small-oscillation period.
    t_end : s, end time; each trajectory takes ceil(t_end/dt) steps.
    method : "rk4" (default) or "euler" (semi-implicit, first order).
    record_every : record every k-th step into time-series variables over
        (trajectory, time); needs one dt and t_end for the whole batch. Off by default.
    reversal_band : hysteresis of the reversal detector, a fraction of |initial spin|.
    parallel : spread blocks of trajectories over numba threads (``threads`` of them,
        default all); ``False`` runs on the calling thread only, releasing the GIL, for
        callers that bring their own parallelism.

    Returns
    -------
    xarray.Dataset over ``trajectory`` with ``first_reversal_time`` (s, NaN when none),
    ``n_reversals``, ``initial_spin``, ``final_spin``, ``mean_final_spin`` (rad/s),
    ``max_tilt`` (rad), ``energy_initial``, ``energy_final``, ``energy_lost`` (J),
    ``slip_fraction``, ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok, capsized,
    lifted_off, non_finite), with every input as a coordinate.
    """
    m = check_method(method)
    rec_every = check_record_every(record_every)
    band = check_band(reversal_band)
    prep = prepare(body, spin=spin, omega=omega, roll=roll, pitch=pitch, yaw=yaw,
                   orientation=orientation, velocity=velocity, mu=mu, mu_static=mu_static,
                   damping=damping, g=g, dt=dt, t_end=t_end)
    if rec_every is not None:
        for name in ("dt", "t_end"):
            values = prep.coords[name][1]
            if np.any(values != values[0]):
                raise ValueError(f"record_every needs a single {name} for the whole batch")
    obs, rec, _ = execute(prep, method=m, record_every=rec_every, band=band,
                          parallel=parallel, threads=threads)
    data = observables_dataset(obs, "trajectory")
    coords: dict[str, Any] = {"trajectory": np.arange(prep.n)}
    if rec is not None:
        data.update(series_dataset(rec, ("trajectory", "time")))
        dt0 = float(prep.coords["dt"][1][0])
        coords["time"] = ("time", np.arange(rec.shape[1]) * record_every * dt0,
                          attrs_for("time"))
    ds = xr.Dataset(data, coords=coords)
    for name, (dims, values) in prep.coords.items():
        attrs = attrs_for(name) if name != "body_name" else {"long_name": "body name"}
        ds = ds.assign_coords({name: (dims, values, attrs)})
    ds = ds.assign_coords({k: v for k, v in VECTOR_COORDS.items() if k in ds.dims})
    ds.attrs.update(run_attrs(method, rec_every, band))
    ds.attrs["batch_shape"] = list(prep.shape)
    return ds


def run_attrs(method: str, record_every: int | None, band: float) -> dict:
    """Global attributes common to every result."""
    return {
        "title": "rattlesweep rattleback simulation",
        "source": f"rattlesweep {__version__}",
        "rattlesweep_version": __version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "method": method,
        "record_every": -1 if record_every is None else record_every,
        "reversal_band": band,
        "Conventions": "CF-1.8",
        "references": "S. Jones and H. E. M. Hunt, Am. J. Phys. 87, 699 (2019), "
                      "doi:10.1119/1.5115498",
    }
