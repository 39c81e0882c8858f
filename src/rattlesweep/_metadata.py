"""CF metadata both models' results share: categorical flags, the status flags, and the
units and long name of each input and coordinate, from the inputs' descriptions
(:mod:`rattlesweep.inputs`). Each model's ``metadata`` module fills them in."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from ._core.workspace import STATUS_NAMES
from .inputs import Input, result_attrs

__all__ = ["coordinate_attrs", "flag_attrs", "lookup_attrs", "status_attrs"]


def flag_attrs(long_name: str, names: Sequence[str], comment: str) -> dict[str, Any]:
    """CF attributes of a categorical variable whose values 0, 1, ... mean ``names``."""
    return {
        "long_name": long_name,
        "flag_values": list(range(len(names))),
        "flag_meanings": " ".join(names),
        "comment": comment,
    }


def status_attrs(comment: str) -> dict[str, Any]:
    """CF attributes of the status flags; ``comment`` says what each status means for a
    model."""
    return flag_attrs("trajectory status", STATUS_NAMES, comment)


def coordinate_attrs(inputs: Mapping[str, Input]) -> dict[str, tuple[str, str]]:
    """Units and long name of each coordinate by name: ``time`` and the inputs
    (``inputs``, a model's descriptions) under their result names."""
    return {
        "time": ("s", "time"),
        **{
            name: (attrs["units"], attrs["long_name"])
            for name, attrs in result_attrs(inputs).items()
        },
    }


def lookup_attrs(
    name: str, status: Mapping[str, Any], coordinates: Mapping[str, tuple[str, str]]
) -> dict[str, Any]:
    """CF attributes of a variable or coordinate of a model whose status flags carry
    ``status`` and whose coordinates ``coordinates`` (:func:`coordinate_attrs`)."""
    if name == "status":
        return dict(status)
    if name == "body_name":
        return {"long_name": "body name"}
    units, long_name = coordinates[name]
    return {"units": units, "long_name": long_name}
