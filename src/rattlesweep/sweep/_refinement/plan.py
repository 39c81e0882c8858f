"""Adaptive refinement of a sweep's grid: which points to simulate at each level, and how
the others are filled from the corners of their cells.

A refined sweep's result lies on its finest grid (:meth:`Sweep.finest`): each refined
axis has ``2**levels`` times finer spacing than declared. Level 0 simulates the declared
grid, which is every ``2**levels``-th point of the finest grid along each refined axis.
Level ``k`` looks at the cells of level ``k - 1`` (boxes between neighbouring points of
that level's lattice, over the refined axes; every combination of the other dimensions
is a separate map):

* a cell whose corners are all simulated is a *boundary* cell when their ``outcome``
  differs, or the sign of their ``lyapunov`` exponent (a sweep that computes it), or,
  with ``reversal_time_jump``, when all of them reversed and their
  ``first_reversal_time`` spans more than that;
* the boundary cells and the cells next to them (a margin of one cell, diagonals
  included, so a feature thinner than a cell next to a visible boundary is not missed)
  are *refined*: the points of level ``k``'s lattice in them (twice as dense) that are
  not simulated yet are simulated;
* every point not simulated inside a cell whose corners are all simulated is filled
  from those corners: floating-point variables by multilinear interpolation (the nearest
  corner's value where a corner has none), integer and flag variables (``status``,
  ``outcome``, ``n_reversals``, ``steps``) from the nearest corner. Points inside cells
  that are refined are filled again from the finer cells at the next level, or
  simulated, so in the end every filled point lies in a cell whose corners agree (same
  outcome, and first reversal times within the jump): it carries the outcome of that
  cell.

Everything here is plain NumPy on arrays over the finest grid; running the levels is
:mod:`~rattlesweep.sweep._refinement.stages`, storing them
:mod:`~rattlesweep.sweep._outputs.refined`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np

__all__ = [
    "NEAREST",
    "Levels",
    "boundary_cells",
    "fill_from_corners",
    "new_points",
    "plan_level",
    "refined_cells",
]

NEAREST = ("status", "outcome", "n_reversals", "steps")
"""Variables a filled point takes from its cell's nearest corner (the others, floating
point, are interpolated)."""


@dataclass(frozen=True)
class Levels:
    """The lattices of a refined sweep: ``shape`` of the finest grid, ``axes`` the
    positions of the refined dimensions in it, ``levels`` the number of refinements."""

    shape: tuple[int, ...]
    axes: tuple[int, ...]
    levels: int

    def stride(self, level: int) -> int:
        """Spacing, in points of the finest grid, of level ``level``'s lattice."""
        return 2 ** (self.levels - level)

    def lattice(self, level: int) -> tuple[slice, ...]:
        """The index of level ``level``'s lattice into an array over the finest grid."""
        s = self.stride(level)
        return tuple(
            slice(None, None, s) if d in self.axes else slice(None)
            for d in range(len(self.shape))
        )

    def lattice_shape(self, level: int) -> tuple[int, ...]:
        s = self.stride(level)
        return tuple(
            (n - 1) // s + 1 if d in self.axes else n for d, n in enumerate(self.shape)
        )

    def level0(self) -> np.ndarray:
        """Flat indices (into the finest grid) of the declared grid, in C order."""
        mask = np.zeros(self.shape, dtype=bool)
        mask[self.lattice(0)] = True
        return np.flatnonzero(mask)


def _along(ndim: int, axes: tuple[int, ...], parts: Sequence[slice]) -> tuple[slice, ...]:
    """An index with slice ``parts[i]`` along refined axis ``axes[i]``, all elsewhere."""
    index = [slice(None)] * ndim
    for a, part in zip(axes, parts):
        index[a] = part
    return tuple(index)


def _corners(
    lattice: np.ndarray, axes: tuple[int, ...]
) -> Iterator[tuple[tuple[int, ...], np.ndarray]]:
    """(offsets, array over the cells) for each corner of the cells of a lattice."""
    for offs in itertools.product((0, 1), repeat=len(axes)):
        parts = [slice(o, lattice.shape[a] - 1 + o) for a, o in zip(axes, offs)]
        yield offs, lattice[_along(lattice.ndim, axes, parts)]


def boundary_cells(
    outcome: np.ndarray,
    first_reversal_time: np.ndarray,
    computed: np.ndarray,
    axes: tuple[int, ...],
    reversal_time_jump: float | None,
) -> tuple[np.ndarray, np.ndarray]:
    """(boundary, full) over the cells of a lattice, from the lattice's values: ``full``
    where every corner is simulated, ``boundary`` where a full cell's corners differ in
    outcome or (with ``reversal_time_jump``, s) all reversed with first reversal times
    spanning more than it."""
    full = np.logical_and.reduce([c for _, c in _corners(computed, axes)])
    o = np.stack([v for _, v in _corners(outcome, axes)])
    boundary = full & (o != o[0]).any(axis=0)
    if reversal_time_jump is not None:
        t = np.stack([v for _, v in _corners(first_reversal_time, axes)])
        reversed_all = np.isfinite(t).all(axis=0)
        with np.errstate(invalid="ignore"):
            span = t.max(axis=0) - t.min(axis=0)
        boundary |= full & reversed_all & (span > reversal_time_jump)
    return boundary, full


def refined_cells(boundary: np.ndarray, axes: tuple[int, ...]) -> np.ndarray:
    """The boundary cells and their neighbours along the refined axes (diagonals
    included)."""
    out = boundary.copy()
    n = boundary.ndim
    for shifts in itertools.product((-1, 0, 1), repeat=len(axes)):
        if not any(shifts):
            continue
        src, dst = [], []
        for a, sh in zip(axes, shifts):
            size = boundary.shape[a]
            src.append(slice(max(0, -sh), size - max(0, sh)))
            dst.append(slice(max(0, sh), size - max(0, -sh)))
        out[_along(n, axes, dst)] |= boundary[_along(n, axes, src)]
    return out


def new_points(
    refine: np.ndarray, computed_next: np.ndarray, axes: tuple[int, ...]
) -> np.ndarray:
    """Mask over the next level's lattice (twice as dense) of its points in the refined
    cells ``refine`` that are not simulated yet (``computed_next``: the simulated points
    of that lattice)."""
    mark = np.zeros(computed_next.shape, dtype=bool)
    n = mark.ndim
    for offs in itertools.product((0, 1, 2), repeat=len(axes)):
        parts = [slice(o, o + 2 * refine.shape[a] - 1, 2) for a, o in zip(axes, offs)]
        mark[_along(n, axes, parts)] |= refine
    return mark & ~computed_next


def fill_from_corners(
    values: dict[str, np.ndarray],
    computed: np.ndarray,
    full: np.ndarray,
    levels: Levels,
    level: int,
) -> None:
    """Fill, in place, every point of the finest grid that is not simulated and lies in a
    full cell (``full``, over the cells of level ``level``'s lattice) from the cell's
    corners (see the module's description). ``values`` maps each variable to its array
    over the finest grid."""
    axes, s = levels.axes, levels.stride(level)
    n = len(levels.shape)
    lattice = levels.lattice(level)
    corners = {name: dict(_corners(v[lattice], axes)) for name, v in values.items()}
    cells = full.shape
    for q in itertools.product(range(s + 1), repeat=len(axes)):
        if all(x in (0, s) for x in q):
            continue  # a corner: a lattice point, simulated in a full cell
        parts = [slice(x, x + s * (cells[a] - 1) + 1, s) for a, x in zip(axes, q)]
        where = _along(n, axes, parts)
        target = full & ~computed[where]
        if not target.any():
            continue
        nearest = tuple(int(2 * x > s) for x in q)
        weights = {
            offs: float(np.prod([x / s if o else 1.0 - x / s for o, x in zip(offs, q)]))
            for offs in itertools.product((0, 1), repeat=len(axes))
        }
        for name, v in values.items():
            near = corners[name][nearest]
            if name in NEAREST or v.dtype.kind != "f":
                v[where][target] = near[target]
                continue
            mix = sum(w * corners[name][offs] for offs, w in weights.items() if w != 0.0)
            mix = np.where(np.isnan(mix), near, mix)
            v[where][target] = mix[target]


def plan_level(
    values: dict[str, np.ndarray],
    computed: np.ndarray,
    levels: Levels,
    level: int,
    reversal_time_jump: float | None,
) -> np.ndarray:
    """Prepare level ``level`` (>= 1) from the state after the levels before it: fill
    the points of the full cells of level ``level - 1`` (in place, see
    :func:`fill_from_corners`) and return the flat indices, into the finest grid, of the
    points to simulate now, longest predicted run first (a filled point's ``t_final``
    predicts its run's length; ties in C order). ``values`` must hold ``outcome``,
    ``first_reversal_time`` and ``t_final``, and may hold ``lyapunov``."""
    axes = levels.axes
    coarse = levels.lattice(level - 1)
    outcome = values["outcome"][coarse]
    if "lyapunov" in values:  # the exponent's sign boundary is refined too
        outcome = 2 * outcome.astype(np.int64) + (values["lyapunov"][coarse] > 0.0)
    boundary, full = boundary_cells(
        outcome,
        values["first_reversal_time"][coarse],
        computed[coarse],
        axes,
        reversal_time_jump,
    )
    fill_from_corners(values, computed, full, levels, level - 1)
    mark = new_points(refined_cells(boundary, axes), computed[levels.lattice(level)], axes)
    where = list(np.nonzero(mark))
    stride = levels.stride(level)
    for a in axes:
        where[a] = where[a] * stride
    index = np.ravel_multi_index(tuple(where), levels.shape)
    order = np.argsort(-values["t_final"].ravel()[index], kind="stable")
    return index[order]
