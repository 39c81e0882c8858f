"""CF metadata (units, long names) of the planar results; status flags are shared with
the 3-D engine (:data:`rattlesweep.metadata.STATUS_ATTRS`)."""

from __future__ import annotations

from ..metadata import STATUS_ATTRS

STATUS_COMMENT = (
    "ok: ran to t_end; capsized: |angle| reached pi/2, a corner of the flat edge touched "
    "the floor; lifted_off: the normal force went negative; non_finite: a state or input "
    "was NaN or inf. A stopped trajectory keeps its last valid state."
)

VARIABLE_ATTRS = {
    # per-run observables
    "energy_initial": ("J", "mechanical energy at t = 0"),
    "energy_final": ("J", "mechanical energy at the end of the run"),
    "energy_lost": ("J", "energy_initial - energy_final"),
    "slip_fraction": ("1", "fraction of steps spent slipping"),
    "max_angle": ("rad", "largest |rocking angle|"),
    "final_angle": ("rad", "rocking angle at the end of the run"),
    "final_rate": ("rad s-1", "rocking rate at the end of the run"),
    "t_final": ("s", "time reached (earlier than t_end when the trajectory stopped)"),
    "steps": ("1", "number of steps taken"),
    # time series
    "time": ("s", "time"),
    "angle": ("rad", "rocking angle theta, counter-clockwise"),
    "rate": ("rad s-1", "rocking rate d(theta)/dt"),
    "x_G": ("m", "horizontal position of the centre of mass"),
    "y_G": ("m", "height of the centre of mass above the floor, h(theta)"),
    "velocity_x": ("m s-1", "horizontal velocity of the centre of mass"),
    "velocity_y": ("m s-1", "vertical velocity of the centre of mass, h'(theta) d(theta)/dt"),
    "slip_velocity": ("m s-1", "horizontal velocity of the material contact point"),
    "slip_speed": ("m s-1", "speed of the material contact point"),
    "normal_force": ("N", "normal contact force"),
    "friction_force": ("N", "horizontal friction force on the body"),
    "energy": ("J", "mechanical energy (floor at zero potential)"),
    "slipping": ("1", "1 while the contact slips, 0 while it sticks"),
    # inputs
    "launch_angle": ("rad", "initial rocking angle"),
    "launch_rate": ("rad s-1", "initial rocking rate"),
    "launch_velocity": ("m s-1", "initial horizontal velocity of the centre of mass"),
    "mu": ("1", "kinetic friction coefficient"),
    "mu_static": ("1", "static friction coefficient"),
    "g": ("m s-2", "gravitational acceleration"),
    "dt": ("s", "time step"),
    "t_end": ("s", "requested end time"),
    "a": ("m", "semi-axis along the flat edge"),
    "b": ("m", "semi-axis normal to the flat edge"),
    "mass": ("kg", "mass"),
    "com_depth": ("m", "depth of the centre of mass below the flat edge"),
    "inertia": ("kg m2", "moment of inertia about the centre of mass"),
}


def attrs_for(name: str) -> dict:
    """CF attributes of a planar variable or coordinate."""
    if name == "status":
        return {**STATUS_ATTRS, "comment": STATUS_COMMENT}
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = VARIABLE_ATTRS[name]
    return {"units": units, "long_name": long_name}
