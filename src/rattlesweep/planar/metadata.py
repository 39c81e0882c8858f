"""CF metadata (units, long names) of the inputs of planar results; the attributes of
what the kernel computes come from :mod:`rattlesweep.core.planar.layout`, and the status
flags are shared with the 3-D engine (:data:`rattlesweep.metadata.STATUS_ATTRS`)."""

from __future__ import annotations

from typing import Any

from ..metadata import STATUS_ATTRS

__all__ = ["STATUS_COMMENT", "VARIABLE_ATTRS", "attrs_for"]

STATUS_COMMENT = (
    "ok: ran to t_end; capsized: |angle| reached pi/2, a corner of the flat edge touched "
    "the floor; lifted_off: the normal force went negative; non_finite: a state or input "
    "was NaN or inf. A stopped trajectory keeps its last valid state."
)

VARIABLE_ATTRS = {
    "time": ("s", "time"),
    # inputs
    "launch_angle": ("rad", "initial rocking angle"),
    "launch_rate": ("rad s-1", "initial rocking rate"),
    "launch_velocity": ("m s-1", "initial horizontal velocity of the centre of mass"),
    "mu": ("1", "kinetic friction coefficient"),
    "mu_static": ("1", "static friction coefficient"),
    "mu_roll": ("m", "rolling resistance coefficient (couple bound per unit normal force)"),
    "g": ("m s-2", "gravitational acceleration"),
    "dt": ("s", "time step"),
    "t_end": ("s", "requested end time"),
    "a": ("m", "semi-axis along the flat edge"),
    "b": ("m", "semi-axis normal to the flat edge"),
    "mass": ("kg", "mass"),
    "com_depth": ("m", "depth of the centre of mass below the flat edge"),
    "inertia": ("kg m2", "moment of inertia about the centre of mass"),
}


def attrs_for(name: str) -> dict[str, Any]:
    """CF attributes of a planar variable or coordinate."""
    if name == "status":
        return {**STATUS_ATTRS, "comment": STATUS_COMMENT}
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = VARIABLE_ATTRS[name]
    return {"units": units, "long_name": long_name}
