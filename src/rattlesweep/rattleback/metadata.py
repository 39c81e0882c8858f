"""CF metadata (units, long names, flags) of the inputs and coordinates of rattleback
results; the inputs' come from their descriptions (:mod:`rattlesweep.inputs`). The
attributes of what the kernel computes (observables, recorded series) come from the
model's row tables (:mod:`rattlesweep._core.rattleback.layout`) through
:meth:`rattlesweep._model.Model.attrs`."""

from __future__ import annotations

from typing import Any

from .._metadata import coordinate_attrs, lookup_attrs, status_attrs
from ..inputs import RATTLEBACK

__all__ = ["STATUS_ATTRS", "STATUS_COMMENT", "VARIABLE_ATTRS", "attrs_for"]

STATUS_COMMENT = (
    "ok: ran to t_end; capsized: the rim reached the floor; lifted_off: the normal force "
    "went negative; non_finite: a state or input was NaN or inf. A stopped trajectory "
    "keeps its last valid state."
)

STATUS_ATTRS = status_attrs(STATUS_COMMENT)

VARIABLE_ATTRS = coordinate_attrs(RATTLEBACK)
"""Units and long name of each coordinate by name: ``time`` and the inputs, from their
descriptions (:mod:`rattlesweep.inputs`)."""


def attrs_for(name: str) -> dict[str, Any]:
    """CF attributes of a variable or coordinate."""
    return lookup_attrs(name, STATUS_ATTRS, VARIABLE_ATTRS)
