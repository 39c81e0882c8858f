"""The rolling rattleback (MODEL.md sections 3, 4 with stick, 6) as a JAX program, three
ways.

Written from MODEL.md's equations for ``benchmarks/bench_peers.py``; it reads only the
public attributes of a ``rattlesweep.Body`` (a, b, c, mass, com, inertia). Rolling only:
the motion never leaves the stick mode, so the state is the quaternion (w, x, y, z), body
-> world, and the body-frame angular velocity omega (rad/s), seven numbers; the position
of G does not enter the equations. RK4 at a fixed step dt (s), the quaternion renormalised
after every step as rattlesweep's kernel does, float64.

* :func:`vmap_runner`: the program most people would write first: a right-hand side of
  one trajectory on a (7,) array with ``jnp.cross`` and ``jnp.linalg.solve``, ``jax.vmap``
  over an (N, 7) batch, the steps in ``lax.fori_loop``, ``jax.jit``.
* :func:`diffrax_runner`: the same right-hand side through ``diffrax.diffeqsolve`` (classic
  RK4 as an explicit Runge-Kutta tableau, ``ConstantStepSize``), vmapped. It keeps only
  the final state (no reversal time) and does not renormalise the quaternion.
* :func:`soa_runner`: the fastest formulation found: the state as seven (N,) arrays
  ("structure of arrays"), the 3 x 3 solve by its adjugate written out: elementwise
  arithmetic only, which XLA fuses into a few dozen loops over the batch per step; the
  batch is split over the host devices
  (``XLA_FLAGS=--xla_force_host_platform_device_count=K`` before JAX is imported gives K).

The vmap and SoA runners track the first reversal on the fly as the kernel does (MODEL.md
section 6: the zero crossing of n = omega . Z, linearly interpolated, before the first
step beyond the band on the opposite side). Every runner enables JAX's float64.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "jax_x64",
    "initial_state",
    "final_spin",
    "vmap_runner",
    "diffrax_runner",
    "soa_runner",
    "spin_history",
]


def jax_x64():
    """The jax module with float64 enabled (JAX computes in float32 otherwise)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    return jax


def initial_state(quaternion, omega) -> np.ndarray:
    """(N, 7) launch states from quaternions (N, 4) and body omega (N, 3)."""
    return np.concatenate([np.atleast_2d(quaternion), np.atleast_2d(omega)], axis=1)


def _constants(body, g):
    return (
        float(body.mass),
        float(g),
        np.array([body.a**2, body.b**2, body.c**2]),
        np.asarray(body.com, dtype=float),
        np.asarray(body.inertia, dtype=float),
    )


def _vector_rhs(body, g):
    """d/dt of one (7,) state, written with JAX's array operations."""
    import jax.numpy as jnp

    m, g, A, G, I = _constants(body, g)
    A, G, I, eye = jnp.asarray(A), jnp.asarray(G), jnp.asarray(I), jnp.eye(3)

    def rhs(y):
        q, w = y[:4], y[4:]
        q0, q1, q2, q3 = q
        s = 2.0 / (q @ q)
        up = jnp.stack(
            [
                s * (q1 * q3 - q0 * q2),
                s * (q2 * q3 + q0 * q1),
                1.0 - s * (q1 * q1 + q2 * q2),
            ]
        )
        an = A * up
        sigma = jnp.sqrt(up @ an)
        rho = -an / sigma - G
        dup = jnp.cross(up, w)
        dsp = -A * dup / sigma + an * ((an @ dup) / sigma**3)
        wv = jnp.cross(w, jnp.cross(w, rho) + dsp)
        M = I + m * ((rho @ rho) * eye - jnp.outer(rho, rho))
        wdot = jnp.linalg.solve(M, -jnp.cross(w, I @ w) + m * jnp.cross(rho, g * up - wv))
        qdot = 0.5 * jnp.stack(
            [
                -q1 * w[0] - q2 * w[1] - q3 * w[2],
                q0 * w[0] + q2 * w[2] - q3 * w[1],
                q0 * w[1] + q3 * w[0] - q1 * w[2],
                q0 * w[2] + q1 * w[1] - q2 * w[0],
            ]
        )
        return jnp.concatenate([qdot, wdot])

    return rhs


def final_spin(states) -> np.ndarray:
    """n = omega . Z (rad/s) of states (N, 7)."""
    return _spin(*np.asarray(states).T)


def _spin(q0, q1, q2, q3, w0, w1, w2):
    """n = omega . Z from components (arrays or scalars)."""
    s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return (
        w0 * s * (q1 * q3 - q0 * q2)
        + w1 * s * (q2 * q3 + q0 * q1)
        + w2 * (1.0 - s * (q1 * q1 + q2 * q2))
    )


def _reversal_update(jnp, k, dt, n0, band, prev, n, last_zero, t_rev):
    """One step of the on-the-fly first reversal (MODEL.md section 6) after step k."""
    sign = jnp.sign(n0)
    crossed = (sign * prev > 0) & (sign * n <= 0)
    t = (k + 1) * dt
    last_zero = jnp.where(crossed, t - dt * n / (n - prev), last_zero)
    beyond = sign * n < -band * jnp.abs(n0)
    t_rev = jnp.where(jnp.isnan(t_rev) & beyond, last_zero, t_rev)
    return last_zero, t_rev


def vmap_runner(body, dt, nsteps, g=9.81, band=0.05):
    """A jitted f((N, 7) states) -> ((N, 7) final states, (N,) first reversal times, NaN
    where none) over `nsteps` RK4 steps of dt (s)."""
    jax = jax_x64()
    import jax.numpy as jnp

    rhs = _vector_rhs(body, g)

    def one(y0):
        n0 = _spin(*y0)

        def step(k, carry):
            y, prev, last_zero, t_rev = carry
            k1 = rhs(y)
            k2 = rhs(y + 0.5 * dt * k1)
            k3 = rhs(y + 0.5 * dt * k2)
            k4 = rhs(y + dt * k3)
            y = y + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            y = y.at[:4].divide(jnp.sqrt(y[:4] @ y[:4]))
            n = _spin(*y)
            last_zero, t_rev = _reversal_update(
                jnp, k, dt, n0, band, prev, n, last_zero, t_rev
            )
            return y, n, last_zero, t_rev

        y, _, _, t_rev = jax.lax.fori_loop(0, nsteps, step, (y0, n0, jnp.nan, jnp.nan))
        return y, t_rev

    return jax.jit(jax.vmap(one))


def diffrax_runner(body, dt, nsteps, g=9.81):
    """A jitted f((N, 7) states) -> (N, 7) final states after `nsteps` steps of classic
    RK4 at dt (s) through diffrax."""
    jax = jax_x64()
    import diffrax

    rhs = _vector_rhs(body, g)

    class RK4(diffrax.AbstractERK):
        tableau = diffrax.ButcherTableau(
            c=np.array([0.5, 0.5, 1.0]),
            b_sol=np.array([1.0, 2.0, 2.0, 1.0]) / 6.0,
            b_error=np.zeros(4),  # fixed steps: no error estimate is used
            a_lower=(np.array([0.5]), np.array([0.0, 0.5]), np.array([0.0, 0.0, 1.0])),
        )
        interpolation_cls = diffrax.ThirdOrderHermitePolynomialInterpolation.from_k

        def order(self, terms):
            return 4

    term, solver = diffrax.ODETerm(lambda t, y, args: rhs(y)), RK4()

    def one(y0):
        sol = diffrax.diffeqsolve(
            term,
            solver,
            0.0,
            nsteps * dt,
            dt,
            y0,
            stepsize_controller=diffrax.ConstantStepSize(),
            saveat=diffrax.SaveAt(t1=True),
            max_steps=nsteps + 1,
        )
        return sol.ys[-1]

    return jax.jit(jax.vmap(one))


def _soa_rhs(body, g):
    """d/dt of the state as a tuple of seven arrays (q0..q3, w0..w2), scalar arithmetic
    only, so that XLA fuses it elementwise over the batch."""
    from jax import lax

    m, g, A, G, I = _constants(body, g)
    (a0, a1, a2), (g0, g1, g2) = A.tolist(), G.tolist()
    (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = I.tolist()

    def cross(x0, x1, x2, y0, y1, y2):
        return x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0

    def rhs(q0, q1, q2, q3, w0, w1, w2):
        s = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        u0, u1, u2 = (
            s * (q1 * q3 - q0 * q2),
            s * (q2 * q3 + q0 * q1),
            1.0 - s * (q1 * q1 + q2 * q2),
        )
        n0, n1, n2 = a0 * u0, a1 * u1, a2 * u2
        inv = lax.rsqrt(u0 * n0 + u1 * n1 + u2 * n2)
        r0, r1, r2 = -n0 * inv - g0, -n1 * inv - g1, -n2 * inv - g2
        d0, d1, d2 = cross(u0, u1, u2, w0, w1, w2)
        f = (n0 * d0 + n1 * d1 + n2 * d2) * inv**3
        p0, p1, p2 = (
            -a0 * d0 * inv + n0 * f,
            -a1 * d1 * inv + n1 * f,
            -a2 * d2 * inv + n2 * f,
        )
        c0, c1, c2 = cross(w0, w1, w2, r0, r1, r2)
        v0, v1, v2 = cross(w0, w1, w2, c0 + p0, c1 + p1, c2 + p2)
        rr = r0 * r0 + r1 * r1 + r2 * r2
        m00, m01, m02 = i00 + m * (rr - r0 * r0), i01 - m * r0 * r1, i02 - m * r0 * r2
        m11, m12, m22 = (
            i11 + m * (rr - r1 * r1),
            i12 - m * r1 * r2,
            i22 + m * (rr - r2 * r2),
        )
        h0, h1, h2 = cross(
            w0,
            w1,
            w2,
            i00 * w0 + i01 * w1 + i02 * w2,
            i10 * w0 + i11 * w1 + i12 * w2,
            i20 * w0 + i21 * w1 + i22 * w2,
        )
        t0, t1, t2 = cross(r0, r1, r2, g * u0 - v0, g * u1 - v1, g * u2 - v2)
        b0, b1, b2 = m * t0 - h0, m * t1 - h1, m * t2 - h2
        # M is symmetric: its inverse is the adjugate (cofactors) over the determinant
        k00, k01, k02 = m11 * m22 - m12 * m12, m02 * m12 - m01 * m22, m01 * m12 - m02 * m11
        k11, k12, k22 = m00 * m22 - m02 * m02, m01 * m02 - m00 * m12, m00 * m11 - m01 * m01
        det = 1.0 / (m00 * k00 + m01 * k01 + m02 * k02)
        e0 = (k00 * b0 + k01 * b1 + k02 * b2) * det
        e1 = (k01 * b0 + k11 * b1 + k12 * b2) * det
        e2 = (k02 * b0 + k12 * b1 + k22 * b2) * det
        return (
            0.5 * (-q1 * w0 - q2 * w1 - q3 * w2),
            0.5 * (q0 * w0 + q2 * w2 - q3 * w1),
            0.5 * (q0 * w1 + q3 * w0 - q1 * w2),
            0.5 * (q0 * w2 + q1 * w1 - q2 * w0),
            e0,
            e1,
            e2,
        )

    return rhs


def _soa_step(rhs, dt):
    from jax import lax

    def axpy(a, x, y):
        return tuple(xi + a * yi for xi, yi in zip(x, y))

    def step(y):
        k1 = rhs(*y)
        k2 = rhs(*axpy(0.5 * dt, y, k1))
        k3 = rhs(*axpy(0.5 * dt, y, k2))
        k4 = rhs(*axpy(dt, y, k3))
        y = tuple(
            yi + dt / 6.0 * (a + 2.0 * b + 2.0 * c + d)
            for yi, a, b, c, d in zip(y, k1, k2, k3, k4)
        )
        inv = lax.rsqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
        return tuple(qi * inv for qi in y[:4]) + y[4:]

    return step


def soa_runner(body, dt, nsteps, g=9.81, band=0.05, devices=None):
    """A function f((N, 7) states) -> ((N, 7) final states, (N,) first reversal times,
    NaN where none), jitted, with the batch split evenly over `devices` (default: all
    of JAX's devices; N must be a multiple of their number)."""
    jax = jax_x64()
    import jax.numpy as jnp
    from jax.sharding import NamedSharding, PartitionSpec

    step = _soa_step(_soa_rhs(body, g), dt)
    devices = jax.devices() if devices is None else devices
    sharding = NamedSharding(
        jax.sharding.Mesh(np.array(devices), ("batch",)), PartitionSpec("batch")
    )

    @jax.jit
    def run(y0):
        y0 = tuple(y0[:, i] for i in range(7))
        n0 = _spin(*y0)

        def body_fn(k, carry):
            y, prev, last_zero, t_rev = carry
            y = step(y)
            n = _spin(*y)
            last_zero, t_rev = _reversal_update(
                jnp, k, dt, n0, band, prev, n, last_zero, t_rev
            )
            return y, n, last_zero, t_rev

        nan = jnp.full_like(n0, jnp.nan)
        y, _, _, t_rev = jax.lax.fori_loop(0, nsteps, body_fn, (y0, n0, nan, nan))
        return jnp.stack(y, axis=1), t_rev

    def call(states):
        states = np.asarray(states, dtype=float)
        if states.shape[0] % len(devices):
            raise ValueError(
                f"batch {states.shape[0]} is not a multiple of the {len(devices)} devices"
            )
        return run(jax.device_put(states, sharding))

    return call


def spin_history(body, dt, nsteps, state, g=9.81) -> np.ndarray:
    """n (rad/s) at every step 0..nsteps of one launch (7,), with the SoA equations."""
    jax = jax_x64()

    step = _soa_step(_soa_rhs(body, g), dt)

    @jax.jit
    def run(y0):
        def scan_fn(y, _):
            y = step(y)
            return y, _spin(*y)

        return jax.lax.scan(scan_fn, tuple(y0), None, length=nsteps)[1]

    return np.concatenate([[_spin(*state)], np.asarray(run(np.asarray(state, float)))])
