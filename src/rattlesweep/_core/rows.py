"""Declarative descriptions of the rows of the kernel's structure-of-arrays blocks.

Every per-trajectory quantity the kernel reads or writes is a *row* (or a run of
consecutive rows, for a vector) of some array of shape ``(..., n_rows, BLOCK)``. A
:class:`Rows` table lists them once, with units and a long name, and gives each its row
index: the kernels use those indices as module-level integer constants, the batch layer
packs inputs and labels outputs from the same table, and the CF attributes of a result
come from it. Plain Python, no numba: the tables are read at import time only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Iterator

__all__ = ["Row", "Rows", "check_regions", "input_row"]


@dataclass(frozen=True)
class Row:
    """One quantity: ``width`` consecutive rows (1 for a scalar).

    ``name`` is the quantity's name in results (a variable, coordinate or attribute);
    ``units`` and ``long_name`` are its CF attributes; ``dim`` names the extra dimension
    of a vector (``width`` > 1) in results. ``pack`` (parameters and states only) makes
    the row's values from the batch layer's flat inputs: a function of a mapping of
    named arrays, returning an array of shape (n,) or (n, width).
    """

    name: str
    units: str
    long_name: str
    width: int = 1
    dim: str | None = None
    pack: Callable | None = field(default=None, compare=False)


def input_row(
    described: Any, width: int = 1, dim: str | None = None, pack: Callable | None = None
) -> Row:
    """The row that packs a per-launch input, named, with units and long name, as the
    input's description in :mod:`rattlesweep.inputs` gives them, so that the kernel's
    tables and the results say the same. ``width`` and ``dim`` stay the layout's own:
    they shape the kernel's rows. ``pack`` makes the row's values (by default the
    input's own values)."""
    name = described.name
    return Row(
        name,
        described.units,
        described.long_name,
        width,
        dim,
        pack=pack if pack is not None else (lambda f: f[name]),
    )


class Rows:
    """An ordered table of :class:`Row` entries laid out in consecutive rows."""

    def __init__(self, label: str, *rows: Row):
        self.label = label
        self.rows = tuple(rows)
        starts, at = {}, 0
        for row in self.rows:
            if row.name in starts:
                raise ValueError(f"{label}: row {row.name!r} is listed twice")
            if row.width > 1 and row.dim is None:
                raise ValueError(f"{label}: vector row {row.name!r} needs a dim name")
            starts[row.name] = at
            at += row.width
        self._starts = starts
        self.size = at

    def __iter__(self) -> Iterator[Row]:
        return iter(self.rows)

    def __contains__(self, name: str) -> bool:
        return name in self._starts

    def __getitem__(self, name: str) -> Row:
        return self.rows[list(self._starts).index(name)]

    def start(self, name: str) -> int:
        """Index of the first row of quantity ``name``."""
        try:
            return self._starts[name]
        except KeyError:
            raise KeyError(f"{self.label} has no row {name!r}") from None

    def slice(self, name: str) -> slice:
        """The rows of quantity ``name``."""
        first = self.start(name)
        return slice(first, first + self[name].width)

    def names(self) -> tuple[str, ...]:
        return tuple(self._starts)

    def __repr__(self) -> str:
        return f"Rows({self.label!r}, {', '.join(self._starts)})"


def check_regions(label: str, regions: dict[str, tuple[int, int]], total: int) -> None:
    """Raise at import time unless the workspace regions ``name -> (offset, n_rows)``
    tile ``range(total)`` exactly: no overlap, no gap."""
    at = 0
    for name, (offset, n) in sorted(regions.items(), key=lambda item: item[1][0]):
        if offset != at:
            raise AssertionError(
                f"{label}: region {name} starts at row {offset}, "
                f"expected {at} (overlap or gap)"
            )
        at = offset + n
    if at != total:
        raise AssertionError(f"{label}: regions end at row {at}, the workspace has {total}")
