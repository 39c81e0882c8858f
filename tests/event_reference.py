"""An independent event-driven reference solver for Coulomb stick/slip
(MODEL.md 3, 4, 6, 8).

Written from MODEL.md's equations, not from the kernel, so that the kernel's fixed-step
Coulomb switching can be checked against it (``tests/test_event_reference.py``,
``tests/data/make_event_reference.py``). It uses only public attributes of a
``rattlesweep.Body`` (a, b, c, mass, com, inertia, full_ellipsoid) and of a
``rattlesweep.planar.PlanarBody`` (a, b, mass, com_depth, inertia); :func:`launch_state`
reads a launch state from a recorded run of the public API.

Method. Each mode (stick, slip) is a smooth ODE integrated by ``scipy.integrate.solve_ivp``
(tight tolerances, dense output) up to a terminal event that ends the segment; the next
segment restarts in the new mode from the state at the event. The default integrator is
LSODA: a slip whose speed |u| is small is stiff (the slip direction relaxes on the time
scale |u| / |du/dt|, ~1e-7 s at the end of an onset), which makes DOP853 crawl through
long near-marginal slips (the kane_levinson launch at mu = 0.3 did not finish 3 s in
5 minutes) and on which Radau failed ("required step size is less than spacing") near a
stop. Over the first 0.4 s of that launch DOP853, LSODA and BDF agree to 1e-8 rad/s in
spin and 1e-9 in slip fraction; LSODA at rtol 1e-10 and 1e-12 agree to ~1e-8 rad/s.

* stick -> slip when mu_s N - |F_t| falls through 0 (F_t the friction sticking needs). The
  slip starts from u = 0. While |u| < ``ONSET_SPEED`` (1e-7 m/s, an "onset" segment) the
  friction direction is the consistent one, d with du/dt parallel to d (Newton's method on
  the angle, from the onset direction -F_t/|F_t| of MODEL.md, which is its limit at the
  onset instant); then u_hat = u/|u|. Why not simply hold -F_t/|F_t|: the contact matrix
  of the kane_levinson body is far from isotropic, so with the direction held u grows along
  K u_hat, measured up to 88 degrees away from u_hat; switching to u/|u| then made u turn
  and stop within microseconds and slip again (spurious stop/slip pairs), and the results
  depended on the hold threshold linearly (5.8e-6 in slip fraction at 1e-7 m/s). With the
  consistent direction, thresholds 3e-8, 1e-7 and 1e-6 m/s agree to 1e-9 in slip fraction
  and 3e-8 rad/s in spin over 3 s. (Much below 1e-7 the slip is so stiff, relaxation time
  |u| / |du/dt|, that the integration crawls.)
* slip -> stick when the slip velocity reaches zero, located as the downward zero of
  u . u_ref (u_ref the slip direction at the start of the segment), which crosses
  transversally while |u| has a kink. The friction direction in a slip segment is
  sign(u . u_ref) u/|u|: u/|u| before the stop, continued smoothly (not flipped) past it,
  so that the integrator's step over the stop stays smooth and the event is located to
  rounding. A new segment (fresh u_ref) starts whenever the angle between u and u_ref
  reaches ``REFRESH_ANGLE`` (30 degrees). At the stop the plastic impulse J = -K^-1 u of
  MODEL.md section 4 removes the residual (~1e-13 m/s), and the cone is checked at once:
  within it the contact sticks, outside it slips on at once in the new onset direction.
* N falling through 0 stops the run (``status = "lifted_off"``); for a semi-ellipsoid, the
  contact reaching the rim (n_hat_z = 0) stops it too (``"capsized"``).

mu = inf is pure rolling (no switching); mu_static = 0 is frictionless. The dissipated work
W(t) = int (mu_k N |u| + c_v |omega|^2) dt is integrated as an extra state component, so
that E(t) + W(t) = E(0) checks the energy balance of MODEL.md section 4 along the solution.

State y of the 3-D model (11): q0..q3 (body -> world unit quaternion, (w, x, y, z)), body
omega (3), X_G, Y_G, V_X, V_Y, exactly as in ``tests/numpy_oracle.py``. Planar (4): theta,
theta_dot, x_G, x_G_dot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy
from scipy.integrate import solve_ivp

__all__ = [
    "EventSolution",
    "PlanarEventSolution",
    "rattleback_events",
    "planar_events",
    "rattleback_regularized",
    "launch_state",
    "first_reversal_from_events",
    "SCIPY_VERSION",
]

SCIPY_VERSION = scipy.__version__
ONSET_SPEED = 1e-7  # m/s: slip speed below which the consistent onset direction is used
REFRESH_ANGLE = math.radians(30.0)  # new slip segment when u turns this far from u_ref
ZERO_SLIP = 1e-12  # m/s: a launch slip speed at or below this is rounding (rolling launch)
MAX_ZERO_SEGMENTS = 50  # consecutive segments of zero length before giving up (chatter)
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
# results
@dataclass
class _Segment:
    t0: float
    t1: float
    mode: str
    sol: object  # scipy OdeSolution over [t0, t1]


@dataclass
class _Solution:
    """Common part of the 3-D and planar results."""

    t: np.ndarray  # sample times (s)
    slipping: np.ndarray  # 0/1 at the samples (1 on slip and onset segments)
    switch_times: list  # [(t, "stick->slip" | "slip->stick")]
    slip_fraction: float  # time fraction slipping over [0, t_final]
    energy: np.ndarray  # J, at the samples
    work: np.ndarray  # J, dissipated work since t = 0, at the samples
    status: str  # "ok", "lifted_off", "capsized"
    t_final: float
    t_end: float
    segments: list = field(repr=False)
    reslips: list = field(default_factory=list)  # stops at which the cone was exceeded
    nfev: int = 0
    options: dict = field(default_factory=dict)
    initial_mode: str = STICK  # "stick" or "slip" at t = 0 (not listed in switch_times)

    def slip_fraction_until(self, t):
        """Time fraction slipping over [0, t] (t <= t_final)."""
        busy = sum(max(0.0, min(s.t1, t) - s.t0) for s in self.segments if s.mode != STICK)
        return busy / t

    def state(self, t):
        """Full state (n_state,) or (len(t), n_state) at any time(s) in [0, t_final],
        from the segments' dense output (continuous across switches up to the plastic
        impulse, ~1e-13 m/s). The last component is the dissipated work W."""
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        starts = np.array([s.t0 for s in self.segments])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        out = np.empty((t.size, self.segments[0].sol(self.segments[0].t0).size))
        for k in np.unique(idx):
            sel = idx == k
            out[sel] = self.segments[k].sol(t[sel]).T
        return out[0] if scalar else out

    def mode_at(self, t):
        """1 where slipping (slip or onset segment), 0 where sticking, at time(s) t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.array([s.t0 for s in self.segments])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        slip = np.array([s.mode in (SLIP, ONSET, FREE) for s in self.segments])
        return slip[idx].astype(np.int8)


@dataclass
class EventSolution(_Solution):
    """Result of :func:`rattleback_events`. ``y`` is (len(t), 11) in the numpy_oracle
    layout; ``spin`` = n = omega . Z (rad/s); ``spin_zeros`` all located zeros of n."""

    y: np.ndarray = None
    spin: np.ndarray = None
    slip_speed: np.ndarray = None
    normal_force: np.ndarray = None
    spin_zeros: np.ndarray = None
    band_crossings: np.ndarray = None
    first_zero_of_spin: float = math.nan
    first_reversal_time: float = math.nan
    onset_fallbacks: int = 0  # evaluations where the consistent onset direction failed
    model: object = field(default=None, repr=False)

    def spin_at(self, t):
        """n(t) (rad/s) at any time(s) in [0, t_final], from the dense output."""
        s = self.state(t)
        return self.model.spin(s.T) if s.ndim == 2 else self.model.spin(s)


@dataclass
class PlanarEventSolution(_Solution):
    """Result of :func:`planar_events`: theta (rad), rate (rad/s), x_G (m), vx (m/s of
    G), u (slip velocity of the material contact point, m/s), normal_force (N)."""

    theta: np.ndarray = None
    rate: np.ndarray = None
    x_G: np.ndarray = None
    vx: np.ndarray = None
    u: np.ndarray = None
    normal_force: np.ndarray = None
    model: object = field(default=None, repr=False)

    def theta_at(self, t):
        """theta(t) (rad) at any time(s) in [0, t_final], from the dense output."""
        s = self.state(t)
        return s[..., 0]


def first_reversal_from_events(n0, zeros, band_crossings):
    """MODEL.md section 6 from located events: the first time n goes beyond -band*|n0| on
    the side opposite n0 (``band_crossings``, the downward crossings of sign(n0) n +
    band |n0|), reported at the last zero crossing of n before it. NaN if none."""
    if n0 == 0 or len(band_crossings) == 0:
        return math.nan
    tb = band_crossings[0]
    before = [z for z in zeros if z <= tb]
    return float(before[-1]) if before else math.nan


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


# --------------------------------------------------------------------------------------
# the driver shared by both models
def _drive(model, z0, t_end, n0, band, *, rtol, atol, max_step, method, planar=False):
    t = 0.0
    z = np.array(z0, dtype=float)
    mode, dref = model.choose_mode(z)
    initial_mode = STICK if mode == STICK else SLIP
    segments, switches, reslips = [], [], []
    observed = {"spin_zero": [], "band": []}
    status = "ok"
    nfev = 0
    zero_run = 0
    while t < t_end:
        if planar and mode == ONSET:
            mode = SLIP  # the planar slip direction is known: no held onset phase
        rhs, terminal, observe = model.mode_functions(mode, dref, n0, band)
        events = [f for _, f in terminal] + [f for _, f in observe]
        sol = solve_ivp(
            rhs,
            (t, t_end),
            z,
            method=method,
            dense_output=True,
            events=events,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
        nfev += sol.nfev
        t1 = float(sol.t[-1])
        if t1 > t:
            segments.append(_Segment(t, t1, mode, sol.sol))
            zero_run = 0
        else:
            zero_run += 1
            if zero_run > MAX_ZERO_SEGMENTS:
                raise RuntimeError(f"mode chatter at t = {t}: {zero_run} empty segments")
        for j, (name, _) in enumerate(observe):
            observed[name].extend(float(x) for x in sol.t_events[len(terminal) + j])
        z = sol.y[:, -1].copy()
        t = t1
        if sol.status == 0:
            break
        fired = [name for j, (name, _) in enumerate(terminal) if len(sol.t_events[j])]
        assert len(fired) == 1, fired
        why = fired[0]
        if why in ("lifted_off", "capsized"):
            status = why
            break
        if not planar:
            z[0:4] /= np.linalg.norm(z[0:4])
        if why == "stick->slip":
            switches.append((t, "stick->slip"))
            if planar:
                _, _, _, F = model.stick(z)
                mode, dref = SLIP, -math.copysign(1.0, F)
            else:
                _, _, _, Ft = model.stick(z, model.kin(z))
                mode, dref = ONSET, -Ft / math.hypot(*Ft)
        elif why in ("grown", "turned"):
            u = model.kin(z)[5]
            mode, dref = SLIP, u / math.hypot(*u)
        elif why == "stop":
            e_before = model.energy(z[:-1])
            z[:-1] = model.impulse(z[:-1])
            z[-1] += e_before - model.energy(z[:-1])  # the impulse's (tiny) loss
            new_mode, new_dref = model.choose_mode(z)
            if new_mode == STICK:
                switches.append((t, "slip->stick"))
            else:
                reslips.append(t)
            mode, dref = new_mode, new_dref
        else:  # pragma: no cover
            raise AssertionError(why)
    slip_time = sum(s.t1 - s.t0 for s in segments if s.mode != STICK)
    return dict(
        segments=segments,
        switch_times=switches,
        reslips=reslips,
        initial_mode=initial_mode,
        status=status,
        t_final=t,
        nfev=nfev,
        slip_fraction=slip_time / t if t > 0 else 0.0,
        spin_zeros=np.array(observed["spin_zero"]),
        band_crossings=np.array(observed["band"]),
    )


# --------------------------------------------------------------------------------------
# public entry points
def rattleback_events(
    body,
    y0,
    *,
    mu,
    mu_static=None,
    g=9.81,
    damping=0.0,
    t_end,
    rtol=1e-10,
    atol=1e-12,
    max_step=np.inf,
    t_eval=None,
    samples=3001,
    band=0.05,
    method="LSODA",
) -> EventSolution:
    """Event-driven Coulomb stick/slip solution of a rattleback (MODEL.md sections 3-4).

    Parameters
    ----------
    body : rattlesweep.Body
    y0 : (11,) state in the numpy_oracle layout (see :func:`launch_state`).
    mu, mu_static : kinetic and static friction coefficients (mu_static defaults to mu;
        mu = inf rolls, mu_static = 0 is frictionless).
    g, damping : gravity (m/s^2) and viscous torque coefficient c_v (N m s).
    t_end : end time (s).
    rtol, atol, max_step, method : passed to solve_ivp for every segment.
    t_eval : sample times (default ``samples`` evenly spaced on [0, t_final]).
    band : reversal hysteresis band as a fraction of |n(0)| (MODEL.md section 6).

    Returns
    -------
    EventSolution with, at the samples ``t``: ``y`` (len(t), 11), ``spin`` (rad/s),
    ``slipping`` (0/1), ``slip_speed`` (m/s), ``normal_force`` (N), ``energy`` (J),
    ``work`` (J dissipated since 0); and ``switch_times`` [(t, "stick->slip" |
    "slip->stick")], ``initial_mode``, ``slip_fraction`` (over [0, t_final]),
    ``slip_fraction_until(t)``, ``spin_zeros``, ``first_zero_of_spin``,
    ``first_reversal_time`` (MODEL.md section 6, NaN if none), ``reslips`` (stops where the
    cone was exceeded at once), ``status``, ``t_final``, ``nfev``, ``onset_fallbacks``,
    ``segments``; dense output ``state(t)``, ``spin_at(t)``, ``mode_at(t)``.
    """
    model = _Rattleback(body, mu, mu_static, g, damping)
    y0 = np.asarray(y0, dtype=float)
    if y0.shape != (11,):
        raise ValueError(f"y0 must have shape (11,), got {y0.shape}")
    n0 = float(model.spin(y0))
    out = _drive(
        model,
        np.append(y0, 0.0),
        float(t_end),
        n0,
        band,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
        method=method,
    )
    res = EventSolution(
        t=None,
        slipping=None,
        switch_times=out["switch_times"],
        slip_fraction=out["slip_fraction"],
        energy=None,
        work=None,
        status=out["status"],
        t_final=out["t_final"],
        t_end=float(t_end),
        segments=out["segments"],
        reslips=out["reslips"],
        nfev=out["nfev"],
        initial_mode=out["initial_mode"],
        options=dict(
            rtol=rtol,
            atol=atol,
            method=method,
            mu=mu,
            mu_static=mu_static,
            g=g,
            damping=damping,
        ),
        spin_zeros=out["spin_zeros"],
        band_crossings=out["band_crossings"],
        model=model,
    )
    t = (
        np.linspace(0.0, out["t_final"], samples)
        if t_eval is None
        else np.asarray(t_eval, dtype=float)
    )
    z = res.state(t)
    res.t = t
    res.y = z[:, :11]
    res.work = z[:, 11]
    res.spin = model.spin(z.T)
    res.slipping = res.mode_at(t)
    res.energy = np.array([model.energy(s) for s in res.y])
    res.slip_speed = np.array([math.hypot(*model.kin(s)[5]) for s in res.y])
    res.normal_force = np.array([_normal_at(res, model, tt, s) for tt, s in zip(t, res.y)])
    res.first_zero_of_spin = (
        float(out["spin_zeros"][0]) if len(out["spin_zeros"]) else math.nan
    )
    res.first_reversal_time = first_reversal_from_events(
        n0, out["spin_zeros"], out["band_crossings"]
    )
    res.onset_fallbacks = model.onset_fallbacks
    return res


def _normal_at(res, model, t, y):
    starts = np.array([s.t0 for s in res.segments])
    seg = res.segments[
        max(0, min(len(starts) - 1, int(np.searchsorted(starts, t, side="right")) - 1))
    ]
    if seg.mode == STICK:
        return model.normal_force(y, STICK, None)
    if seg.mode == FREE:
        return model.normal_force(y, FREE, np.array([1.0, 0.0]))
    u = model.kin(y)[5]
    speed = math.hypot(*u)
    d = u / speed if speed > 0 else np.array([1.0, 0.0])
    return model.normal_force(y, SLIP, d)


def planar_events(
    body,
    theta0,
    rate0=0.0,
    vx0=None,
    *,
    mu,
    mu_static=None,
    g=9.81,
    t_end,
    rtol=1e-10,
    atol=1e-12,
    max_step=np.inf,
    t_eval=None,
    samples=3001,
    method="LSODA",
) -> PlanarEventSolution:
    """Event-driven Coulomb stick/slip solution of the planar rocking semi-ellipse
    (MODEL.md section 8). State (theta, theta_dot, x_G, x_G_dot); ``vx0`` defaults to the
    rolling launch -rate0 h(theta0).

    Returns a PlanarEventSolution: at the samples ``t``, ``theta``, ``rate``, ``x_G``,
    ``vx``, ``u`` (slip velocity), ``slipping``, ``normal_force``, ``energy``, ``work``;
    ``switch_times``, ``initial_mode``, ``slip_fraction``, ``slip_fraction_until(t)``,
    ``reslips`` (stops where the slip reversed at once), ``status``; dense output
    ``state(t)`` (theta, theta_dot, x_G, x_G_dot, W) and ``theta_at(t)``."""
    model = _Planar(body, mu, mu_static, g)
    if vx0 is None:
        vx0 = -rate0 * model.h(theta0)[0]
    z0 = np.array([theta0, rate0, 0.0, vx0, 0.0], dtype=float)
    out = _drive(
        model,
        z0,
        float(t_end),
        0.0,
        0.0,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
        method=method,
        planar=True,
    )
    res = PlanarEventSolution(
        t=None,
        slipping=None,
        switch_times=out["switch_times"],
        slip_fraction=out["slip_fraction"],
        energy=None,
        work=None,
        status=out["status"],
        t_final=out["t_final"],
        t_end=float(t_end),
        segments=out["segments"],
        reslips=out["reslips"],
        nfev=out["nfev"],
        initial_mode=out["initial_mode"],
        options=dict(rtol=rtol, atol=atol, method=method, mu=mu, mu_static=mu_static, g=g),
        model=model,
    )
    t = (
        np.linspace(0.0, out["t_final"], samples)
        if t_eval is None
        else np.asarray(t_eval, dtype=float)
    )
    z = res.state(t)
    res.t = t
    res.theta, res.rate, res.x_G, res.vx, res.work = z.T
    res.u = np.array([model.slip_velocity(s) for s in z])
    res.energy = np.array([model.energy(s) for s in z])
    res.slipping = res.mode_at(t)
    starts = np.array([s.t0 for s in res.segments])
    idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
    nf = []
    for k, s in zip(idx, z):
        seg = res.segments[k]
        sg = math.copysign(1.0, model.slip_velocity(s)) if seg.mode != STICK else None
        nf.append(model.normal_force(s, seg.mode, sg))
    res.normal_force = np.array(nf)
    return res


def rattleback_regularized(
    body,
    y0,
    *,
    mu,
    delta,
    g=9.81,
    damping=0.0,
    t_end,
    rtol=1e-10,
    atol=1e-12,
    method="LSODA",
    t_eval=None,
    samples=3001,
):
    """Cross-check without events: Coulomb friction regularised to
    F_t = -mu N u / sqrt(|u|^2 + delta^2) (delta in m/s), one stiff integration.

    It converges to the Coulomb solution as delta -> 0 (the contact creeps at ~delta
    while it should stick), by a route independent of the event logic (onset direction,
    stop location, impulses). Measured on kane_levinson, spin 5 rad/s, pitch 0.5 deg,
    mu = 0.3 over 3 s: max |n - n_event| 0.21, 0.073, 0.0096, 0.0013 rad/s and first zero
    of spin 2.31672, 2.35569, 2.35914, 2.35955 s for delta = 1e-4 ... 1e-7 m/s (event
    solution 2.35961 s). Returns (t, y (len(t), 11), spin, slip speed)."""
    model = _Rattleback(body, mu, None, g, damping)

    def rhs(t, y):
        k = model.kin(y)
        u = k[5]
        d = u / math.sqrt(u @ u + delta * delta)
        wdot, a_h, N = model.slip(y, k, d, model.mu_k)
        return model.assemble(
            y, wdot, a_h, model.mu_k * N * (u @ d) + model.cv * (y[4:7] @ y[4:7])
        )

    sol = solve_ivp(
        rhs,
        (0.0, t_end),
        np.append(np.asarray(y0, dtype=float), 0.0),
        method=method,
        rtol=rtol,
        atol=atol,
        dense_output=True,
    )
    if sol.status != 0:
        raise RuntimeError(sol.message)
    t = np.linspace(0.0, t_end, samples) if t_eval is None else np.asarray(t_eval, float)
    z = sol.sol(t)
    speed = np.array([math.hypot(*model.kin(z[:, i])[5]) for i in range(t.size)])
    return t, z[:11].T, model.spin(z), speed


def launch_state(run):
    """The t = 0 state of a recorded run of the public API: (11,) numpy_oracle layout for
    ``rs.simulate`` (variables quaternion, omega, position, velocity), or
    (theta, theta_dot, x_G, x_G_dot) for ``rattlesweep.planar.simulate_planar``
    (variables angle, rate, x_G, velocity_x)."""
    if "quaternion" in run:
        return np.concatenate(
            [
                run.quaternion.values[0],
                run.omega.values[0],
                run.position.values[0, :2],
                run.velocity.values[0, :2],
            ]
        ).astype(float)
    return np.array(
        [
            run.angle.values[0],
            run.rate.values[0],
            run.x_G.values[0],
            run.velocity_x.values[0],
        ],
        dtype=float,
    )
