"""The two models of the event-driven reference solver (tests/event_reference.py): the
rattleback and the planar rocking semi-ellipse, each with its modes' right-hand sides,
contact forces and switching functions, written from MODEL.md's equations; and the
constants and small helpers they share with the driver."""

from __future__ import annotations

import math

import numpy as np

ONSET_SPEED = 1e-7  # m/s: slip speed below which the consistent onset direction is used
REFRESH_ANGLE = math.radians(30.0)  # new slip segment when u turns this far from u_ref
ZERO_SLIP = 1e-12  # m/s: a launch slip speed at or below this is rounding (rolling launch)
STICK, SLIP, ONSET, FREE = "stick", "slip", "onset", "free"


# --------------------------------------------------------------------------------------
# small vector helpers (3-vectors as numpy arrays)
def _cross(a, b):
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _event(fun, terminal, direction):
    fun.terminal = terminal
    fun.direction = direction
    return fun


# --------------------------------------------------------------------------------------
# the 3-D model
class _Rattleback:
    def __init__(self, body, mu, mu_static, g, damping):
        self.m = float(body.mass)
        self.g = float(g)
        self.A = np.array([body.a**2, body.b**2, body.c**2], dtype=float)
        self.G = np.asarray(body.com, dtype=float).copy()
        self.I = np.asarray(body.inertia, dtype=float).copy()
        self.I_inv = np.linalg.inv(self.I)
        self.full = bool(body.full_ellipsoid)
        self.mu_k = float(mu)
        self.mu_s = float(mu) if mu_static is None else float(mu_static)
        self.cv = float(damping)
        self.onset_fallbacks = 0  # onset_direction calls that kept the guess
        if not (self.mu_s >= self.mu_k >= 0.0):
            raise ValueError(f"need mu_static >= mu >= 0, got {self.mu_s}, {self.mu_k}")

    # geometry ----------------------------------------------------------------------
    @staticmethod
    def rotation(q):
        q0, q1, q2, q3 = q
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        return np.array(
            [
                [
                    1 - s * (q2 * q2 + q3 * q3),
                    s * (q1 * q2 - q0 * q3),
                    s * (q1 * q3 + q0 * q2),
                ],
                [
                    s * (q1 * q2 + q0 * q3),
                    1 - s * (q1 * q1 + q3 * q3),
                    s * (q2 * q3 - q0 * q1),
                ],
                [
                    s * (q1 * q3 - q0 * q2),
                    s * (q2 * q3 + q0 * q1),
                    1 - s * (q1 * q1 + q2 * q2),
                ],
            ]
        )

    def kin(self, y):
        """R, n_hat, rho, w = omega x (omega x rho + ds_P/dt), omega x rho, horizontal u."""
        R = self.rotation(y[0:4])
        w = y[4:7]
        up = R[2]
        an = self.A * up
        sigma = math.sqrt(up @ an)
        rho = -an / sigma - self.G
        dup = _cross(up, w)
        dsp = -self.A * dup / sigma + an * ((an @ dup) / sigma**3)
        wxr = _cross(w, rho)
        wv = _cross(w, wxr + dsp)
        vrel = R @ wxr
        u = np.array([y[9] + vrel[0], y[10] + vrel[1]])
        return R, up, rho, wv, wxr, u

    def spin(self, y):
        """n = omega . n_hat for a state (11+,) or states (11+, k)."""
        q0, q1, q2, q3 = y[0:4]
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        up = np.array(
            [s * (q1 * q3 - q0 * q2), s * (q2 * q3 + q0 * q1), 1 - s * (q1 * q1 + q2 * q2)]
        )
        return (y[4:7] * up).sum(0)

    def energy(self, y):
        R, up, rho, wv, wxr, u = self.kin(y)
        w = y[4:7]
        vz = -(up @ wxr)
        return (
            0.5 * self.m * (y[9] ** 2 + y[10] ** 2 + vz**2)
            + 0.5 * w @ (self.I @ w)
            - self.m * self.g * (rho @ up)
        )

    # dynamics ----------------------------------------------------------------------
    def stick(self, y, k):
        """Stick: omega_dot, world a_G (3), N, world friction F_t (2) needed."""
        R, up, rho, wv, wxr, u = k
        w = y[4:7]
        m = self.m
        M = self.I + m * ((rho @ rho) * np.eye(3) - np.outer(rho, rho))
        rhs = -_cross(w, self.I @ w) - self.cv * w + m * _cross(rho, self.g * up - wv)
        wdot = np.linalg.solve(M, rhs)
        a_g = -(_cross(wdot, rho) + wv)
        F = m * (a_g + self.g * up)
        N = F @ up
        Ft = R @ (F - N * up)
        return wdot, R @ a_g, N, Ft[:2]

    def slip(self, y, k, d, mu):
        """Slip with friction -mu N d (d world horizontal unit 2-vector): omega_dot,
        horizontal a_G (2), N."""
        R, up, rho, wv, wxr, u = k
        w = y[4:7]
        m = self.m
        db = R[0] * d[0] + R[1] * d[1]  # body components of (d, 0)
        l = _cross(rho, up)
        kk = _cross(rho, up - mu * db)
        n0 = m * (self.g - up @ wv)
        rhs = -_cross(w, self.I @ w) - self.cv * w + n0 * kk
        wdot = np.linalg.solve(self.I + m * np.outer(kk, l), rhs)
        N = n0 - m * (l @ wdot)
        return wdot, -mu * N / m * np.asarray(d), N

    def slip_acceleration(self, y, k, d, mu):
        """Horizontal acceleration of the material contact point (world, 2) in slip with
        friction -mu N d: du/dt = a_G + R (omega_dot x rho + w)."""
        R, up, rho, wv, wxr, u = k
        wdot, a_h, N = self.slip(y, k, d, mu)
        return a_h + (R @ (_cross(wdot, rho) + wv))[:2]

    def onset_direction(self, y, k, dref):
        """The consistent slip direction at (nearly) zero slip speed: the unit d along
        which the contact point then accelerates or decelerates, du/dt = lambda d (the
        direction u/|u| locks onto it on the time scale |u| / |du/dt|, which is what makes
        small slips stiff). Found by Newton's method on the angle, from u/|u| once |u| is
        clear of rounding, else from ``dref`` (the onset direction -F_t/|F_t|, the limit
        at the onset instant). Holding d = dref instead lets u grow along K d, up to ~90
        degrees away for the kane_levinson contact."""
        mu = self.mu_k
        u = k[5]
        speed = math.hypot(*u)
        guess = u / speed if speed > 1e3 * ZERO_SLIP and u @ dref > 0 else dref
        phi = math.atan2(guess[1], guess[0])

        def cross(p):
            d = np.array([math.cos(p), math.sin(p)])
            a = self.slip_acceleration(y, k, d, mu)
            return a[0] * d[1] - a[1] * d[0]

        g0 = cross(phi)
        for _ in range(12):
            h = 1e-7
            slope = (cross(phi + h) - cross(phi - h)) / (2 * h)
            if slope == 0.0:
                break
            step = max(-0.3, min(0.3, -g0 / slope))
            phi += step
            g0 = cross(phi)
            if abs(step) < 1e-13:
                break
        d = np.array([math.cos(phi), math.sin(phi)])
        if abs(g0) > 1e-9 * (mu * self.g + 1e-300) or d @ guess < math.cos(REFRESH_ANGLE):
            self.onset_fallbacks += 1
            return np.asarray(guess, dtype=float)
        return d

    def assemble(self, y, wdot, a_h, dwork):
        q0, q1, q2, q3 = y[0:4]
        w0, w1, w2 = y[4:7]
        return np.array(
            [
                -0.5 * (q1 * w0 + q2 * w1 + q3 * w2),
                0.5 * (q0 * w0 + q2 * w2 - q3 * w1),
                0.5 * (q0 * w1 + q3 * w0 - q1 * w2),
                0.5 * (q0 * w2 + q1 * w1 - q2 * w0),
                wdot[0],
                wdot[1],
                wdot[2],
                y[9],
                y[10],
                a_h[0],
                a_h[1],
                dwork,
            ]
        )

    def impulse(self, y):
        """The plastic contact impulse J = -K^-1 u that brings the material contact point
        to rest (MODEL.md section 4); returns the new state."""
        R, up, rho, wv, wxr, u = self.kin(y)
        ub = R[0] * u[0] + R[1] * u[1]
        X = np.array(
            [[0.0, -rho[2], rho[1]], [rho[2], 0.0, -rho[0]], [-rho[1], rho[0], 0.0]]
        )  # X v = rho x v
        K = np.eye(3) / self.m - X @ self.I_inv @ X
        J = -np.linalg.solve(K, ub)
        z = np.array(y, dtype=float)
        z[4:7] += self.I_inv @ _cross(rho, J)
        dv = R @ J / self.m
        z[9:11] += dv[:2]
        return z

    # one mode's right-hand side and events -----------------------------------------
    def mode_functions(self, mode, dref, n0, band):
        """(rhs, terminal events as [(name, fun)], observing events [(name, fun)])."""
        mu = self.mu_k
        cv = self.cv

        def power(y, k, N):
            p = cv * (y[4:7] @ y[4:7])
            if mode in (SLIP, ONSET):
                p += mu * N * math.hypot(*k[5])
            return p

        if mode == STICK:

            def rhs(t, y):
                k = self.kin(y)
                wdot, a_g, N, Ft = self.stick(y, k)
                return self.assemble(y, wdot, a_g[:2], cv * (y[4:7] @ y[4:7]))

            def normal(t, y):
                return self.stick(y, self.kin(y))[2]

            terminal = [("lifted_off", _event(normal, True, -1))]
            if math.isfinite(self.mu_s):

                def cone(t, y):
                    _, _, N, Ft = self.stick(y, self.kin(y))
                    return self.mu_s * N - math.hypot(*Ft)

                terminal.append(("stick->slip", _event(cone, True, -1)))
        else:

            def direction(y, k):
                if mode == FREE:
                    return dref
                if mode == ONSET:
                    return self.onset_direction(y, k, dref)
                u = k[5]
                speed = math.hypot(*u)
                if speed == 0.0:
                    return dref
                return u / speed if u @ dref >= 0.0 else -u / speed

            mu_mode = 0.0 if mode == FREE else mu

            def rhs(t, y):
                k = self.kin(y)
                d = direction(y, k)
                wdot, a_h, N = self.slip(y, k, d, mu_mode)
                return self.assemble(y, wdot, a_h, power(y, k, N))

            def normal(t, y):
                k = self.kin(y)
                return self.slip(y, k, direction(y, k), mu_mode)[2]

            terminal = [("lifted_off", _event(normal, True, -1))]
            if mode in (SLIP, ONSET):

                def stop(t, y):
                    return self.kin(y)[5] @ dref

                terminal.append(("stop", _event(stop, True, -1)))
            if mode == ONSET:

                def grown(t, y):
                    return math.hypot(*self.kin(y)[5]) - ONSET_SPEED

                terminal.append(("grown", _event(grown, True, 1)))
            if mode == SLIP:
                cos_max = math.cos(REFRESH_ANGLE)

                def turned(t, y):
                    u = self.kin(y)[5]
                    speed = math.hypot(*u)
                    return 1.0 if speed == 0.0 else abs(u @ dref) / speed - cos_max

                terminal.append(("turned", _event(turned, True, -1)))
        if not self.full:

            def rim(t, y):
                return self.rotation(y[0:4])[2, 2]

            terminal.append(("capsized", _event(rim, True, -1)))
        sgn = math.copysign(1.0, n0) if n0 != 0 else 0.0
        observe = []  # n(0) = 0: no reversal by definition, and n may stay 0 to rounding
        if sgn != 0:
            observe.append(("spin_zero", _event(lambda t, y: self.spin(y), False, 0)))
            observe.append(
                (
                    "band",
                    _event(lambda t, y: sgn * self.spin(y) + band * abs(n0), False, -1),
                )
            )
        return rhs, terminal, observe

    def choose_mode(self, y):
        """Mode at a state where the contact has (nearly) stopped: (mode, direction)."""
        k = self.kin(y)
        if self.mu_s == 0.0:
            return FREE, np.array([1.0, 0.0])
        u = k[5]
        speed = math.hypot(*u)
        if speed > ZERO_SLIP:
            return SLIP, u / speed
        _, _, N, Ft = self.stick(y, k)
        f = math.hypot(*Ft)
        if f <= self.mu_s * N:
            return STICK, None
        return ONSET, -Ft / f

    def normal_force(self, y, mode, dref):
        k = self.kin(y)
        if mode == STICK:
            return self.stick(y, k)[2]
        if mode == FREE:
            return self.slip(y, k, dref, 0.0)[2]
        return self.slip(y, k, dref, self.mu_k)[2]


# --------------------------------------------------------------------------------------
# the planar model
class _Planar:
    def __init__(self, body, mu, mu_static, g):
        self.a, self.b = float(body.a), float(body.b)
        self.m = float(body.mass)
        self.d = float(body.com_depth)
        self.I = float(body.inertia)
        self.g = float(g)
        self.mu_k = float(mu)
        self.mu_s = float(mu) if mu_static is None else float(mu_static)
        if not (self.mu_s >= self.mu_k >= 0.0):
            raise ValueError(f"need mu_static >= mu >= 0, got {self.mu_s}, {self.mu_k}")

    def h(self, th):
        """h, h', h'' (MODEL.md section 8), derived here: sigma' = (a^2-b^2) s c/sigma,
        sigma'' = ((a^2-b^2)(c^2-s^2) - sigma'^2)/sigma."""
        s, c = math.sin(th), math.cos(th)
        a2, b2 = self.a**2, self.b**2
        sig = math.sqrt(a2 * s * s + b2 * c * c)
        sp = (a2 - b2) * s * c / sig
        spp = ((a2 - b2) * (c * c - s * s) - sp * sp) / sig
        return sig - self.d * c, sp + self.d * s, spp + self.d * c

    def slip_velocity(self, y):
        return y[3] + y[1] * self.h(y[0])[0]

    def energy(self, y):
        h, hp, _ = self.h(y[0])
        return (
            0.5 * self.m * (y[3] ** 2 + (hp * y[1]) ** 2)
            + 0.5 * self.I * y[1] ** 2
            + self.m * self.g * h
        )

    def stick(self, y):
        """theta_ddot, x_ddot, N, F (friction needed)."""
        th, r = y[0], y[1]
        h, hp, hpp = self.h(th)
        m, g = self.m, self.g
        acc = -m * hp * (g + (h + hpp) * r * r) / (self.I + m * (h * h + hp * hp))
        xdd = -acc * h - r * r * hp
        return acc, xdd, m * (g + hp * acc + hpp * r * r), m * xdd

    def slip(self, y, s, mu):
        """Friction -mu N s: theta_ddot, x_ddot, N."""
        th, r = y[0], y[1]
        h, hp, hpp = self.h(th)
        m, g = self.m, self.g
        lever = hp + mu * s * h
        den = self.I + m * hp * lever
        if den <= 0.0:
            raise RuntimeError(
                "Painleve: slip equations singular (I + m h'(h' + mu s h) <= 0)"
            )
        acc = -m * (g + hpp * r * r) * lever / den
        N = m * (g + hp * acc + hpp * r * r)
        return acc, -mu * N * s / m, N

    def impulse(self, y):
        h, hp, _ = self.h(y[0])
        m, I = self.m, self.I
        K = np.array([[1 / m + h * h / I, -h * hp / I], [-h * hp / I, 1 / m + hp * hp / I]])
        J = np.linalg.solve(K, [-self.slip_velocity(y), 0.0])
        z = np.array(y, dtype=float)
        z[1] += (h * J[0] - hp * J[1]) / I
        z[3] += J[0] / m
        return z

    def mode_functions(self, mode, s, n0, band):
        mu = self.mu_k
        if mode == STICK:

            def rhs(t, y):
                acc, xdd, N, F = self.stick(y)
                return np.array([y[1], acc, y[3], xdd, 0.0])

            terminal = [("lifted_off", _event(lambda t, y: self.stick(y)[2], True, -1))]
            if math.isfinite(self.mu_s):

                def cone(t, y):
                    _, _, N, F = self.stick(y)
                    return self.mu_s * N - abs(F)

                terminal.append(("stick->slip", _event(cone, True, -1)))
        else:
            mu_mode = 0.0 if mode == FREE else mu

            def rhs(t, y):
                acc, xdd, N = self.slip(y, s, mu_mode)
                return np.array(
                    [y[1], acc, y[3], xdd, mu_mode * N * abs(self.slip_velocity(y))]
                )

            terminal = [
                ("lifted_off", _event(lambda t, y: self.slip(y, s, mu_mode)[2], True, -1))
            ]
            if mode != FREE:
                terminal.append(
                    ("stop", _event(lambda t, y: s * self.slip_velocity(y), True, -1))
                )
        terminal.append(("capsized", _event(lambda t, y: math.cos(y[0]), True, -1)))
        return rhs, terminal, []

    def choose_mode(self, y):
        if self.mu_s == 0.0:
            return FREE, 1.0
        u = self.slip_velocity(y)
        if abs(u) > ZERO_SLIP:
            return SLIP, math.copysign(1.0, u)
        _, _, N, F = self.stick(y)
        if abs(F) <= self.mu_s * N:
            return STICK, None
        return ONSET, -math.copysign(1.0, F)

    def normal_force(self, y, mode, s):
        if mode == STICK:
            return self.stick(y)[2]
        return self.slip(y, s, 0.0 if mode == FREE else self.mu_k)[2]
