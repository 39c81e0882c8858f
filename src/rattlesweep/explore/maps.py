"""A reversal map for the page: a refined :class:`rattlesweep.Sweep` of two axes run in
memory, level by level (:mod:`rattlesweep.sweep._refinement.plan`), a chunk of launches per
scheduler piece, with a snapshot of the outcomes so far for the page to draw."""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from ..sweep._outputs.outcomes import OUTCOME_NAMES
from ..sweep._config.params import result_name
from ..sweep._refinement.plan import Levels, plan_level
from ..sweep._execution.tiles import NOT_COMPUTED, compute_points, result_dtypes

__all__ = ["MapJob"]

_NEEDED = ("outcome", "first_reversal_time", "t_final")


class MapJob:
    """The state of one map: call :meth:`step` until it returns ``(True, ...)``;
    :meth:`snapshot` may be called from another thread at any time. Each step simulates
    ``chunk`` launches, resized after each step to take about ``piece_seconds`` (s)."""

    def __init__(self, sweep: Any, chunk: int = 16, piece_seconds: float = 0.1) -> None:
        self.sweep = sweep
        self.fine = sweep.finest()
        refine = sweep.refine or {"levels": 0, "axes": list(sweep.dims)}
        self.levels = Levels(
            self.fine.shape,
            # the refined axes by their inputs' names (spin), the
            # dimensions by the results' (launch_spin)
            tuple(list(self.fine.dims).index(result_name(k)) for k in refine["axes"]),
            refine["levels"],
        )
        dtypes = result_dtypes(self.fine)
        self.values = {
            k: np.full(
                self.fine.shape,
                NOT_COMPUTED if dtypes[k].kind in "iu" else np.nan,
                dtype=dtypes[k],
            )
            for k in _NEEDED
        }
        self.computed = np.zeros(self.fine.shape, dtype=bool)
        self.level = 0
        self.todo = self.levels.level0()
        self.pos = 0
        self.chunk = chunk
        self.piece_seconds = piece_seconds
        self.simulated = 0
        self.started = time.perf_counter()
        self.seconds = 0.0
        self.done = False
        self._lock = threading.Lock()
        self.boundary, self.boundary_note = _stability(sweep)

    def step(self) -> tuple[bool, Any]:
        """Simulate the next chunk of launches (or plan the next level)."""
        if self.pos >= len(self.todo):
            if self.level >= self.levels.levels:
                with self._lock:
                    self.done = True
                    self.seconds = time.perf_counter() - self.started
                return True, self.snapshot()
            with self._lock:
                self.level += 1
                self.todo = plan_level(
                    self.values, self.computed, self.levels, self.level, None
                )
                self.pos = 0
            return False, None
        index = self.todo[self.pos : self.pos + self.chunk]
        t0 = time.perf_counter()
        data, _ = compute_points(self.fine, index)
        # size the next chunk to about piece_seconds of work: a map gives way to other
        # sessions' runs that often
        took = max(time.perf_counter() - t0, 1e-4)
        self.chunk = int(min(256, max(4, len(index) * self.piece_seconds / took)))
        with self._lock:
            for name, v in self.values.items():
                v.ravel()[index] = data[name]
            self.computed.ravel()[index] = True
            self.pos += len(index)
            self.simulated += len(index)
        return False, None

    def snapshot(self) -> dict[str, Any]:
        """The map so far: ``outcome`` over the finest grid (x across, y up; -1 where
        nothing is known yet, points not yet simulated drawn as their nearest point of the
        declared grid), coordinates, progress and the stability boundary."""
        with self._lock:
            outcome = self.values["outcome"].copy()
            frac = (self.level + (self.pos / len(self.todo) if len(self.todo) else 1.0)) / (
                self.levels.levels + 1
            )
            state = {
                "level": self.level,
                "levels": self.levels.levels,
                "simulated": self.simulated,
                "level_points": len(self.todo),
                "level_done": self.pos,
                "done": self.done,
                "progress": 1.0 if self.done else min(frac, 0.999),
                "seconds": self.seconds
                if self.done
                else time.perf_counter() - self.started,
            }
        known = outcome != NOT_COMPUTED
        stride = self.levels.stride(0)
        near = np.ix_(
            *[
                np.clip(np.rint(np.arange(n) / stride) * stride, 0, n - 1).astype(np.intp)
                if d in self.levels.axes
                else np.arange(n)
                for d, n in enumerate(outcome.shape)
            ]
        )
        shown = np.where(known, outcome, outcome[near])
        axes = self.fine.grid_axes
        return {
            **state,
            "x": {
                "param": axes[0].key,
                "units": axes[0].units,
                "values": [float(v) for v in axes[0].values],
            },
            "y": {
                "param": axes[1].key,
                "units": axes[1].units,
                "values": [float(v) for v in axes[1].values],
            },
            "outcome": shown.astype(int).T.tolist(),  # rows: y; columns: x
            "outcome_names": list(OUTCOME_NAMES),
            "unstable": self.boundary,
            "boundary_note": self.boundary_note,
            "toml": self.sweep.to_toml(),
        }


def _stability(sweep: Any) -> tuple[list[list[int | None]] | None, str]:
    """Where steady upright spin is linearly unstable (1), stable (0) or neutral (None)
    over the finest grid, rows y, for the rolling case; else None and why not."""
    from ..stability import stability_dataset

    mu = sweep.fixed_si().get("mu", math.inf)
    if "mu" in sweep.dims or not math.isinf(mu):
        return None, (
            "linear stability boundary: drawn for the rolling case (mu = inf) only"
        )
    try:
        ds = stability_dataset(sweep)
    except ValueError as exc:
        return None, f"linear stability boundary: not available ({exc})"
    return _classes(ds.growth_rate.transpose(*sweep.dims).values).T.tolist(), (
        "linear stability of steady upright spin (rolling contact): hatched where it is "
        "unstable, dashed where it turns stable"
    )


def _classes(growth: np.ndarray) -> np.ndarray:
    """1 where the growth rate (1/s) is clearly positive, 0 where clearly negative, None
    where it is zero to rounding (no spin, no misalignment: neutral, about 1e-15 of the
    map's largest rate either side), so that no boundary is drawn around such cells."""
    scale = float(np.nanmax(np.abs(growth))) if np.isfinite(growth).any() else 0.0
    tol = 1e-9 * scale
    out = np.full(growth.shape, None, dtype=object)
    out[growth > tol] = 1
    out[growth < -tol] = 0
    return out
