"""Input validation: bad input becomes a ``ValueError`` naming the parameter, the value and
the rule it breaks, before any computation can turn it into a NaN or a cryptic error.

Non-numbers (strings, other objects) get the same kind of message as bad numbers, never a
``TypeError`` from deep inside numpy or ``float``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["as_float_array", "fail_where", "finite_vector", "positive"]


def positive(name: str, value: Any) -> float:
    """``value`` as a float, which must be finite and > 0.

    Raises ``ValueError("<name> must be a finite number > 0, got <value>")`` otherwise,
    non-numbers included.
    """
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        v = math.nan
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def finite_vector(name: str, value: Any, n: int) -> np.ndarray:
    """``value`` as a new float array of shape ``(n,)`` with finite entries.

    Raises ``ValueError`` naming ``name`` when it is not numbers, has another shape or
    holds a NaN or an infinity.
    """
    arr = as_float_array(name, value).copy()  # never the caller's array, which may change
    if arr.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def as_float_array(name: str, value: Any) -> np.ndarray:
    """``value`` as a float array (0-d for a scalar; no copy when it already is one).

    Raises ``ValueError("<name> must be a number or an array of numbers, got <value>")``
    when numpy cannot convert it (a string, a ragged list). numpy turns ``None`` into NaN,
    which a finiteness rule then refuses.
    """
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or an array of numbers, got {value!r}"
                         ) from None


def fail_where(name: str, arr: np.ndarray, bad: np.ndarray, rule: str) -> None:
    """Raise ``ValueError("<name> <rule>; got <value> at index <idx>")`` for the first
    entry of ``arr`` where the boolean mask ``bad`` (same shape) is true; do nothing when
    it is false everywhere. A 0-d ``arr`` gives no index.

    ``rule`` reads after the name, e.g. ``"must be finite and > 0"``.
    """
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f" at index {idx}" if arr.ndim else ""
        value = arr[idx]
        # a plain number, as the user wrote it (-1.0, not numpy's np.float64(-1.0))
        shown = repr(float(value)) if np.ndim(value) == 0 else repr(np.asarray(value).tolist())
        raise ValueError(f"{name} {rule}; got {shown}{where}")
