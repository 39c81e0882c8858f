"""The rules the values of an input obey (:class:`Rule`), each with its error message
and its text for a table; :mod:`rattlesweep.inputs` gives each input its rule."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "AT_LEAST_MU",
    "BAND",
    "FINITE",
    "HALF_TURN",
    "NONNEG",
    "NONNEG_INF",
    "POSITIVE",
    "UNIT_QUATERNION",
    "Rule",
]


@dataclass(frozen=True)
class Rule:
    """A rule every value of a numeric input obeys."""

    message: str  # what an error says after the input's name: "must be finite and > 0"
    short: str  # the same for a table: "finite, > 0"
    ok: Callable[[np.ndarray], np.ndarray]  # True where a value obeys it

    def bad(self, values: ArrayLike) -> np.ndarray:
        """True where a value breaks the rule (NaN breaks every rule)."""
        with np.errstate(invalid="ignore"):
            return ~np.asarray(self.ok(np.asarray(values, dtype=float)), dtype=bool)


POSITIVE = Rule("must be finite and > 0", "finite, > 0", lambda v: np.isfinite(v) & (v > 0))
FINITE = Rule("must be finite", "finite", np.isfinite)
NONNEG_INF = Rule(
    "must be >= 0 (inf allowed: rolling without slip)",
    ">= 0, `inf` allowed",
    lambda v: v >= 0,
)
NONNEG = Rule(
    "must be finite and >= 0", "finite, >= 0", lambda v: np.isfinite(v) & (v >= 0)
)
HALF_TURN = Rule(
    "must be in (-pi/2, pi/2) rad (at |theta| = pi/2 the flat edge reaches the floor)",
    "in (-pi/2, pi/2)",
    lambda v: np.abs(v) < math.pi / 2,
)
AT_LEAST_MU = Rule(
    NONNEG_INF.message,
    ">= `mu`, `inf` allowed",
    NONNEG_INF.ok,
)
"""The static coefficient's rule. A value alone is checked against NONNEG_INF's rule;
``>= mu`` is checked where both values are at hand
(:func:`rattlesweep._launches.check_common`, a sweep's corners)."""
UNIT_QUATERNION = Rule(
    "must be a unit quaternion (w, x, y, z), |q| = 1 to 1e-6",
    "a unit quaternion (w, x, y, z): norm 1 to 1e-6",
    lambda q: np.abs(np.linalg.norm(q, axis=-1) - 1.0) <= 1e-6,
)
"""The orientation's rule, over the last axis (one quaternion a value)."""
BAND = Rule(
    "must be in [0, 1) (a fraction of |initial spin|)",
    "in [0, 1)",
    lambda v: (v >= 0) & (v < 1),
)
