"""CF metadata (units, long names) of the inputs of planar results, from their
descriptions (:mod:`rattlesweep.inputs`); the attributes of what the kernel computes
come from :mod:`rattlesweep.core.planar.layout`, and the status flags are shared with the
3-D engine (:data:`rattlesweep.metadata.STATUS_ATTRS`)."""

from __future__ import annotations

from typing import Any

from ..inputs import PLANAR, result_attrs
from ..metadata import STATUS_ATTRS

__all__ = ["STATUS_COMMENT", "VARIABLE_ATTRS", "attrs_for"]

STATUS_COMMENT = (
    "ok: ran to t_end; capsized: |angle| reached pi/2, a corner of the flat edge touched "
    "the floor; lifted_off: the normal force went negative; non_finite: a state or input "
    "was NaN or inf. A stopped trajectory keeps its last valid state."
)

VARIABLE_ATTRS = {"time": ("s", "time"), **{
    name: (attrs["units"], attrs["long_name"])
    for name, attrs in result_attrs(PLANAR).items()}}
"""Units and long name of each coordinate by name: ``time`` and the inputs, from their
descriptions (:mod:`rattlesweep.inputs`)."""


def attrs_for(name: str) -> dict[str, Any]:
    """CF attributes of a planar variable or coordinate."""
    if name == "status":
        return {**STATUS_ATTRS, "comment": STATUS_COMMENT}
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = VARIABLE_ATTRS[name]
    return {"units": units, "long_name": long_name}
