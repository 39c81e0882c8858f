"""The options of a run that are not per-launch inputs, checked: the integration method,
the recording stride, the reversal band and the stop rule."""

from __future__ import annotations

import numpy as np

from ._model import Prepared
from ._validation import is_real
from ._core.workspace import METHODS, STOP_RULES
from .inputs import RATTLEBACK

__all__ = [
    "check_band",
    "check_method",
    "check_record_every",
    "check_single_step",
    "check_stop",
]


def check_method(method: str) -> int:
    try:
        return METHODS.index(method)
    except (ValueError, TypeError):
        raise ValueError(
            f"method must be one of {sorted(METHODS)}, got {method!r}"
        ) from None


def check_record_every(record_every: int | None) -> int | None:
    if record_every is None:
        return None
    if not (
        isinstance(record_every, (int, np.integer))
        and not isinstance(record_every, bool)
        and record_every >= 1
    ):
        raise ValueError(
            f"record_every must be a positive integer or None, got {record_every!r}"
        )
    return int(record_every)


def check_single_step(prep: Prepared) -> None:
    """Records need one time step and one end time for the whole batch."""
    for name in ("dt", "t_end"):
        values = prep.coords[name][1]
        if values.size and np.any(values != values[0]):
            raise ValueError(f"record_every needs a single {name} for the whole batch")


def check_band(reversal_band: float) -> float:
    band = float(reversal_band) if is_real(reversal_band) else np.nan  # else refused below
    rule = RATTLEBACK["reversal_band"].rule
    assert rule is not None
    if rule.bad(band):
        raise ValueError(f"reversal_band {rule.message}, got {reversal_band!r}")
    return band


def check_stop(stop: str | None) -> float:
    """The ``stop_rule`` row value of a ``stop`` argument: None (run to ``t_end``) or
    ``"first_reversal"``."""
    try:
        return STOP_RULES[stop]
    except (KeyError, TypeError):
        raise ValueError(
            f"stop must be None (run to t_end) or 'first_reversal', got {stop!r}"
        ) from None
