"""Where the body touches the floor, and what friction does there: post-processing of a
recorded :func:`rattlesweep.simulate` run (the picture behind the spin bias).

Everything is computed from the run's own series (quaternion, position, friction force,
ω) and its attributes (geometry, centre of mass, inertia), with the closed-form contact
point of docs/model.md, so it needs no body object and works on a run read back
from netCDF.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .launch import rotation_matrices
from .metadata import attrs_for

__all__ = ["CONTACT_ATTRS", "RUN_SERIES", "check_run", "body_geometry", "contact_dataset"]

CONTACT_ATTRS = {
    "contact_body": (
        "m",
        "contact point on the body, body frame (origin at the centre of the flat face)",
    ),
    "contact_floor": ("m", "contact point on the floor, world frame"),
    "lever": ("m", "contact point relative to the centre of mass, world frame"),
    "friction_couple": (
        "N m",
        "vertical moment of the friction force about the centre of mass",
    ),
    "impulse_couple": (
        "N m s",
        "vertical moment about the centre of mass of the "
        "re-stick friction impulses since the previous sample",
    ),
    "angular_momentum_z": (
        "kg m2 s-1",
        "vertical component of the angular momentum about the centre of mass",
    ),
}


RUN_SERIES = ("quaternion", "position", "friction_force", "friction_impulse", "omega")


def check_run(run: object) -> None:
    """Raise ValueError unless ``run`` is a recorded :func:`rattlesweep.simulate` result
    (or its file): a Dataset over ``time`` with the series contact kinematics needs."""
    if not isinstance(run, xr.Dataset) or "time" not in run.dims:
        raise ValueError(
            "run must be an xarray.Dataset over 'time' (a rattlesweep.simulate "
            f"result or its netCDF file), got {type(run).__name__}"
        )
    for name in RUN_SERIES:
        if name not in run:
            raise ValueError(
                f"run has no variable {name!r}; contact kinematics need a "
                "rattlesweep.simulate result (or its netCDF file)"
            )


def _run_attr(run: xr.Dataset, name: str) -> np.ndarray:
    if name not in run.attrs:
        raise ValueError(
            f"run has no attribute {name!r}; contact_dataset needs a "
            "rattlesweep.simulate result (or its netCDF file)"
        )
    return np.asarray(run.attrs[name], dtype=float)


def body_geometry(run: xr.Dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Semi-axes (a, b, c) (m), centre of mass in body axes (m) and the inertia tensor
    about it (kg m²), from a run's attributes."""
    axes = np.array([_run_attr(run, k) for k in ("a", "b", "c")])
    com = _run_attr(run, "com").reshape(3)
    i = {
        k: float(_run_attr(run, f"inertia_{k}"))
        for k in ("xx", "yy", "zz", "xy", "xz", "yz")
    }
    inertia = np.array(
        [
            [i["xx"], i["xy"], i["xz"]],
            [i["xy"], i["yy"], i["yz"]],
            [i["xz"], i["yz"], i["zz"]],
        ]
    )
    return axes, com, inertia


def contact_dataset(run: xr.Dataset) -> xr.Dataset:
    """Contact kinematics of a recorded run, over its ``time``.

    Returns an ``xarray.Dataset`` with ``contact_body`` (time, body_axis; m), the contact
    point on the body's curved surface in body axes; ``contact_floor`` (time, horizontal;
    m), its trace on the floor; ``lever`` (time, axis; m), the contact point relative to
    G in world axes; ``friction_couple`` (time; N m), the vertical moment about G of the
    friction force, (r × F)·Z (the normal force is vertical and has none); and
    ``impulse_couple`` (time; N m s), the same for the plastic impulses that bring a
    slipping contact to rest (summed since the previous sample); and
    ``angular_momentum_z`` (time; kg m² s⁻¹), Z·(R I ω). Without damping friction is the
    only vertical moment about G, so the time integral of the couple plus the impulse
    couples equals the change of ``angular_momentum_z``: that is how friction turns the
    spin round.
    """
    check_run(run)
    axes, com, inertia = body_geometry(run)
    rot = rotation_matrices(run.quaternion.transpose("time", "quaternion_component").values)
    up = rot[:, 2, :]  # world Z in body axes
    d = axes**2
    # The lowest point of x²/a² + y²/b² + z²/c² = 1 is where the outward normal is −up.
    contact = -d * up / np.sqrt((d * up * up).sum(-1, keepdims=True))
    lever = np.einsum("tij,tj->ti", rot, contact - com)
    floor = run.position.transpose("time", "axis").values + lever
    force = run.friction_force.transpose("time", "horizontal").values
    couple = lever[:, 0] * force[:, 1] - lever[:, 1] * force[:, 0]
    # impulses act at the step's start, on the lever of the sample they are recorded with
    # (exact when every step is recorded)
    impulse = run.friction_impulse.transpose("time", "horizontal").values
    impulse_couple = lever[:, 0] * impulse[:, 1] - lever[:, 1] * impulse[:, 0]
    omega = run.omega.transpose("time", "body_axis").values
    l_z = np.einsum("ti,ij,tj->t", up, inertia, omega)

    def var(
        name: str, dims: tuple[str, ...], values: np.ndarray
    ) -> tuple[tuple[str, ...], np.ndarray, dict[str, str]]:
        units, long_name = CONTACT_ATTRS[name]
        return (dims, values, {"units": units, "long_name": long_name})

    return xr.Dataset(
        {
            "contact_body": var("contact_body", ("time", "body_axis"), contact),
            "contact_floor": var("contact_floor", ("time", "horizontal"), floor[:, :2]),
            "lever": var("lever", ("time", "axis"), lever),
            "friction_couple": var("friction_couple", ("time",), couple),
            "impulse_couple": var("impulse_couple", ("time",), impulse_couple),
            "angular_momentum_z": var("angular_momentum_z", ("time",), l_z),
        },
        coords={
            "time": ("time", run.time.values, attrs_for("time")),
            "body_axis": ["x", "y", "z"],
            "horizontal": ["X", "Y"],
            "axis": ["X", "Y", "Z"],
        },
    )
