"""CF metadata (units, long names, flags) of the inputs and coordinates of rattleback
results; the inputs' come from their descriptions (:mod:`rattlesweep.inputs`). The
attributes of what the kernel computes (observables, recorded series) come from the
model's row tables (:mod:`rattlesweep.core.rattleback.layout`) through
:meth:`rattlesweep.engine.Model.attrs`."""

from __future__ import annotations

from typing import Any, Sequence

from .core.workspace import STATUS_NAMES
from .inputs import RATTLEBACK, result_attrs

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

VARIABLE_ATTRS = {"time": ("s", "time"), **{
    name: (attrs["units"], attrs["long_name"])
    for name, attrs in result_attrs(RATTLEBACK).items()}}
"""Units and long name of each coordinate by name: ``time`` and the inputs, from their
descriptions (:mod:`rattlesweep.inputs`)."""


def attrs_for(name: str) -> dict[str, Any]:
    """CF attributes of a variable or coordinate."""
    if name == "status":
        return dict(STATUS_ATTRS)
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = VARIABLE_ATTRS[name]
    return {"units": units, "long_name": long_name}
