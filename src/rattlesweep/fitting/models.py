"""Which friction model the data support: the same fit under rolling contact, Coulomb
friction, and Coulomb friction with spin friction, ranked by an information criterion.

Each model is one :func:`~rattlesweep.fitting.fit` with the user's other free and fixed
inputs:

* ``rolling``: ``mu = inf`` (the contact never slips), ``mu_spin = 0``;
* ``coulomb``: ``mu`` free, ``mu_spin = 0``;
* ``coulomb_spin``: ``mu`` and ``mu_spin`` free.

The criterion is Akaike's, corrected for a small number of features (AICc), on the
residual sum of squares with the noise level estimated from it:
``n ln(chi2 / n) + 2 k + 2 k (k + 1) / (n - k - 1)``, with ``n`` the compared features
and ``k`` the free inputs plus the offsets fitted in closed form. It is written that way,
not as ``chi2 + 2 k``, because a feature's scale is a floor (a few per cent of its
range), not a measured noise: a reduced chi-squared far from 1 would otherwise inflate
every difference. The Bayesian criterion ``n ln(chi2 / n) + k ln n`` is reported beside
it. A model whose AICc is within 2 of the lowest is as well supported; of those, the one
with the fewest free inputs is preferred (``preferred``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from .api import FitResult, fit

__all__ = ["MODELS", "ModelComparison", "ModelScore", "compare_models"]

MODELS = ("rolling", "coulomb", "coulomb_spin")
"""The friction models compared, simplest first."""

MU_BOUNDS = (0.05, 1.5)
"""Bounds of ``mu`` where the caller gives none: dry contacts of wood, plastic, metal
and glass on tables."""

MU_SPIN_BOUNDS = (0.0, 2e-3)
"""m: bounds of ``mu_spin`` where the caller gives none (a contact patch of a few
millimetres times a friction coefficient)."""

_FRICTION = ("mu", "mu_static", "mu_spin")

SUPPORTED = 2.0
"""An AICc within this of the lowest: as well supported (Burnham and Anderson)."""


@dataclass(frozen=True)
class ModelScore:
    """One model's fit and its criteria: ``aicc``, ``bic``, ``delta`` (AICc less the
    lowest) and ``weight`` (its Akaike weight)."""

    name: str
    result: FitResult
    k: int
    n: int
    aicc: float
    bic: float
    delta: float
    weight: float


@dataclass(frozen=True)
class ModelComparison:
    """The models' scores, simplest first, and the ``preferred`` one's name."""

    scores: tuple[ModelScore, ...]
    preferred: str

    def __getitem__(self, name: str) -> ModelScore:
        for score in self.scores:
            if score.name == name:
                return score
        raise KeyError(name)

    def table(self) -> str:
        """The comparison as lines of text."""
        lines = [
            f"  {'model':<13} {'inputs':>6} {'reduced chi2':>12} {'AICc':>9} "
            f"{'dAICc':>7} {'weight':>7} {'BIC':>9}"
        ]
        for s in self.scores:
            mark = "  <- preferred" if s.name == self.preferred else ""
            lines.append(
                f"  {s.name:<13} {s.k:>6} {s.result.reduced_chi2:>12.3g} {s.aicc:>9.2f} "
                f"{s.delta:>7.2f} {s.weight:>7.2f} {s.bic:>9.2f}{mark}"
            )
        for s in self.scores:
            lines += [f"  {s.name}: {note}" for note in s.result.notes]
        return "\n".join(lines)

    def document(self) -> dict[str, Any]:
        """The comparison as a table of plain values (``models.toml``)."""
        return {
            "preferred": self.preferred,
            "criterion": "AICc = n ln(chi2/n) + 2k + 2k(k+1)/(n-k-1); within "
            f"{SUPPORTED:g} of the lowest, the model with fewest inputs is preferred",
            "models": {
                s.name: {
                    "inputs": s.k,
                    "features": s.n,
                    "chi2": s.result.chi2,
                    "reduced_chi2": s.result.reduced_chi2,
                    "aicc": s.aicc,
                    "delta_aicc": s.delta,
                    "weight": s.weight,
                    "bic": s.bic,
                    "fitted": {
                        f.name: {
                            "value": f.value,
                            "low": f.low,
                            "high": f.high,
                            "determined": f.determined,
                        }
                        for f in s.result.fitted.values()
                    },
                    "notes": list(s.result.notes),
                }
                for s in self.scores
            },
        }


def model_inputs(
    name: str, free: Mapping[str, tuple[float, float]], fixed: Mapping[str, Any]
) -> tuple[dict[str, tuple[float, float]], dict[str, Any]]:
    """The free and fixed inputs of model ``name``: the caller's, with the friction
    inputs set by the model (``mu``'s and ``mu_spin``'s bounds kept where given)."""
    if name not in MODELS:
        raise ValueError(f"models: {name!r} is not a model; they are {', '.join(MODELS)}")
    given = sorted(n for n in fixed if n in _FRICTION)
    if given:
        raise ValueError(
            f"{', '.join(given)} fixed: the model comparison sets the friction "
            "inputs itself (give their bounds with free instead)"
        )
    rest = {k: v for k, v in free.items() if k not in _FRICTION}
    mu = free.get("mu", MU_BOUNDS)
    mu_spin = free.get("mu_spin", MU_SPIN_BOUNDS)
    if name == "rolling":
        return rest, {**fixed, "mu": math.inf, "mu_spin": 0.0}
    if name == "coulomb":
        return {**rest, "mu": mu}, {**fixed, "mu_spin": 0.0}
    return {**rest, "mu": mu, "mu_spin": mu_spin}, dict(fixed)


def compare_models(
    data: Any,
    body: Any,
    free: Mapping[str, tuple[float, float]],
    fixed: Mapping[str, Any] | None = None,
    *,
    models: tuple[str, ...] = MODELS,
    progress: Callable[[str], None] | None = None,
    **options: Any,
) -> ModelComparison:
    """Fit each friction model in ``models`` and rank them (module docstring).

    ``free`` and ``fixed`` are as :func:`~rattlesweep.fitting.fit` takes them; ``mu``
    and ``mu_spin`` may be given in ``free`` for their bounds (defaults
    :data:`MU_BOUNDS`, :data:`MU_SPIN_BOUNDS`) and must not be fixed. ``options`` go
    to each :func:`~rattlesweep.fitting.fit`."""
    say = progress or (lambda line: None)
    fixed = dict(fixed or {})
    if not models:
        raise ValueError("models: name at least one model")
    inputs = {m: model_inputs(m, free, fixed) for m in models}  # refuse before compute
    raw = []
    for name in models:
        model_free, model_fixed = inputs[name]
        if not model_free:
            raise ValueError(
                f"model {name} leaves nothing free: free at least one input besides "
                "the friction"
            )
        say(f"model {name}: fitting {', '.join(model_free)}")
        result = fit(data, body, model_free, model_fixed, progress=say, **options)
        k = len(model_free) + len(result.offsets)
        n = int(result.dataset["measured_feature"].size)
        rss = max(result.chi2, 1e-300)
        aicc = n * math.log(rss / n) + 2 * k + 2 * k * (k + 1) / max(1, n - k - 1)
        bic = n * math.log(rss / n) + k * math.log(n)
        raw.append((name, result, k, n, aicc, bic))
    lowest = min(r[4] for r in raw)
    weights = [math.exp(-0.5 * (r[4] - lowest)) for r in raw]
    total = sum(weights)
    scores = tuple(
        ModelScore(name, result, k, n, aicc, bic, aicc - lowest, w / total)
        for (name, result, k, n, aicc, bic), w in zip(raw, weights)
    )
    supported = [s for s in scores if s.delta <= SUPPORTED]
    preferred = min(supported, key=lambda s: (s.k, s.delta)).name
    return ModelComparison(scores, preferred)
