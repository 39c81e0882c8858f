"""Launch conditions: orientation, angular velocity and velocity of G at t = 0.

Conventions (radians, SI):

* ``roll``, ``pitch``, ``yaw`` (rad; or ``roll_deg``, ``pitch_deg``, ``yaw_deg`` in
  degrees, never both forms of one angle) give the orientation R = R_z(yaw) R_y(pitch)
  R_x(roll) (body → world): starting from upright, turn by ``roll`` about the world X axis
  (the body's long axis x at that moment), then by ``pitch`` about the world Y axis, then by
  ``yaw`` about the vertical Z (the same as yaw, then pitch about the new body y, then
  roll about the newest body x). Each turn is right-handed: positive roll raises the
  body's +y side, positive pitch lowers its +x end. Alternatively
  ``orientation=(w, x, y, z)``, a unit quaternion taking body components to world
  components.
* ``spin`` (rad/s) is a rotation about the world vertical, positive counter-clockwise seen
  from above; alternatively ``omega`` gives the body-frame angular velocity (rad/s).
* ``velocity=(vx, vy)`` (m/s, world) launches G sliding; by default G moves so that the
  material contact point is at rest (pure rolling).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validation import as_float_array
from .._rules import UNIT_QUATERNION

__all__ = [
    "quaternion_from_angles",
    "rotation_matrices",
    "up_vector",
    "check_unit_quaternion",
    "tilt_limit_error",
    "UnitsWarning",
    "angles_in_radians",
]


class UnitsWarning(UserWarning):
    """An input whose value makes sense only in other units: a tilt angle given in
    radians that can only be degrees typed as radians (``roll=30``)."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so


def angles_in_radians(
    given: dict[str, Any], *, full_ellipsoid: bool, stacklevel: int = 3
) -> dict[str, Any]:
    """``roll``, ``pitch``, ``yaw`` in radians from the radian or the degree form of each
    (``given`` maps ``roll`` and ``roll_deg`` etc. to a value or None). Raises ValueError
    when both forms of one angle are given. Warns (:class:`UnitsWarning`) when a tilt
    angle (roll or pitch) given in radians exceeds what a launch can mean in radians:
    |angle| > pi/2 for a semi-ellipsoid (its rim would be on the floor), > pi for a full
    ellipsoid (``full_ellipsoid`` True when every body is one)."""
    out: dict[str, Any] = {}
    limit = math.pi if full_ellipsoid else math.pi / 2
    for name in ("roll", "pitch", "yaw"):
        rad, deg = given.get(name), given.get(f"{name}_deg")
        if rad is not None and deg is not None:
            raise ValueError(
                f"give either {name} (rad) or {name}_deg (degrees), not both; "
                f"got {name}={rad!r} and {name}_deg={deg!r}"
            )
        if deg is not None:
            out[name] = np.radians(as_float_array(f"{name}_deg", deg))
            continue
        out[name] = 0.0 if rad is None else rad
        if rad is None or name == "yaw":
            continue
        try:
            if np.iscomplexobj(rad):
                raise TypeError
            values = np.abs(np.asarray(rad, dtype=float))
        except (TypeError, ValueError):  # refused with its name by the checks
            continue
        big = np.isfinite(values) & (values > limit)
        if np.any(big):
            signed = np.broadcast_to(np.asarray(rad, dtype=float), values.shape)
            worst = float(signed[big][np.argmax(values[big])])
            warnings.warn(
                f"{name} = {worst:g} rad ({math.degrees(worst):.0f} degrees) is more than "
                f"{math.degrees(limit):.0f} degrees from upright; {name} is in radians: "
                f"if {worst:g} is in degrees, give {name}_deg={worst:g}",
                UnitsWarning,
                stacklevel=stacklevel,
            )
    return out


def quaternion_from_angles(roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike) -> np.ndarray:
    """Unit quaternions (..., 4) = q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll), angles in rad."""
    roll, pitch, yaw = np.broadcast_arrays(
        *(np.asarray(x, dtype=float) for x in (roll, pitch, yaw))
    )
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ],
        axis=-1,
    )


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices R (..., 3, 3), body to world, of unit quaternions (..., 4) =
    (w, x, y, z)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack(
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1
            ),
            np.stack(
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1
            ),
            np.stack(
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1
            ),
        ],
        -2,
    )


def up_vector(q: np.ndarray) -> np.ndarray:
    """World up-vector in body components, Rᵀ Ẑ (the last row of R), for unit quaternions
    (..., 4)."""
    return rotation_matrices(q)[..., 2, :]


def check_unit_quaternion(q: np.ndarray) -> None:
    """Raise ValueError for a finite quaternion whose norm is not 1 (to 1e-6)."""
    norm = np.linalg.norm(q, axis=-1)
    bad = np.isfinite(norm) & UNIT_QUATERNION.bad(q)
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        raise ValueError(
            f"orientation {UNIT_QUATERNION.message}; "
            f"got |q| = {norm[tuple(idx)]:.9g} at index {tuple(int(i) for i in idx)}"
        )


def tilt_limit_error(tilt_cos: np.ndarray, full: np.ndarray) -> None:
    """Raise ValueError when a semi-ellipsoid would start with its rim on the floor."""
    bad = np.isfinite(tilt_cos) & (tilt_cos <= 0.0) & ~full
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(tilt_cos[tuple(idx)])))))
        # a single launch needs no index
        where = f" at index {tuple(int(i) for i in idx)}" if tilt_cos.size > 1 else ""
        raise ValueError(
            f"roll/pitch/orientation: initial tilt {tilt:.3g} deg{where} "
            f"puts the rim of the semi-ellipsoid on the floor; "
            "the tilt from upright must be below 90 deg"
        )
