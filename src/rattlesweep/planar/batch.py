"""Batches of planar launches through the kernel: validation, packing, results.

:func:`run_planar_batch` broadcasts every per-trajectory input (arrays of bodies too) and
flattens the batch onto one ``trajectory`` dimension whose coordinates are the inputs, as
:func:`rattlesweep.run_batch` does for the 3-D body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from ..batch import (
    _as_float, _fail, _numba_threads, as_bodies, check_method, check_record_every, run_attrs,
)
from ..core import planar as K
from ..core.layout import BLOCK
from .body import PlanarBody
from .metadata import attrs_for

TITLE = "rattlesweep planar rocking semi-ellipse simulation"


@dataclass(frozen=True)
class PlanarPrepared:
    """A validated planar batch packed into kernel blocks (see :mod:`rattlesweep.core.planar`)."""

    P: np.ndarray  # (n_blocks, N_PARAM, BLOCK)
    Y: np.ndarray  # (n_blocks, N_STATE, BLOCK)
    nsteps: np.ndarray  # (n_blocks, BLOCK) int64; 0 for padding lanes
    n: int  # trajectories
    shape: tuple[int, ...]  # broadcast shape of the inputs
    coords: dict[str, np.ndarray]  # name -> flat values over the trajectories


def prepare_planar(body, *, theta, rate=0.0, velocity=None, mu=math.inf, mu_static=None,
                   g=9.81, dt=None, t_end) -> PlanarPrepared:
    """Validate and broadcast planar launch inputs and pack them for the kernel.

    See :func:`run_planar_batch` for the arguments. Raises ValueError naming the parameter,
    the value and the rule for any invalid input. Non-finite launch values (theta, rate,
    velocity) are not errors: those trajectories get the status ``non_finite``.
    """
    if theta is None:
        raise ValueError("theta (rad) is required")
    if t_end is None:
        raise ValueError("t_end (s) is required")
    bodies = as_bodies(body, PlanarBody)
    inputs = {"theta": theta, "rate": rate, "mu": mu,
              "mu_static": mu if mu_static is None else mu_static, "g": g, "t_end": t_end}
    if velocity is not None:
        inputs["velocity"] = velocity
    if dt is not None:
        inputs["dt"] = dt
    arrays = {k: _as_float(k, v) for k, v in inputs.items()}
    try:
        shape = np.broadcast_shapes(bodies.shape, *(v.shape for v in arrays.values()))
    except ValueError:
        shapes = {k: v.shape for k, v in arrays.items()}
        raise ValueError(f"inputs cannot be broadcast together: shapes {shapes}, "
                         f"body {bodies.shape}") from None

    # --- parameter rules (launch values may be non-finite: flagged, not refused) -------
    th = arrays["theta"]
    _fail("theta", th, np.isfinite(th) & (np.abs(th) >= math.pi / 2),
          "must be in (-pi/2, pi/2) rad (at |theta| = pi/2 the flat edge reaches the floor)")
    mu_k, mu_s = arrays["mu"], arrays["mu_static"]
    _fail("mu", mu_k, ~(mu_k >= 0), "must be >= 0 (inf for pure rolling)")
    _fail("mu_static", mu_s, ~(mu_s >= 0), "must be >= 0 (inf for pure rolling)")
    bad = mu_s < mu_k
    _fail("mu_static", np.broadcast_to(mu_s, bad.shape), bad, "must be >= mu")
    for name in ("g", "t_end") + (("dt",) if "dt" in arrays else ()):
        v = arrays[name]
        _fail(name, v, ~(np.isfinite(v) & (v > 0)), "must be finite and > 0")

    n = int(np.prod(shape))
    flat = {k: np.broadcast_to(v, shape).reshape(n) for k, v in arrays.items()}
    flat_bodies = np.broadcast_to(bodies, shape).reshape(n)
    rows = np.array([[b.a, b.b, b.com_depth, b.mass, b.inertia] for b in flat_bodies])
    a, b, depth, mass, inertia = rows.T
    if "dt" not in flat:
        cache: dict[tuple[int, float], float] = {}
        flat["dt"] = np.array([
            cache.setdefault((id(bd), gi), bd.default_dt(float(gi)))
            for bd, gi in zip(flat_bodies, flat["g"])])
    nsteps = np.maximum(np.ceil(flat["t_end"] / flat["dt"] * (1.0 - 1e-12)), 1).astype(np.int64)

    # --- initial state: rolling (contact point at rest) unless a velocity is given ------
    rate0 = flat["rate"]
    h = np.array([bd.height(t) for bd, t in zip(flat_bodies, flat["theta"])])
    rolling = 0.0 - rate0 * h  # (not -rate0 * h: no -0.0 for a launch at rest)
    if "velocity" in flat:
        v0 = flat["velocity"]
        sliding = np.isfinite(v0) & np.isfinite(rolling) & (v0 != rolling)
        _fail("velocity", v0, sliding & np.isinf(flat["mu_static"]),
              "makes a sliding launch, which needs a finite mu_static")
    else:
        v0 = rolling

    n_blocks = -(-n // BLOCK)
    n_pad = n_blocks * BLOCK
    P = np.empty((K.N_PARAM, n_pad))
    Y = np.zeros((K.N_STATE, n_pad))
    steps = np.zeros(n_pad, dtype=np.int64)

    def fill(arr, row, values):
        arr[row, :n] = values
        arr[row, n:] = values[0]  # padding lanes copy a valid trajectory and take 0 steps

    for row, values in ((K.A2, a * a), (K.B2, b * b), (K.AB2, a * a * b * b),
                        (K.DEPTH, depth), (K.MASS, mass), (K.INERTIA, inertia),
                        (K.MU_K, flat["mu"]), (K.MU_S, flat["mu_static"]),
                        (K.GRAV, flat["g"]), (K.DT, flat["dt"]),
                        (K.EPS_U, 1e-6 * flat["g"] * flat["dt"])):
        fill(P, row, values)
    fill(Y, K.THETA, flat["theta"])
    fill(Y, K.RATE, rate0)
    fill(Y, K.VXG, v0)
    steps[:n] = nsteps
    blocked = lambda arr: np.ascontiguousarray(
        arr.reshape(arr.shape[0], n_blocks, BLOCK).transpose(1, 0, 2))

    coords = {
        "launch_angle": flat["theta"], "launch_rate": rate0, "launch_velocity": v0,
        "mu": flat["mu"], "mu_static": flat["mu_static"], "g": flat["g"], "dt": flat["dt"],
        "t_end": flat["t_end"], "a": a, "b": b, "mass": mass, "com_depth": depth,
        "inertia": inertia, "body_name": np.array([bd.name for bd in flat_bodies]),
    }
    return PlanarPrepared(blocked(P), blocked(Y), steps.reshape(n_blocks, BLOCK), n,
                          tuple(shape), coords)


def execute_planar(prep: PlanarPrepared, *, method: int, record_every: int | None,
                   parallel: bool = True, threads: int | None = None):
    """Run a prepared batch. Returns (observables (N_OBS, n), records (n, n_rec, N_REC) or
    None, final state (N_STATE, n))."""
    n_blocks = prep.P.shape[0]
    n_rec = 0 if record_every is None else int(prep.nsteps.max()) // record_every + 1
    REC = np.empty((n_blocks, n_rec, K.N_REC, BLOCK))
    O = np.empty((n_blocks, K.N_OBS, BLOCK))
    Y = prep.Y.copy()
    entry = K.integrate_parallel if parallel else K.integrate_serial
    with _numba_threads(threads):
        entry(prep.P, Y, prep.nsteps, method, record_every or 1, O, REC)
    unblock = lambda arr: arr.transpose(1, 0, 2).reshape(arr.shape[1], -1)[:, :prep.n]
    rec = None
    if n_rec:
        rec = REC.transpose(0, 3, 1, 2).reshape(n_blocks * BLOCK, n_rec, K.N_REC)[:prep.n]
    return unblock(O), rec, unblock(Y)


def observables(obs: np.ndarray, dim: str | None) -> dict[str, xr.DataArray]:
    """Per-run observables as labelled DataArrays over ``dim`` (scalars for None)."""
    pick = (lambda row: obs[row]) if dim else (lambda row: obs[row, 0])
    out = {
        "energy_initial": pick(K.O_E0),
        "energy_final": pick(K.O_E_END),
        "energy_lost": pick(K.O_E0) - pick(K.O_E_END),
        "slip_fraction": pick(K.O_SLIP_FRAC),
        "max_angle": pick(K.O_MAX_ANGLE),
        "final_angle": pick(K.O_FINAL_ANGLE),
        "final_rate": pick(K.O_FINAL_RATE),
        "t_final": pick(K.O_T_END),
        "steps": pick(K.O_STEPS).astype(np.int64),
        "status": pick(K.O_STATUS).astype(np.int8),
    }
    dims = (dim,) if dim else ()
    return {k: xr.DataArray(v, dims=dims, attrs=attrs_for(k)) for k, v in out.items()}


def series(rec: np.ndarray, dims: tuple[str, ...]) -> dict[str, xr.DataArray]:
    """Recorded time series (..., n_rec, N_REC) as labelled DataArrays."""
    rows = {"angle": K.R_ANGLE, "rate": K.R_RATE, "x_G": K.R_XG, "y_G": K.R_YG,
            "velocity_x": K.R_VX, "velocity_y": K.R_VY, "slip_velocity": K.R_U,
            "normal_force": K.R_N, "friction_force": K.R_F, "energy": K.R_ENERGY,
            "slipping": K.R_SLIP}
    out = {k: xr.DataArray(rec[..., row], dims=dims, attrs=attrs_for(k))
           for k, row in rows.items()}
    out["slip_speed"] = xr.DataArray(np.abs(rec[..., K.R_U]), dims=dims,
                                     attrs=attrs_for("slip_speed"))
    return out


def planar_run_attrs(method: str, record_every: int | None) -> dict:
    """Global attributes of a planar result."""
    attrs = run_attrs(method, record_every, 0.0)
    attrs.pop("reversal_band", None)  # no spin, no reversals in the plane
    attrs["title"] = TITLE
    attrs["model"] = "MODEL.md section 8: rocking half-ellipse lamina"
    return attrs


def run_planar_batch(
    body: PlanarBody | Any,
    *,
    theta, rate=0.0, velocity=None, mu=math.inf, mu_static=None, g=9.81, dt=None, t_end,
    method: str = "rk4", record_every: int | None = None, parallel: bool = True,
    threads: int | None = None,
) -> xr.Dataset:
    """Integrate many planar launches at once; return per-trajectory observables.

    Every argument except ``method``, ``record_every``, ``parallel`` and ``threads`` may be
    an array; all are broadcast together and flattened onto a ``trajectory`` dimension.

    Parameters
    ----------
    body : PlanarBody or array of PlanarBody
    theta : rad, initial rocking angle, |theta| < pi/2 (counter-clockwise).
    rate : rad/s, initial dθ/dt.
    velocity : m/s, initial horizontal velocity of G; default rolling, ẋ_G = −rate·h(θ).
        A velocity other than the rolling one launches the body sliding.
    mu, mu_static : kinetic and static Coulomb coefficients; ``inf`` rolls without slip,
        ``0`` is frictionless; ``mu_static`` defaults to ``mu`` and must be >= ``mu``.
    g : m/s², gravitational acceleration.
    dt : s, time step; default 1/64 of the body's shorter small-rocking period.
    t_end : s, end time; each trajectory takes ceil(t_end/dt) steps.
    method : "rk4" (default) or "euler" (semi-implicit, first order).
    record_every : record every k-th step into time series over (trajectory, time); needs
        one dt and t_end for the whole batch. Off by default.
    parallel : spread blocks of trajectories over numba threads (``threads`` of them,
        default all); ``False`` runs on the calling thread only, releasing the GIL.

    Returns
    -------
    xarray.Dataset over ``trajectory`` with ``energy_initial``, ``energy_final``,
    ``energy_lost`` (J), ``slip_fraction``, ``max_angle``, ``final_angle`` (rad),
    ``final_rate`` (rad/s), ``t_final`` (s), ``steps`` and ``status`` (CF flags: ok,
    capsized, lifted_off, non_finite), with every input as a coordinate (``launch_angle``,
    ``launch_rate``, ``launch_velocity`` — the velocity actually used —, ``mu``, ...,
    and the body's ``a``, ``b``, ``mass``, ``com_depth``, ``inertia``, ``body_name``).
    """
    m = check_method(method)
    rec_every = check_record_every(record_every)
    prep = prepare_planar(body, theta=theta, rate=rate, velocity=velocity, mu=mu,
                          mu_static=mu_static, g=g, dt=dt, t_end=t_end)
    if rec_every is not None:
        for name in ("dt", "t_end"):
            values = prep.coords[name]
            if np.any(values != values[0]):
                raise ValueError(f"record_every needs a single {name} for the whole batch")
    obs, rec, _ = execute_planar(prep, method=m, record_every=rec_every, parallel=parallel,
                                 threads=threads)
    data = observables(obs, "trajectory")
    coords: dict[str, Any] = {"trajectory": np.arange(prep.n)}
    if rec is not None:
        data.update(series(rec, ("trajectory", "time")))
        coords["time"] = ("time", np.arange(rec.shape[1]) * rec_every * prep.coords["dt"][0],
                          attrs_for("time"))
    ds = xr.Dataset(data, coords=coords)
    ds = ds.assign_coords({k: ("trajectory", v, attrs_for(k)) for k, v in prep.coords.items()})
    ds.attrs.update(planar_run_attrs(method, rec_every))
    ds.attrs["batch_shape"] = list(prep.shape)
    return ds
