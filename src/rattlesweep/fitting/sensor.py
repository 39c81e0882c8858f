"""The gyroscope on a measured rattleback: its axes relative to the body's, and its mass.

A sensor fixed to the body reads ``R @ omega`` (body-frame ``omega``, rad/s) plus a bias
per axis. ``R`` is given either as a matrix (``sensor_rotation``) or by three angles in
degrees, each fixed or fitted: the sensor's axes are the body's turned by
``sensor_yaw_deg`` about z, then ``sensor_pitch_deg`` about the turned y, then
``sensor_roll_deg`` about the twice-turned x (intrinsic z-y'-x''). A phone lying flat on
the flat face, turned in its plane, has only a yaw. The sensor's mass (``sensor_mass``,
kg) at ``sensor_position`` (m, body frame from its origin: the centre of the flat face,
of a full ellipsoid its centre; default the origin) is added to the body as a point
mass: the fitted body carries it.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ..rattleback.body import Body

__all__ = ["ANGLES", "FIXED_ONLY", "SENSOR_NAMES", "rotations", "sensor_body", "split"]

ANGLES = ("sensor_yaw_deg", "sensor_pitch_deg", "sensor_roll_deg")
"""The sensor's angles (degrees): fitted or fixed."""

FIXED_ONLY = ("sensor_mass", "sensor_position")
"""The sensor's mass (kg) and position (m): weighed and measured, so fixed only."""

SENSOR_NAMES = ANGLES + FIXED_ONLY

UNITS = {"sensor_mass": "kg", "sensor_position": "m"}


def split(given: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the simulate inputs, the sensor's) of a mapping of fixed inputs."""
    sensor = {k: v for k, v in given.items() if k in SENSOR_NAMES}
    rest = {k: v for k, v in given.items() if k not in SENSOR_NAMES}
    return rest, sensor


def check(sensor: Mapping[str, Any], kind: str, matrix: Any) -> None:
    """Refuse sensor inputs that cannot apply, naming them: any on heading data, angles
    beside a matrix, a mass that is not positive, a position that is not 3 numbers."""
    if kind != "gyro":
        names = sorted(n for n in sensor if n in ANGLES) + (
            ["sensor_rotation"] if matrix is not None else []
        )
        if names:
            raise ValueError(
                f"{', '.join(names)}: a sensor's axes apply to gyroscope data; these "
                "data are a heading"
            )
    if matrix is not None and any(n in sensor for n in ANGLES):
        raise ValueError(
            "give the sensor's axes either as sensor_rotation (a matrix) or by "
            "sensor_yaw_deg/sensor_pitch_deg/sensor_roll_deg, not both"
        )
    if "sensor_mass" in sensor:
        m = sensor["sensor_mass"]
        if not (isinstance(m, (int, float)) and math.isfinite(m) and m > 0):
            raise ValueError(f"sensor_mass must be a positive number of kg, got {m!r}")
    if "sensor_position" in sensor:
        p = np.asarray(sensor["sensor_position"], dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(
                "sensor_position must be three finite numbers (x, y, z in m, body frame "
                f"from the centre of the flat face), got {sensor['sensor_position']!r}"
            )
        if "sensor_mass" not in sensor:
            raise ValueError("sensor_position is given without sensor_mass")
    for name in ANGLES:
        if name in sensor and not math.isfinite(float(sensor[name])):
            raise ValueError(f"{name} must be a finite angle in degrees")


def sensor_body(body: Body, sensor: Mapping[str, Any]) -> Body:
    """The body with the sensor's mass added (the body itself without one)."""
    if "sensor_mass" not in sensor:
        return body
    position = np.asarray(sensor.get("sensor_position", (0.0, 0.0, 0.0)), dtype=float)
    x, y, z = position
    # on the body: within its outline seen from above, and no farther above or below
    # the origin than the body is deep (a phone lying on the flat face is well within)
    if (x / body.a) ** 2 + (y / body.b) ** 2 > 1.0 or abs(z) > body.c:
        raise ValueError(
            f"sensor_position ({x:g}, {y:g}, {z:g}) m is not on the body: it must lie "
            f"within its outline x^2/a^2 + y^2/b^2 <= 1 (a = {body.a:g} m, b = "
            f"{body.b:g} m) and within c = {body.c:g} m of the origin in z (the origin "
            "is the centre of the flat face; of a full ellipsoid, its centre)"
        )
    try:
        return body.with_point_masses([(float(sensor["sensor_mass"]), position)])
    except ValueError as exc:
        raise ValueError(
            f"sensor_mass {sensor['sensor_mass']:g} kg at sensor_position ({x:g}, "
            f"{y:g}, {z:g}) m makes an impossible body: {exc}"
        ) from None


def rotations(yaw_deg: Any, pitch_deg: Any, roll_deg: Any) -> np.ndarray:
    """``R`` (..., 3, 3) with a reading ``R @ omega_body``, for the sensor's angles in
    degrees (arrays broadcast together)."""
    y, p, r = (
        np.radians(np.asarray(v, dtype=float)) for v in (yaw_deg, pitch_deg, roll_deg)
    )
    y, p, r = np.broadcast_arrays(y, p, r)
    cy, sy, cp, sp, cr, sr = (
        np.cos(y),
        np.sin(y),
        np.cos(p),
        np.sin(p),
        np.cos(r),
        np.sin(r),
    )
    # columns of Q = Rz(yaw) Ry(pitch) Rx(roll) are the sensor's axes in the body's
    q = np.empty(y.shape + (3, 3))
    q[..., 0, 0] = cy * cp
    q[..., 0, 1] = cy * sp * sr - sy * cr
    q[..., 0, 2] = cy * sp * cr + sy * sr
    q[..., 1, 0] = sy * cp
    q[..., 1, 1] = sy * sp * sr + cy * cr
    q[..., 1, 2] = sy * sp * cr - cy * sr
    q[..., 2, 0] = -sp
    q[..., 2, 1] = cp * sr
    q[..., 2, 2] = cp * cr
    return np.swapaxes(q, -1, -2)
