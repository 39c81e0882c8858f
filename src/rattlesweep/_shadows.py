"""Lyapunov batches: each launch beside its shadow in the kernel's blocks.

The kernel computes a launch's largest Lyapunov exponent from a shadow lane
(:mod:`rattlesweep._core.lyapunov`): lane j < BLOCK/2 of a block is a launch, lane
j + BLOCK/2 its shadow, a copy of the launch displaced by :func:`displaced`. So a
Lyapunov batch of n launches takes ceil(2n / BLOCK) blocks, twice the lanes of a plain
one, and each launch's results are read from its own lane (:attr:`Prepared.lanes`).

The renormalisation interval is :data:`INTERVAL` of the launch's own time (the nearest
whole number of its steps, at least one), so that a launch's exponent depends on its own
inputs alone.
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ._core.lyapunov import D0, HALF
from ._core.workspace import BLOCK
from ._model import Model, Prepared
from ._pack import prepared

__all__ = [
    "DISPLACEMENT",
    "INTERVAL",
    "SHORT_RUN",
    "check_rolling",
    "lane_sources",
    "lyapunov_attrs",
    "shadowed",
    "warn_short",
    "with_lyapunov",
]

INTERVAL = 0.05
"""s: the shadow is renormalised every INTERVAL of the launch's time. Short against
the growth times of the rattling (a tenth of a second and more), so that the
separation grows by a few times at most between renormalisations."""

DISPLACEMENT = D0
"""Size of the launch displacement of a shadow in each direction of
:func:`displaced`'s tangent vector (the kernel rescales it to D0 before the first
step)."""


SHORT_RUN = 10 * INTERVAL
"""s: a run shorter than this is a few renormalisation intervals: its exponent is mostly
the launch transient, and a warning says so."""


def warn_short(t_end: np.ndarray, stacklevel: int) -> None:
    """Warn (RuntimeWarning) when some launch runs for less than :data:`SHORT_RUN`."""
    short = np.asarray(t_end) < SHORT_RUN
    if np.any(short):
        t = float(np.min(np.asarray(t_end)))
        warnings.warn(
            f"lyapunov over a run of t_end = {t:g} s, {t / INTERVAL:.3g} renormalisation "
            f"intervals of {INTERVAL:g} s: the exponent is mostly the launch's transient; "
            "runs of several seconds give exponents worth comparing",
            RuntimeWarning,
            stacklevel=stacklevel + 1,
        )


def lyapunov_attrs() -> dict[str, Any]:
    """Global attributes of a result with exponents: how they were computed."""
    return {
        "lyapunov_method": "renormalised shadow launch (largest exponent)",
        "lyapunov_interval": INTERVAL,
        "lyapunov_separation": D0,
    }


def with_lyapunov(model: Model) -> Model:
    """``model`` whose results carry the ``lyapunov`` observable too."""
    return dataclasses.replace(model, observables=(*model.observables, "lyapunov"))


def check_rolling(flat: Mapping[str, np.ndarray], shape: Sequence[int]) -> None:
    """Refuse a Lyapunov batch any of whose launches can slip or has a friction couple
    (``flat``: the batch's flat inputs by name, ``mu``, ``mu_static``, ``mu_spin`` and
    ``mu_roll`` among them, over ``shape``).

    Across a switch between sticking and slipping the flow changes, and the tangent
    vector jumps (its saltation); a shadow lane that switches a step earlier or later
    than its launch would measure that jump as growth. The exponent is computed only
    where every step follows the one smooth rolling flow: an infinite static friction
    (``mu_static``, which defaults to ``mu``) and no couples."""
    mu_static = np.asarray(flat["mu_static"])
    for name, bad in (
        ("mu_static", ~(mu_static == np.inf)),
        ("mu_spin", ~(np.asarray(flat["mu_spin"]) == 0.0)),
        ("mu_roll", ~(np.asarray(flat["mu_roll"]) == 0.0)),
    ):
        if not np.any(bad):
            continue
        i = int(np.argmax(bad))
        where = (
            f" at index {tuple(int(k) for k in np.unravel_index(i, tuple(shape)))}"
            if bad.size > 1
            else ""
        )
        if name == "mu_static":
            got = f"mu = {np.asarray(flat['mu']).flat[i]:g}"
            if np.asarray(flat["mu"]).flat[i] != mu_static.flat[i]:
                got += f", mu_static = {mu_static.flat[i]:g}"
        else:
            got = f"{name} = {np.asarray(flat[name]).flat[i]:g}"
        raise ValueError(
            "lyapunov needs rolling contact throughout: mu = inf (the default; or "
            f"mu_static = inf) and mu_spin = mu_roll = 0; got {got}{where}. The "
            "exponent is not computed across stick/slip switches, where the flow "
            "changes and the tangent vector jumps."
        )


def lane_sources(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For a Lyapunov batch of n launches: (source, shadow, lanes). ``source`` (lanes,)
    is the launch each lane copies (padding lanes copy launch 0), ``shadow`` (lanes,)
    is True for the shadow lanes, ``lanes`` (n,) the lane of each launch."""
    n_blocks = -(-n // HALF)
    lane = np.arange(n_blocks * BLOCK)
    block, j = np.divmod(lane, BLOCK)
    source = block * HALF + j % HALF
    shadow = j >= HALF
    lanes = (np.arange(n) // HALF) * BLOCK + np.arange(n) % HALF
    return np.where(source < n, source, 0), shadow, lanes


def shadowed(
    model: Model,
    columns: Mapping[str, np.ndarray],
    state: Mapping[str, np.ndarray],
    nsteps: np.ndarray,
    n: int,
    shape: Sequence[int],
    displaced: Callable[[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray], None],
) -> Prepared:
    """A :class:`Prepared` Lyapunov batch of the n launches given as for
    :func:`rattlesweep._pack.prepared`. ``displaced(state, columns, shadow)`` moves the
    launch state of the lanes marked in ``shadow`` off their launch by about
    :data:`DISPLACEMENT` in each direction the model's metric measures, in place."""
    source, shadow, lanes = lane_sources(n)
    valid = np.zeros(source.size, dtype=bool)
    valid[lanes] = True
    valid[lanes + HALF] = True
    lane_columns: dict[str, Any] = {k: np.asarray(v)[source] for k, v in columns.items()}
    lane_state = {k: np.array(np.asarray(v)[source], dtype=float) for k, v in state.items()}
    every = np.maximum(1.0, np.rint(INTERVAL / lane_columns["dt"]))
    lane_columns["lyapunov_steps"] = np.where(valid & ~shadow, every, 0.0)
    if "stop_rule" in lane_columns:  # a shadow runs as long as its launch, no longer
        lane_columns["stop_rule"] = np.where(shadow, 0.0, lane_columns["stop_rule"])
    displaced(lane_state, lane_columns, shadow & valid)
    steps = np.where(valid, np.asarray(nsteps)[source], 0)
    prep = prepared(model, lane_columns, lane_state, steps, source.size, shape, {})
    return dataclasses.replace(prep, n=n, lanes=lanes)
