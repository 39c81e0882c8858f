"""Tiles: blocks of the grid whose points are consecutive flat indices, each computed by
one task on one core. A task returns its results as plain arrays (:class:`TileResult`,
about 120 bytes per point); the process that runs the sweep writes them, so workers never
need the output's filesystem."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import _results as results
from ... import _run as engine
from ..._shadows import with_lyapunov
from ...rattleback.batch import MODEL, prepare
from ..._options import check_method
from ...inputs import RATTLEBACK
from .._outputs.outcomes import OUTCOME_ATTRS, classify
from .._config.spec import Sweep

__all__ = [
    "NOT_COMPUTED",
    "RESULT_VARS",
    "result_vars",
    "LevelTile",
    "LevelTileResult",
    "TileResult",
    "compute_level_tile",
    "compute_points",
    "compute_tile",
    "extra_vars",
    "result_dtypes",
    "result_names",
    "variable_attrs",
]

RESULT_VARS = MODEL.observables
"""Kernel observables kept for every point, besides ``outcome``."""

NOT_COMPUTED = -1
"""``status`` and ``outcome`` of a point not computed yet (in a zarr store being
written); every other variable of such a point is NaN, or -1 for integers."""


@dataclass(frozen=True)
class TileResult:
    """What a tile task returns: the per-point results of flat points [start, stop)
    (``data``: variable name -> 1-d array), the kernel's trajectory-steps and the
    task's wall time (s)."""

    tile: int
    start: int
    stop: int
    data: dict[str, np.ndarray]
    steps: int
    seconds: float

    def summary(self) -> dict[str, Any]:
        """What the progress report needs."""
        return {
            "tile": self.tile,
            "n": self.stop - self.start,
            "steps": self.steps,
            "seconds": self.seconds,
        }


def extra_vars(sweep: Sweep) -> tuple[str, ...]:
    """Per-point variables besides the observables: the default time step when dt is not
    given, and the random draws."""
    given = {k[:-4] if k.endswith("_deg") else k for k in (*sweep.axes, *sweep.fixed)}
    return (("dt",) if "dt" not in given else ()) + tuple(
        r.name for r in sweep.random_params
    )


def result_vars(sweep: Sweep) -> tuple[str, ...]:
    """The kernel observables the sweep keeps for every point: :data:`RESULT_VARS`, and
    ``lyapunov`` when the sweep computes it."""
    return (*RESULT_VARS, "lyapunov") if sweep.lyapunov else RESULT_VARS


def result_names(sweep: Sweep) -> tuple[str, ...]:
    """Every per-point variable of the sweep's result, in order."""
    return (*result_vars(sweep), "outcome", *extra_vars(sweep))


def result_dtypes(sweep: Sweep) -> dict[str, np.dtype]:
    """The dtype of every per-point variable, known before anything is computed."""
    model = with_lyapunov(MODEL)
    n_obs = 1 + max(
        model.observable_row(k) for k in model.observables if k not in MODEL.derived
    )
    empty = results.observables_dataset(model, np.zeros((n_obs, 0)), "point")
    dtypes = {k: empty[k].dtype for k in result_vars(sweep)}
    dtypes["outcome"] = np.dtype(np.int8)
    dtypes.update({k: np.dtype(float) for k in extra_vars(sweep)})
    return dtypes


_STATUS_COMMENT = (
    "not_computed: the point has not been computed yet (a store being written)."
)
_STOP_COMMENT = (
    "stop = first_reversal: each launch ended at its first reversal, so "
    "several_reversals does not occur and capsized, lifted_off and "
    "numerical_failure happened before any reversal; t_final says when the "
    "launch ended."
)


def variable_attrs(sweep: Sweep, name: str) -> dict[str, Any]:
    """CF attributes of a per-point result variable. The flags of ``status`` and
    ``outcome`` include ``not_computed`` (:data:`NOT_COMPUTED`), which only a sweep still
    being written shows."""
    if name in ("status", "outcome"):
        attrs = dict(OUTCOME_ATTRS) if name == "outcome" else MODEL.attrs("status")
        attrs["flag_values"] = [*attrs["flag_values"], NOT_COMPUTED]
        attrs["flag_meanings"] = attrs["flag_meanings"] + " not_computed"
        attrs["comment"] = attrs["comment"] + " " + _STATUS_COMMENT
        if name == "outcome" and sweep.stop is not None:
            attrs["comment"] += " " + _STOP_COMMENT
        return attrs
    if name == "dt":
        return {
            **RATTLEBACK["dt"].attrs,
            "comment": f"the default step: {RATTLEBACK['dt'].default_doc.replace('`', '')}",
        }
    for rp in sweep.random_params:
        if rp.name == name:
            # the long name is the input's, as in every other result; the draw is a comment
            return {
                "units": rp.result_units,
                "long_name": rp.long_name,
                "comment": f"random draw, {rp.kind} {rp.a:g}, {rp.b:g}",
            }
    return MODEL.attrs(name)


def compute_points(sweep: Sweep, index: np.ndarray) -> tuple[dict[str, np.ndarray], int]:
    """Run the points at flat indices ``index`` of the sweep's grid through the kernel on
    the calling thread (numba's serial ``nogil`` entry, so tasks on different threads
    run in parallel without nesting threads). Returns every per-point variable
    (:func:`result_names`) and the trajectory-steps taken. Touches no file."""
    bodies, kwargs = sweep.points_at(index)
    # a sweep announces its size as a whole, not each tile
    prep = prepare(
        bodies, stop=sweep.stop, lyapunov=sweep.lyapunov, announce=False, **kwargs
    )
    raw = engine.execute(
        prep,
        method=check_method(sweep.method),
        record_every=None,
        band=sweep.reversal_band,
        parallel=False,
    )
    obs = results.observables_dataset(prep.model, raw.observables, "point")
    data = {k: obs[k].values for k in result_vars(sweep)}
    data["outcome"] = classify(
        data["status"],
        data["n_reversals"],
        data["mean_final_spin"],
        data["initial_spin"],
        sweep.reversal_band,
    )
    if "dt" in extra_vars(sweep):
        data["dt"] = np.asarray(prep.coords["dt"][1], dtype=float)
    for rp in sweep.random_params:
        data[rp.name] = rp.result_draw(sweep.seed, index)
    return data, int(np.sum(data["steps"]))


def compute_tile(sweep: Sweep, tile: int) -> TileResult:
    """Run one tile of the sweep's grid (:func:`compute_points`) and return its
    results."""
    t0 = time.perf_counter()
    start, stop = sweep.tile_range(tile)
    data, steps = compute_points(sweep, np.arange(start, stop, dtype=np.int64))
    return TileResult(tile, start, stop, data, steps, time.perf_counter() - t0)


@dataclass(frozen=True)
class LevelTile:
    """A task of a refined sweep: the points ``index`` (flat indices into the finest
    grid) of tile ``tile`` of refinement level ``level``."""

    level: int
    tile: int
    index: np.ndarray

    @property
    def key(self) -> str:
        return f"level{self.level}-{self.tile}"


@dataclass(frozen=True)
class LevelTileResult:
    """A finished :class:`LevelTile`: every per-point variable, the trajectory-steps
    taken and the task's wall time (s)."""

    level: int
    tile: int
    index: np.ndarray
    data: dict[str, np.ndarray]
    steps: int
    seconds: float

    def summary(self) -> dict[str, Any]:
        return {
            "tile": self.tile,
            "n": len(self.index),
            "steps": self.steps,
            "seconds": self.seconds,
        }


def compute_level_tile(fine: Sweep, item: LevelTile) -> LevelTileResult:
    """Simulate the points of one level's tile on the finest grid ``fine``."""
    t0 = time.perf_counter()
    data, steps = compute_points(fine, item.index)
    return LevelTileResult(
        item.level, item.tile, item.index, data, steps, time.perf_counter() - t0
    )
