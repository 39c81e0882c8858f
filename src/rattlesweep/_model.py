"""What the batch layer knows of a model, and the two things it hands between its
layers: a :class:`Prepared` batch (packed by :mod:`rattlesweep._pack`) and the
:class:`Raw` arrays a kernel run returns (:mod:`rattlesweep._run`), which
:mod:`rattlesweep._results` labels.

A model is described once by a :class:`Model`: its kernel number, its row tables
(:mod:`rattlesweep._core.rattleback.layout`, :mod:`rattlesweep._core.planar.layout`) and
which observables and series its results carry.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Callable, Mapping

import numpy as np

from ._core.workspace import OBSERVABLES

__all__ = ["Model", "Prepared", "Raw"]


@dataclass(frozen=True)
class Model:
    """What the batch layer needs to know of a model.

    ``number`` is the kernel's model number (:mod:`rattlesweep._core.models`); ``layout``
    the model's layout module (``PARAMS``, ``STATE``, ``RECORD``, ``OBSERVABLES``,
    ``N_OBS``); ``observables`` the names of the per-run results, in order, each a row
    of the shared or the model's observables or a key of ``derived``: (function of the
    observables before it by name, units, long name); ``status_attrs`` are the CF
    attributes of the status flags (their comment says what each status means for the
    model).
    """

    number: int
    layout: ModuleType
    observables: tuple[str, ...]
    status_attrs: Mapping[str, Any]
    derived: Mapping[
        str, tuple[Callable[[Mapping[str, np.ndarray]], np.ndarray], str, str]
    ] = field(default_factory=dict)

    def observable_row(self, name: str) -> int:
        if name in OBSERVABLES:
            return OBSERVABLES.start(name)
        return OBSERVABLES.size + self.layout.OBSERVABLES.start(name)

    def attrs(self, name: str) -> dict[str, Any]:
        """CF attributes of a result variable of this model."""
        if name == "status":
            return dict(self.status_attrs)
        if name in self.derived:
            return {"units": self.derived[name][1], "long_name": self.derived[name][2]}
        for rows in (self.layout.OBSERVABLES, OBSERVABLES, self.layout.RECORD):
            if name in rows:
                row = rows[name]
                return {"units": row.units, "long_name": row.long_name}
        raise KeyError(name)


@dataclass(frozen=True)
class Prepared:
    """A validated batch packed into kernel blocks."""

    model: Model
    P: np.ndarray  # (n_blocks, n_param, BLOCK)
    Y: np.ndarray  # (n_blocks, n_state, BLOCK)
    nsteps: np.ndarray  # (n_blocks, BLOCK) int64; 0 for padding lanes
    n: int  # trajectories
    shape: tuple[int, ...]  # broadcast shape of the inputs
    coords: dict[str, Any]  # name -> (dims, flat values), every input per trajectory
    # each trajectory's lane among all of the blocks' lanes, when they are not the first n
    # in order (a Lyapunov batch: each launch beside its shadow, rattlesweep._shadows)
    lanes: np.ndarray | None = None

    def per_trajectory(self, arr: np.ndarray) -> np.ndarray:
        """(n_blocks, n_rows, BLOCK) → (n_rows, n): each trajectory's lane."""
        flat = arr.transpose(1, 0, 2).reshape(arr.shape[1], -1)
        return flat[:, : self.n] if self.lanes is None else flat[:, self.lanes]


@dataclass(frozen=True)
class Raw:
    """What a kernel run returns, per trajectory: observables (n_obs, n), records
    (n, n_rec, n_record) or None, final state (n_state, n)."""

    observables: np.ndarray
    records: np.ndarray | None
    final_state: np.ndarray
