"""The corner check of a sweep and the automatic tile size.

The batch layer's rules (tilt within the rim, ``mu_static >= mu``, curvature against the
step size, ...) are monotone in each parameter, so checking every combination of the
extremes of the axes and random ranges checks the whole grid, and the largest number of
steps any point takes is reached at a corner too. That number sizes the tiles.
"""

from __future__ import annotations

import itertools
import math
from typing import Any, Mapping

import numpy as np

from ..._shadows import check_rolling
from ...rattleback import batch
from ...rattleback.body import Body
from .grid import Axis, RandomParam, batch_inputs
from .params import resolve

__all__ = ["TILE_STEPS", "check_corners", "choose_tile_size", "tile_block"]

TILE_STEPS = 2e7
"""Trajectory-steps per tile aimed at by the automatic tile size."""

_STABILITY_T_END = 1.0
"""End time (s) the tiles of a configuration without ``t_end`` are sized for."""


def _max_steps(bodies: np.ndarray, kwargs: Mapping[str, Any]) -> int:
    return batch.max_steps(bodies, **kwargs)


PERIODIC = ("roll", "pitch")
"""The launch angles that tilt the body. The tilt rule is periodic in them, so the
extremes of an axis or range do not stand for the values between: the body's z axis has
the vertical component cos(roll) cos(pitch), which is extreme over a grid where each
angle takes a value of smallest or largest cosine (:func:`angle_corners`)."""


def angle_corners(
    values: list[float], lo: float | None = None, hi: float | None = None
) -> list[float]:
    """The values (rad) that stand for a launch angle's axis in the corner check: its
    extremes and its values of smallest and largest cosine; with ``lo`` and ``hi`` (a
    random range, rad), also the multiples of π inside it, where the cosine is ±1."""
    found = {min(values), max(values), min(values, key=math.cos), max(values, key=math.cos)}
    if lo is not None and hi is not None:
        k = math.ceil(lo / math.pi)
        found.update(min(max(j * math.pi, lo), hi) for j in (k, k + 1) if j * math.pi <= hi)
    return sorted(found)


def check_corners(
    grid_axes: tuple[Axis, ...],
    random_params: tuple[RandomParam, ...],
    fixed_si: dict[str, float],
    fixed_body: str | Body | None,
    fixed_shown: str = "",
    *,
    lyapunov: bool = False,
) -> int:
    """Check every combination of the extremes of the varying parameters (for a launch
    angle, :func:`angle_corners`) against the batch layer's rules; return the largest
    number of steps any point takes.

    ``fixed_si`` holds the fixed numeric parameters in SI by canonical name and
    ``fixed_body`` the fixed body (a preset name, a Body, or None when it varies). A
    broken rule is a ValueError naming the first offending corner and, when given,
    ``fixed_shown``, the fixed values as the configuration spells them (a rule may
    tie a fixed value to a varying one, or break on a fixed value alone). With
    ``lyapunov``, every corner must roll (:func:`rattlesweep._shadows.check_rolling`).
    """
    varying: list[tuple[str, str, list[Any]]] = []
    for ax in grid_axes:
        if ax.param == "body":
            varying.append((ax.key, "body", list(ax.values)))
        elif ax.param in PERIODIC:
            varying.append((ax.key, ax.param, angle_corners([float(v) for v in ax.si])))
        else:
            si = ax.si
            varying.append((ax.key, ax.param, sorted({float(si.min()), float(si.max())})))
    for rp in random_params:
        lo, hi = (bound * rp.factor for bound in rp.bounds())
        varying.append(
            (
                rp.key,
                rp.param,
                angle_corners([lo, hi], lo, hi) if rp.param in PERIODIC else [lo, hi],
            )
        )
    combos = list(itertools.product(*[v[2] for v in varying]))
    fixed = dict(fixed_si)
    if "t_end" not in fixed and all(param != "t_end" for _, param, _ in varying):
        fixed["t_end"] = _STABILITY_T_END
    columns = {k: np.full(len(combos), v) for k, v in fixed.items()}
    body_column = None
    for j, (_, param, _) in enumerate(varying):
        values = [c[j] for c in combos]
        if param == "body":
            body_column = np.array(values)
        else:
            columns[param] = np.array(values, dtype=float)

    def describe(i: int) -> str:
        return ", ".join(
            f"{key}={_show(combos[i][j], param, key)}"
            for j, (key, param, _) in enumerate(varying)
        )

    def check(sel: slice) -> int:
        bodies, kwargs = batch_inputs(
            {k: v[sel] for k, v in columns.items()},
            None if body_column is None else body_column[sel],
            fixed_body,
        )
        if lyapunov:
            given = {k: v[sel] for k, v in columns.items()}
            n = len(combos[sel])
            mu = given.get("mu", np.full(n, math.inf))
            check_rolling(
                {
                    "mu": mu,
                    "mu_static": given.get("mu_static", mu),
                    "mu_spin": given.get("mu_spin", np.zeros(n)),
                    "mu_roll": given.get("mu_roll", np.zeros(n)),
                },
                (n,),
            )
        return _max_steps(bodies, kwargs)

    try:
        return check(slice(None))
    except ValueError:
        # find the first offending corner to name it
        for i in range(len(combos)):
            try:
                check(slice(i, i + 1))
            except ValueError as exc:
                fixed_part = f"; fixed: {fixed_shown}" if fixed_shown else ""
                raise ValueError(
                    f"{exc} (at the sweep corner {describe(i)}{fixed_part})"
                ) from None
        raise


def choose_tile_size(max_steps: int, size: int) -> int:
    """Points per tile: about :data:`TILE_STEPS` trajectory-steps (``max_steps`` per
    point) and at least 16 tiles over ``size`` points, in multiples of 32 from 256 to
    65536."""
    tile = min(TILE_STEPS / max_steps, size / 16)
    return int(min(max(32 * math.ceil(tile / 32), 256), 65536))


def tile_block(shape: tuple[int, ...], tile_size: int) -> tuple[int, ...]:
    """The shape of a tile: a block of the grid of at most ``tile_size`` points whose
    points are consecutive in the flattened (C-order) grid.

    The trailing dimensions that fit in a tile are whole, the next one is cut into runs
    of even length, the leading ones into single indices. Such a block is both a
    contiguous range of flat point indices (what a task computes) and a rectangular
    region of the grid (a chunk of a zarr array).
    """
    block = list(shape)
    trailing = 1
    for j in reversed(range(len(shape))):
        if trailing * shape[j] <= tile_size:
            trailing *= shape[j]
            continue
        runs = -(-shape[j] // max(1, tile_size // trailing))
        block[j] = -(-shape[j] // runs)
        block[:j] = [1] * j
        break
    return tuple(block)


def _show(value: Any, param: str, key: str) -> str:
    if param == "body":
        return repr(value)
    try:
        _, factor, cf = resolve(key, None, key)
    except ValueError:
        factor, cf = 1.0, ""
    return f"{value / factor:g}" + (f" {cf}" if cf not in ("", "1") else "")
