"""Outcome classes of a launch, from its per-run observables."""

from __future__ import annotations

import numpy as np

from ..._core import workspace as _status
from ..._metadata import flag_attrs

__all__ = [
    "CAPSIZED",
    "FAILED",
    "LIFTED_OFF",
    "NO_REVERSAL",
    "OUTCOME_ATTRS",
    "OUTCOME_NAMES",
    "REVERSED",
    "SEVERAL",
    "STOPPED",
    "at_first_reversal",
    "classify",
]

OUTCOME_NAMES = (
    "no_reversal",
    "reversed",
    "several_reversals",
    "stopped",
    "capsized",
    "lifted_off",
    "numerical_failure",
)
NO_REVERSAL, REVERSED, SEVERAL, STOPPED, CAPSIZED, LIFTED_OFF, FAILED = range(7)

OUTCOME_ATTRS = flag_attrs(
    "outcome of the launch",
    OUTCOME_NAMES,
    "capsized, lifted_off, numerical_failure: the trajectory stopped with that status "
    "(whatever it did before); otherwise reversed: exactly one reversal of the heading "
    "(the long axis seen from above), several_reversals: two or more; stopped: no reversal "
    "and the mean spin over the last "
    "10% of the run is within the reversal band of zero; no_reversal: none of these.",
)


def classify(
    status: np.ndarray,
    n_reversals: np.ndarray,
    mean_final_spin: np.ndarray,
    initial_spin: np.ndarray,
    band: float,
) -> np.ndarray:
    """Outcome codes (int8, see :data:`OUTCOME_NAMES`) from kernel observables.

    ``band`` is the reversal band, a fraction of the initial spin's magnitude: a run without
    reversal whose final mean spin is inside it has stopped spinning.
    """
    out = np.full(np.shape(status), NO_REVERSAL, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        stopped = np.abs(mean_final_spin) <= band * np.abs(initial_spin)
    out[(n_reversals == 0) & stopped & (initial_spin != 0)] = STOPPED
    out[n_reversals == 1] = REVERSED
    out[n_reversals >= 2] = SEVERAL
    out[status == _status.CAPSIZED] = CAPSIZED
    out[status == _status.LIFTED_OFF] = LIFTED_OFF
    out[status == _status.NON_FINITE] = FAILED
    return out


def at_first_reversal(outcome: np.ndarray, n_reversals: np.ndarray) -> np.ndarray:
    """The outcome a launch run to ``t_end`` would have had with ``stop =
    "first_reversal"``: ``reversed`` once it reversed at all (several reversals, or a
    capsize, lift-off or failure after the first), otherwise the same."""
    out = np.array(outcome, dtype=np.int8, copy=True)
    out[np.asarray(n_reversals) >= 1] = REVERSED
    return out
