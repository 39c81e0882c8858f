"""A rattlesweep body as a MuJoCo model, launched from rattlesweep's own t = 0 state.

For ``benchmarks/bench_peers.py`` and ``tests/test_peers.py``. The body is an ellipsoid
geom (MuJoCo's ellipsoids are full ones, as the ``kane_levinson`` preset declares itself)
on a plane, with a free joint. The body frame sits at G, so that MuJoCo's free-joint
position and linear velocity are G's and its angular velocity is body omega; the geom is
at C - G = -com, and the inertia about G is given as the full tensor (MuJoCo's
``fullinertia`` takes the tensor's elements, I_xy = -∫xy dm, as rattlesweep does). Contact:
condim 3 (sliding friction only, no torsional or rolling friction), elliptic cone,
friction mu on both geoms (MuJoCo combines them by the maximum). MuJoCo's contact is soft:
a constraint with time constant ``timeconst`` (s) and damping ratio 1 (``solref``), so the
body sinks into the floor (at rest by about g timeconst² / 10: 0.27 µm at 5e-4 s, 0.37 mm
at MuJoCo's default 0.02 s) and the contact point creeps while it "sticks"; rattlesweep's
contact is rigid.

MuJoCo's free joint stores the body's quaternion (w, x, y, z), body -> world, exactly as
rattlesweep does, so a launch converts component by component (:func:`physics_state`) and
:func:`check_same_start` verifies what matters before anything is timed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "Contact",
    "DEFAULT",
    "mjcf",
    "build",
    "physics_state",
    "launch_states",
    "check_same_start",
    "spin_histories",
    "spin_of_states",
]


@dataclass(frozen=True)
class Contact:
    """MuJoCo settings of a run: contact time constant (s, ``solref``), step (s),
    integrator ("RK4", "implicitfast", "Euler"), ``noslip_iterations`` and ``impratio``.
    MuJoCo raises a time constant below 2 steps to 2 steps, so keep timeconst >= 2 dt."""

    timeconst: float
    dt: float
    integrator: str = "RK4"
    noslip: int = 0
    impratio: float = 1.0

    def label(self) -> str:
        extra = (f", noslip {self.noslip}" if self.noslip else "") + (
            f", impratio {self.impratio:g}" if self.impratio != 1.0 else ""
        )
        return f"{self.integrator}, solref {self.timeconst:g}, dt {self.dt:g}{extra}"


DEFAULT = Contact(0.02, 0.002, "Euler")  # MuJoCo's own defaults


def mjcf(body, mu: float, contact: Contact, g: float = 9.81) -> str:
    """The MJCF text of `body` on a floor with friction coefficient `mu`."""

    def nums(*values):
        return " ".join(repr(float(v)) for v in values)

    I, c = np.asarray(body.inertia, dtype=float), -np.asarray(body.com, dtype=float)
    geom = f'condim="3" friction="{nums(mu, 0, 0)}" solref="{nums(contact.timeconst, 1)}"'
    return f"""<mujoco model="rattleback">
  <option timestep="{nums(contact.dt)}" integrator="{contact.integrator}" cone="elliptic"
          gravity="{nums(0, 0, -g)}" impratio="{nums(contact.impratio)}"
          noslip_iterations="{contact.noslip}"/>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" {geom}/>
    <body name="rattleback">
      <freejoint/>
      <geom name="shell" type="ellipsoid" size="{nums(body.a, body.b, body.c)}"
            pos="{nums(*c)}" {geom}/>
      <inertial pos="0 0 0" mass="{nums(body.mass)}"
                fullinertia="{nums(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])}"/>
    </body>
  </worldbody>
</mujoco>"""


def build(body, mu: float, contact: Contact, g: float = 9.81):
    """(MjModel, MjData) of :func:`mjcf`."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf(body, mu, contact, g))
    return model, mujoco.MjData(model)


def physics_state(model, quaternion, omega, position, velocity) -> np.ndarray:
    """MuJoCo full-physics states (N, nstate) from rattlesweep's t = 0 state (N, 4),
    (N, 3) body omega, (N, 3) position and (N, 3) velocity of G (world)."""
    import mujoco

    data = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    out = np.empty((len(quaternion), mujoco.mj_stateSize(model, spec)))
    for i, (q, w, x, v) in enumerate(zip(quaternion, omega, position, velocity)):
        mujoco.mj_resetData(model, data)
        data.qpos[:] = np.concatenate([x, q])
        data.qvel[:] = np.concatenate([v, w])
        mujoco.mj_getState(model, data, out[i], spec)
    return out


def launch_states(model, start) -> np.ndarray:
    """MuJoCo full-physics states (N, nstate) of rattlesweep launches: `start` is a
    ``run_batch(..., record_every=1)`` result at t = 0, over ``trajectory`` or one of its
    trajectories (variables quaternion, omega, position, velocity)."""

    def pick(name):
        return np.atleast_2d(start[name].values)

    return physics_state(
        model, pick("quaternion"), pick("omega"), pick("position"), pick("velocity")
    )


def check_same_start(model, body, state, contact_point, spin, tol=1e-9) -> dict:
    """Checks that a MuJoCo state starts where rattlesweep's launch does: the same mass,
    centre of mass and inertia tensor about G (from MuJoCo's principal moments and
    axes), one contact, at zero distance, at rattlesweep's contact point on the floor
    (`contact_point`, world X, Y), the material point there at rest (rolling launch), and
    the same spin (rad/s). Returns the discrepancies (m, kg m², m/s, rad/s); raises
    AssertionError when one exceeds `tol` (relative for mass and inertia)."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(model, data)

    def matrix(quaternion):
        out = np.empty(9)
        mujoco.mju_quat2Mat(out, quaternion)
        return out.reshape(3, 3)

    axes = matrix(model.body_iquat[1])  # principal axes of inertia in body axes
    inertia = axes @ np.diag(model.body_inertia[1]) @ axes.T
    geom = model.geom("shell").id
    com_from_c = model.body_ipos[1] - model.geom_pos[geom]  # G - C in body axes
    omega_world = matrix(data.qpos[3:7]) @ data.qvel[3:6]
    found = {
        "mass": abs(model.body_mass[1] / body.mass - 1.0),
        "com": float(np.max(np.abs(com_from_c - np.asarray(body.com)))),
        "inertia": float(
            np.max(np.abs(inertia - body.inertia)) / np.max(np.abs(body.inertia))
        ),
        "contacts": int(data.ncon),
        "contact_distance": float(abs(data.contact.dist[0])) if data.ncon else np.inf,
        "contact_point": float(np.max(np.abs(data.contact.pos[0, :2] - contact_point)))
        if data.ncon
        else np.inf,
        # velocity of the material point at the contact, v_G + omega x (P - G)
        "contact_velocity": float(
            np.linalg.norm(
                data.qvel[:3] + np.cross(omega_world, data.contact.pos[0] - data.qpos[:3])
            )
        )
        if data.ncon
        else np.inf,
        "spin": float(abs(omega_world[2] - spin)),
    }
    bad = {k: v for k, v in found.items() if (v != 1 if k == "contacts" else v > tol)}
    assert not bad, f"MuJoCo and rattlesweep start differently: {bad}"
    return found


def spin_of_states(states) -> np.ndarray:
    """n = omega . Z (rad/s) of full-physics states (..., nstate) of this model (time,
    qpos (7), qvel (6), ...)."""
    w, x, y, z = np.moveaxis(states[..., 4:8], -1, 0)
    norm = w * w + x * x + y * y + z * z
    up = (
        np.stack(
            [2 * (x * z - w * y), 2 * (y * z + w * x), norm - 2 * (x * x + y * y)], axis=-1
        )
        / norm[..., None]
    )
    return (up * states[..., 11:14]).sum(-1)


def spin_histories(
    model, states, nstep: int, threads: int = 1, chunk: int = 4096
) -> np.ndarray:
    """n (rad/s) at every step 0..nstep of each state (N, nstate), from
    ``mujoco.rollout`` on `threads` threads, `chunk` steps per call (the rollout returns
    every step's full state; chunks bound its memory)."""
    import mujoco
    from mujoco import rollout

    states = np.atleast_2d(np.asarray(states, dtype=float))
    datas = [mujoco.MjData(model) for _ in range(threads)]
    spins = np.empty((len(states), nstep + 1))
    spins[:, 0] = spin_of_states(states)
    done, current = 0, states
    while done < nstep:
        n = min(chunk, nstep - done)
        out, _ = rollout.rollout(
            model, datas, current, nstep=n, persistent_pool=threads > 1
        )
        spins[:, done + 1 : done + n + 1] = spin_of_states(out)
        current, done = out[:, -1], done + n
    return spins
