"""An independent count of heading reversals from recorded quaternions, in NumPy, and
the published multi-reversal launch the counting is checked on.

The heading is the direction of the body's long (x) axis seen from above. Here it is
taken from the rotation matrix of each recorded quaternion, unwrapped with
``np.unwrap``, and its reversals counted by the documented rule: each time the heading,
having turned one way, turns back by more than ``HEADING_BAND`` from the furthest it
reached; at launch it is followed in the sense of the launch spin. A first reversal
still under way at the end of a run (the spin beyond its band the other way and on that
side ever since, the heading not yet turned back by the band) counts too.
"""

import math

import numpy as np

import rattlesweep as rs
from rattlesweep.rattleback.body import rotated_inertia

HEADING_BAND = 0.1  # rad, as documented in docs/model.md


def heading_from_quaternions(q):
    """Unwrapped heading (rad) of quaternions q (..., 4) = (w, x, y, z), body to world."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    # first column of the rotation matrix: the body x axis in world components
    r00 = w * w + x * x - y * y - z * z
    r10 = 2.0 * (x * y + w * z)
    return np.unwrap(np.arctan2(r10, r00))


def heading_reversal_steps(q, sense, band=HEADING_BAND):
    """Sample indices at which each heading reversal is counted (the turn back first
    exceeds ``band``) for a recorded quaternion series q (n, 4), NaN rows (after the
    run stopped) ignored; ``sense`` is the sign of the launch spin."""
    q = np.asarray(q, dtype=float)
    q = q[np.all(np.isfinite(q), axis=1)]
    psi = heading_from_quaternions(q)
    found = []
    furthest = psi[0]
    for i, p in enumerate(psi):
        if sense * (p - furthest) > 0.0:
            furthest = p
        elif sense * (furthest - p) > band:
            found.append(i)
            sense = -sense
            furthest = p
    return found


def reversal_count(q, spin, band=0.05):
    """The number of reversals of a recorded run by the documented rule, from its
    quaternions q (n, 4) and its spin n (n,) (NaN after the run stopped)."""
    spin = np.asarray(spin, dtype=float)
    spin = spin[np.isfinite(spin)]
    side = np.sign(spin[0])
    count = len(heading_reversal_steps(q, side))
    beyond = np.flatnonzero(side * spin < -band * abs(spin[0]))
    pending = (
        count == 0 and beyond.size > 0 and bool(np.all(side * spin[beyond[0] :] < 0.0))
    )
    return count + int(pending)


def largest_turn_back(q, sense):
    """The largest turn back (rad) of the heading from the furthest it had reached in
    the sense ``sense``, over a run that never reverses."""
    turned = sense * heading_from_quaternions(q)
    return float(np.max(np.maximum.accumulate(turned) - turned))


def wackelstein():
    """Kuypers' "Wackelstein 1": a full ellipsoid a, b, c = 0.2, 0.03, 0.02 m, 1 kg, G
    1 mm below the centre, principal moments (2e-4, 1.6e-3, 1.7e-3) kg m² turned 0.1 rad
    about the vertical, viscous torque 1e-4 N m s, launched rolling from
    R = R_x(-0.02) R_y(-0.02) with body omega = (0, 0, -8) rad/s. Returns (body, the
    launch as run_batch/simulate keywords)."""
    inertia = rotated_inertia(2e-4, 1.6e-3, 1.7e-3, 0.1)
    body = rs.Body(
        0.2,
        0.03,
        0.02,
        1.0,
        (0.0, 0.0, -0.001),
        inertia,
        full_ellipsoid=True,
        name="wackelstein_1",
    )
    c, s = math.cos(-0.01), math.sin(-0.01)
    qx = np.array([c, s, 0.0, 0.0])
    qy = np.array([c, 0.0, s, 0.0])
    w1, x1, y1, z1 = qx
    w2, x2, y2, z2 = qy
    q = np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )
    return body, dict(omega=[0.0, 0.0, -8.0], orientation=q, damping=1e-4)
