"""CF metadata (units, long names, flags) of the inputs and coordinates of rattleback
results. The attributes of what the kernel computes (observables, recorded series) come
from the model's row tables (:mod:`rattlesweep.core.rattleback.layout`) through
:meth:`rattlesweep.engine.Model.attrs`."""

from __future__ import annotations

from typing import Any, Sequence

from .core.workspace import STATUS_NAMES

__all__ = ["STATUS_ATTRS", "VARIABLE_ATTRS", "attrs_for", "flag_attrs"]


def flag_attrs(long_name: str, names: Sequence[str], comment: str) -> dict[str, Any]:
    """CF attributes of a categorical variable whose values 0, 1, ... mean ``names``."""
    return {"long_name": long_name, "flag_values": list(range(len(names))),
            "flag_meanings": " ".join(names), "comment": comment}


STATUS_ATTRS = flag_attrs(
    "trajectory status", STATUS_NAMES,
    "ok: ran to t_end; capsized: the rim reached the floor; lifted_off: the normal force "
    "went negative; non_finite: a state or input was NaN or inf. A stopped trajectory "
    "keeps its last valid state.")

VARIABLE_ATTRS = {
    "time": ("s", "time"),
    # inputs
    "roll_deg": ("degree", "initial roll about body x"),
    "pitch_deg": ("degree", "initial pitch about body y"),
    "yaw_deg": ("degree", "initial yaw about the vertical"),
    "orientation": ("1", "initial orientation quaternion (w, x, y, z)"),
    "launch_spin": ("rad s-1", "initial spin about the vertical"),
    "launch_omega": ("rad s-1", "initial angular velocity, body components"),
    "launch_velocity": ("m s-1", "initial horizontal velocity of G (sliding launch)"),
    "mu": ("1", "kinetic friction coefficient"),
    "mu_static": ("1", "static friction coefficient"),
    "mu_spin": ("m", "spin friction coefficient (couple bound per unit normal force)"),
    "mu_roll": ("m", "rolling resistance coefficient (couple bound per unit normal force)"),
    "damping": ("N m s", "viscous torque coefficient"),
    "g": ("m s-2", "gravitational acceleration"),
    "dt": ("s", "time step"),
    "t_end": ("s", "requested end time"),
    "a": ("m", "semi-axis along body x"),
    "b": ("m", "semi-axis along body y"),
    "c": ("m", "semi-axis along body z"),
    "mass": ("kg", "mass"),
    "com": ("m", "centre of mass from the centre of the flat face, body frame"),
    "inertia_xx": ("kg m2", "inertia tensor element I_xx about G"),
    "inertia_yy": ("kg m2", "inertia tensor element I_yy about G"),
    "inertia_zz": ("kg m2", "inertia tensor element I_zz about G"),
    "inertia_xy": ("kg m2", "inertia tensor element I_xy about G"),
    "inertia_xz": ("kg m2", "inertia tensor element I_xz about G"),
    "inertia_yz": ("kg m2", "inertia tensor element I_yz about G"),
    "full_ellipsoid": ("1", "1 for a full ellipsoid (no rim), 0 for a semi-ellipsoid"),
}


def attrs_for(name: str) -> dict[str, Any]:
    """CF attributes of a variable or coordinate."""
    if name == "status":
        return dict(STATUS_ATTRS)
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = VARIABLE_ATTRS[name]
    return {"units": units, "long_name": long_name}
