"""An independent NumPy model of the rolling rattleback (MODEL.md sections 3, 4 and 6).

Written from the equations, not from the kernel, so that agreement with the kernel is a
real check (``tests/test_oracle.py``); ``benchmarks/bench_kernel.py`` also times it as a
baseline. It uses only the public attributes of a ``rattlesweep.Body`` (a, b, c, mass,
com, inertia, full_ellipsoid), nothing else from rattlesweep.

Rolling only (stick, mu = inf, no damping), vectorised over a batch. State y (11, n):
quaternion (w, x, y, z) body -> world, body-frame omega, horizontal position X, Y and
velocity V_X, V_Y of G.
"""

from __future__ import annotations

import math

import numpy as np


def cross(a, b):
    """a x b for stacks of vectors, shape (3, n)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def solve3(M, b):
    """Solve M x = b for a stack of 3x3 systems, M (3, 3, n), b (3, n), by the adjugate:
    the inverse has columns (r1 x r2, r2 x r0, r0 x r1) / det for the rows r_i."""
    c0, c1, c2 = cross(M[1], M[2]), cross(M[2], M[0]), cross(M[0], M[1])
    det = (M[0] * c0).sum(0)
    return (c0 * b[0] + c1 * b[1] + c2 * b[2]) / det


class NumpyRolling:
    """Rolling (stick) rattleback on a flat floor, RK4 at a fixed step, in plain NumPy."""

    def __init__(self, body, g: float = 9.81):
        self.m = float(body.mass)
        self.g = float(g)
        self.A = np.array([body.a**2, body.b**2, body.c**2])[:, None]
        self.G = np.asarray(body.com, dtype=float)[:, None]
        self.I = np.asarray(body.inertia, dtype=float)
        self.full = bool(body.full_ellipsoid)

    @staticmethod
    def frame(q):
        """First two rows of R(q) and n_hat = R^T Z (its third row), for any non-zero q."""
        q0, q1, q2, q3 = q
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        row0 = np.array(
            [1 - s * (q2 * q2 + q3 * q3), s * (q1 * q2 - q0 * q3), s * (q1 * q3 + q0 * q2)]
        )
        row1 = np.array(
            [s * (q1 * q2 + q0 * q3), 1 - s * (q1 * q1 + q3 * q3), s * (q2 * q3 - q0 * q1)]
        )
        up = np.array(
            [s * (q1 * q3 - q0 * q2), s * (q2 * q3 + q0 * q1), 1 - s * (q1 * q1 + q2 * q2)]
        )
        return row0, row1, up

    def contact(self, up):
        """rho = s_P - G (from G to the contact point), A n_hat and sigma (section 3)."""
        an = self.A * up
        sigma = np.sqrt((up * an).sum(0))
        return -an / sigma - self.G, an, sigma

    def rhs(self, y):
        m, g = self.m, self.g
        q0, q1, q2, q3 = y[0:4]
        w = y[4:7]
        row0, row1, up = self.frame(y[0:4])
        rho, an, sigma = self.contact(up)
        dup = cross(up, w)  # d n_hat / dt in body components
        dsp = -self.A * dup / sigma + an * ((an * dup).sum(0) / sigma**3)  # J dn_hat/dt
        wv = cross(w, cross(w, rho) + dsp)
        # stick: (I + m(|rho|^2 1 - rho rho^T)) wdot = -w x Iw + m rho x (g n_hat - wv)
        M = (
            self.I[:, :, None]
            + m * (rho * rho).sum(0) * np.eye(3)[:, :, None]
            - m * rho[:, None, :] * rho[None, :, :]
        )
        wdot = solve3(M, -cross(w, self.I @ w) + m * cross(rho, g * up - wv))
        a_g = -(cross(wdot, rho) + wv)  # acceleration of G, body components
        dy = np.empty_like(y)
        dy[0] = -0.5 * (q1 * w[0] + q2 * w[1] + q3 * w[2])
        dy[1] = 0.5 * (q0 * w[0] + q2 * w[2] - q3 * w[1])
        dy[2] = 0.5 * (q0 * w[1] + q3 * w[0] - q1 * w[2])
        dy[3] = 0.5 * (q0 * w[2] + q1 * w[1] - q2 * w[0])
        dy[4:7] = wdot
        dy[7:9] = y[9:11]
        dy[9] = (row0 * a_g).sum(0)
        dy[10] = (row1 * a_g).sum(0)
        return dy

    def spin(self, y):
        """n = omega . n_hat (rad/s)."""
        return (y[4:7] * self.frame(y[0:4])[2]).sum(0)

    def initial(self, spin, roll):
        """Rolling launch: tilted by `roll` about body x, spinning at `spin` about the
        vertical, G moving so that the material contact point is at rest."""
        spin = np.atleast_1d(np.asarray(spin, dtype=float))
        y = np.zeros((11, spin.size))
        y[0] = math.cos(roll / 2)
        y[1] = math.sin(roll / 2)
        row0, row1, up = self.frame(y[0:4])
        y[4:7] = spin * up
        v_g = -cross(y[4:7], self.contact(up)[0])  # v_P = v_G + omega x rho = 0
        y[9] = (row0 * v_g).sum(0)
        y[10] = (row1 * v_g).sum(0)
        return y

    def rk4(self, y, dt, nsteps):
        """Classic RK4, the quaternion renormalised after every step. Returns the final
        state and the spin at every step, (nsteps + 1, n). A semi-ellipsoid whose contact
        would leave the curved surface (n_hat_z <= 0, section 3) is set to NaN there."""
        y = np.array(y, dtype=float)
        spins = np.empty((nsteps + 1, y.shape[1]))
        spins[0] = self.spin(y)
        for k in range(nsteps):
            k1 = self.rhs(y)
            k2 = self.rhs(y + 0.5 * dt * k1)
            k3 = self.rhs(y + 0.5 * dt * k2)
            k4 = self.rhs(y + dt * k3)
            y = y + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            y[0:4] /= np.sqrt((y[0:4] ** 2).sum(0))
            if not self.full:
                y[:, ~(self.frame(y[0:4])[2][2] > 0.0)] = np.nan
            spins[k + 1] = self.spin(y)
        return y, spins


def first_reversal(t, spin, band: float = 0.05) -> float:
    """First reversal time of a sampled spin history (MODEL.md section 6): the first
    sample beyond -band*|n0| on the side opposite n0, reported at the last zero crossing
    before it, linearly interpolated. NaN if none (or n0 == 0)."""
    i = reversal_bracket(spin, band)
    if i is None:
        return math.nan
    return t[i + 1] - (t[i + 1] - t[i]) * spin[i + 1] / (spin[i + 1] - spin[i])


def reversal_bracket(spin, band: float = 0.05) -> int | None:
    """Index i such that the first reversal's zero crossing lies in [i, i + 1]."""
    s = np.sign(spin[0])
    if s == 0:
        return None
    beyond = np.flatnonzero(s * spin < -band * abs(spin[0]))
    if beyond.size == 0:
        return None
    return int(np.flatnonzero(s * spin[: beyond[0]] > 0)[-1])
