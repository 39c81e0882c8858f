"""Packing: a batch's flat per-trajectory inputs and launch state as the kernel's blocks
of BLOCK lanes, laid out by the model's row tables (:meth:`Prepared.per_trajectory
<rattlesweep._model.Prepared.per_trajectory>` reads them back)."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ._model import Model, Prepared
from ._core.rows import Rows
from ._core.workspace import BLOCK

__all__ = ["blocked", "pack", "prepared"]


def blocked(rows: np.ndarray, n: int) -> np.ndarray:
    """(n_rows, n) → (n_blocks, n_rows, BLOCK); padding lanes copy the first
    trajectory (they take no steps)."""
    n_blocks = -(-n // BLOCK)
    out = np.empty((rows.shape[0], n_blocks * BLOCK))
    out[:, :n] = rows
    out[:, n:] = rows[:, :1]
    return np.ascontiguousarray(
        out.reshape(rows.shape[0], n_blocks, BLOCK).transpose(1, 0, 2)
    )


def pack(table: Rows, columns: Mapping[str, np.ndarray], n: int) -> np.ndarray:
    """The rows of a parameter or state table as kernel blocks: each row from its
    ``pack`` function of the flat per-trajectory ``columns``, or, without one, the
    column of its name."""
    rows = np.empty((table.size, n))
    for row in table:
        values = np.asarray(
            row.pack(columns) if row.pack else columns[row.name], dtype=float
        )
        rows[table.slice(row.name)] = values.reshape(n, row.width).T
    return blocked(rows, n)


def prepared(
    model: Model,
    columns: Mapping[str, np.ndarray],
    state: Mapping[str, np.ndarray],
    nsteps: np.ndarray,
    n: int,
    shape: Sequence[int],
    coords: dict[str, Any],
) -> Prepared:
    """A :class:`~rattlesweep._model.Prepared` batch: the model's parameter rows packed
    from ``columns``, its state rows from ``state`` (flat per-trajectory values by row
    name)."""
    Y = pack(model.layout.STATE, state, n)
    steps = np.zeros(Y.shape[0] * BLOCK, dtype=np.int64)
    steps[:n] = nsteps
    return Prepared(
        model,
        pack(model.layout.PARAMS, columns, n),
        Y,
        steps.reshape(-1, BLOCK),
        n,
        tuple(shape),
        coords,
    )
