"""How a refined sweep's map compares with the same map simulated at every point."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .outcomes import OUTCOME_NAMES, at_first_reversal

__all__ = ["compare_with_full"]


def compare_with_full(refined: xr.Dataset, full: xr.Dataset) -> dict[str, Any]:
    """Figures of a refined result against a full sweep on the same (finest) grid.

    When ``refined`` was run with ``stop = "first_reversal"`` and ``full`` was not,
    ``full``'s outcomes are first brought to what they would have been with the stop
    (:func:`~rattlesweep.sweep._outputs.outcomes.at_first_reversal`).

    Returns a dict: ``points``, ``simulated`` (fraction of points simulated),
    ``mismatch`` (fraction of points whose outcome differs), ``mismatch_filled``
    (mismatches among filled points), ``misses`` ({(full outcome, refined outcome):
    count}), ``both_reversed`` (points where both have a first reversal time),
    ``time_difference`` (absolute differences there, s, sorted) and
    ``time_difference_filled`` (the same at filled points only).
    """
    refined, full = xr.align(refined, full, join="exact")
    expected = full.outcome.values
    if refined.attrs.get("stop") == "first_reversal" and full.attrs.get("stop") is None:
        expected = at_first_reversal(expected, full.n_reversals.values)
    got = refined.outcome.values
    filled = (
        refined.computed.values == 0
        if "computed" in refined
        else np.zeros(got.shape, dtype=bool)
    )
    wrong = got != expected
    misses: dict[tuple[str, str], int] = {}
    for a, b in zip(expected[wrong], got[wrong]):
        key = (OUTCOME_NAMES[a], OUTCOME_NAMES[b])
        misses[key] = misses.get(key, 0) + 1
    t_ref = refined.first_reversal_time.values
    t_full = full.first_reversal_time.values
    both = np.isfinite(t_ref) & np.isfinite(t_full)
    return {
        "points": int(got.size),
        "simulated": float(1.0 - filled.mean()),
        "mismatch": float(wrong.mean()),
        "mismatch_filled": int((wrong & filled).sum()),
        "misses": dict(sorted(misses.items(), key=lambda kv: -kv[1])),
        "both_reversed": int(both.sum()),
        "time_difference": np.sort(np.abs(t_ref - t_full)[both]),
        "time_difference_filled": np.sort(np.abs(t_ref - t_full)[both & filled]),
    }
