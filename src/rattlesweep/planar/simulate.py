"""One planar launch, with its time series: :func:`simulate_planar`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from .. import _results as results
from .._options import check_method, check_record_every
from .._run import execute
from .batch import prepare, run_attrs
from .body import PlanarBody
from .metadata import attrs_for

__all__ = ["simulate_planar"]


def simulate_planar(
    body: PlanarBody,
    *,
    theta: float,
    rate: float = 0.0,
    velocity: float | None = None,
    mu: float = math.inf,
    mu_static: float | None = None,
    mu_roll: float = 0.0,
    g: float = 9.81,
    dt: float | None = None,
    t_end: float,
    method: str = "rk4",
    record_every: int | None = None,
) -> xr.Dataset:
    """Simulate one launch of a rocking semi-ellipse and return its time series.

    Arguments are those of :func:`run_planar_batch`, as scalars: ``theta`` (rad, initial
    angle, ``abs(theta) < pi/2``), ``rate`` (rad/s), ``velocity`` (m/s, initial ẋ_G; default
    the rolling one, −rate·h(θ)), ``mu``/``mu_static`` (``inf`` rolling, ``0``
    frictionless), ``mu_roll`` (m, rolling resistance),
    ``g`` (m/s²), ``dt`` (s, default :meth:`PlanarBody.default_dt`), ``t_end`` (s),
    ``method`` ("rk4" or "euler"). ``record_every`` defaults to the smallest stride that
    keeps at most 10 000 samples.

    Returns
    -------
    xarray.Dataset
        Over ``time`` (s): ``angle`` (rad), ``rate`` (rad/s), ``x_G``, ``y_G`` (m),
        ``velocity_x``, ``velocity_y`` (m/s, of G), ``slip_velocity`` and ``slip_speed``
        (m/s, of the material contact point), ``normal_force`` and ``friction_force``
        (N), ``energy`` (J), ``slipping`` (0/1); the per-run observables of
        :func:`run_planar_batch` as scalar variables; every input as an attribute (units
        in ``<name>_units``).

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule.

    Warns
    -----
    RuntimeWarning
        When the run ends with a status other than ``ok``.
    """
    if not isinstance(body, PlanarBody):
        raise ValueError(f"body must be a PlanarBody, got {body!r}")
    m = check_method(method)
    rec_every = check_record_every(record_every)
    inputs: dict[str, Any] = dict(
        theta=theta,
        rate=rate,
        velocity=velocity,
        mu=mu,
        mu_static=mu_static,
        mu_roll=mu_roll,
        g=g,
        dt=dt,
        t_end=t_end,
    )
    for name, value in inputs.items():
        if value is not None and np.ndim(value) != 0:
            raise ValueError(
                f"{name} must be a scalar for simulate_planar(); "
                f"use run_planar_batch for arrays"
            )
    prep = prepare(body, **inputs)
    rec_every = results.default_record_every(prep, rec_every)
    raw = execute(prep, method=m, record_every=rec_every, parallel=False)
    config = {
        "body": body.describe(),
        "launch": {k: (None if v is None else float(v)) for k, v in inputs.items()},
        "dt_used": float(prep.coords["dt"][1][0]),
        "method": method,
        "record_every": rec_every,
    }
    return results.run_dataset(
        prep, raw, rec_every, attrs_for, run_attrs(method, rec_every), config
    )
