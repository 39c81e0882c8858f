"""What a sweep holds in memory at once, estimated from its configuration, and the
refusals of a sweep that could not fit: from the declared ``num`` of its axes before any
axis is made (:func:`check_declared_size`), and from the whole sweep before a run starts
(:func:`check_size`; a dry run reports the same figures, :func:`size_needs`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:
    from .spec import Sweep

__all__ = [
    "MAX_POINTS",
    "MERGED_BYTES",
    "REFINED_BYTES",
    "TILE_BYTES",
    "check_declared_size",
    "check_size",
    "size_needs",
]


MERGED_BYTES = 3
"""Bytes held per byte of a point's results while a netCDF sweep merges its tiles (the
merged arrays, a tile read, the writer's buffers)."""
REFINED_BYTES = 1000
"""Bytes a refined sweep holds per point of its finest grid: every result, its inputs
and the ``computed`` flag (about 250 bytes), the level plans and the written dataset."""
TILE_BYTES = 200
"""Bytes held per tile: its done flag, its entry in the list of tiles to compute."""


def check_size(sweep: Sweep) -> None:
    """Refuse, before anything is written or computed, a sweep whose result would not
    fit in the memory available: a netCDF sweep merges the whole grid in memory, a
    refined one holds its finest grid, a zarr one a flag per tile."""
    from ..._validation import check_memory

    for need in size_needs(sweep):
        check_memory(*need)


def size_needs(sweep: Sweep) -> list[tuple[str, str, int, str, str]]:
    """What :func:`check_size` checks: ``(name, value, bytes, what, advice)`` for each
    part of the sweep held in memory at once (the arguments of ``check_memory``)."""
    from .._execution.tiles import result_dtypes

    per_point = sum(d.itemsize for d in result_dtypes(sweep).values())
    fine = sweep.finest().shape if sweep.refine is not None else None
    return _needs(sweep.refine, sweep.output, sweep.shape, sweep.n_tiles, per_point, fine)


def check_declared_size(config: Mapping[str, Any]) -> None:
    """Refuse a grid no run could hold, from the declared ``num`` of the axes of a
    normalised configuration: run before any axis's values are made, so that a grid of
    10^16 points is refused at once rather than after gigabytes of axis values. What
    only some runs need (a netCDF merge, a refined sweep's finest grid) is checked by
    :func:`check_size` when a run starts, and reported by a dry run."""
    from ..._validation import check_memory
    from .corners import tile_block

    nums = {
        k: int(a["num"]) if "num" in a else len(a["values"])
        for k, a in config["axes"].items()
    }
    shape = tuple(nums.values()) + ((config["repeats"],) if config["random"] else ())
    points = math.prod(shape)
    declared = " × ".join(f"{k} (num = {n:,})" for k, n in nums.items())
    if len(shape) > len(nums):
        declared += f" × {shape[-1]:,} repeats"
    declared += f" = {points:,} points"
    if points > MAX_POINTS:
        raise ValueError(
            f"axes = {declared}: a sweep has at most 2**63 - 1 = {MAX_POINTS:,} points "
            "(its points are numbered by 64-bit integers); use fewer or shorter axes"
        )
    # every run holds its list of tiles; tiles hold 65536 points at most unless
    # tile_size says more (corners.choose_tile_size)
    block = tile_block(shape, config["tile_size"] or 65536)
    n_tiles = math.prod(-(-n // b) for n, b in zip(shape, block))
    ((name, _, need, what, advice),) = _needs(None, "zarr", shape, n_tiles, 0, None)
    check_memory(name, declared, need, what, advice)


MAX_POINTS = 2**63 - 1
"""The most points of a sweep's grid: flat point indices are 64-bit integers."""


def _needs(
    refine: Mapping[str, Any] | None,
    output: str,
    shape: tuple[int, ...],
    n_tiles: int,
    per_point: int,
    fine: tuple[int, ...] | None,
) -> list[tuple[str, str, int, str, str]]:
    if refine is not None and fine is not None:
        points = math.prod(fine)
        return [
            (
                "refine.levels",
                str(refine["levels"]),
                points * REFINED_BYTES,
                f"the finest grid {fine} ({points:,} points)",
                "refine fewer levels or fewer axes, or start from a coarser grid",
            )
        ]
    needs = [
        (
            "axes",
            f"grid {shape}",
            n_tiles * TILE_BYTES,
            f"the list of its {n_tiles:,} tiles",
            "a larger tile_size",
        )
    ]
    if output == "netcdf":
        size = math.prod(shape)
        needs.append(
            (
                "axes",
                f"grid {shape}",
                size * per_point * MERGED_BYTES,
                f"merging its {size:,} points into sweep.nc",
                'fewer points, or output = "zarr" (written tile by tile)',
            )
        )
    return needs
