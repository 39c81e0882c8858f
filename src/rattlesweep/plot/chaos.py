"""Pictures of chaos: maps of the largest Lyapunov exponent over a sweep, with the linear
stability of steady spin over them, and Poincaré sections of single runs."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

import xarray as xr
from matplotlib.figure import Figure

from .labels import axis_label
from .maps import (
    _axis_values,
    _edges,
    _select,
    centred_limit,
    is_log_spaced,
    mpl_cmap,
    overlay_panel,
    reversal_map,
)

if TYPE_CHECKING:
    import numpy as np
    from matplotlib.axes import Axes

__all__ = ["LYAPUNOV_ZERO", "lyapunov_map", "poincare_plot"]

LYAPUNOV_ZERO = "exponent 0"
"""The legend's words for the exponent's zero line."""

_REGIONS = (
    (0.9, "exponent > 0: launches separate (chaos, or escape from an unstable spin)"),
    (0.5, "exponent near 0: regular motion (a finite run: of order 1 / t_end)"),
    (0.1, "exponent < 0: the motion settles onto a steady state"),
)


def lyapunov_map(
    ds: xr.Dataset,
    x: str,
    y: str,
    *,
    stability: xr.Dataset | None = None,
    facet: str | None = None,
    select: Mapping[str, Any] | None = None,
    reduce: str | None = None,
    title: str | None = None,
    ncols: int = 3,
    cmap: str = "RdBu_r",
) -> Figure:
    """Map of the largest Lyapunov exponent (``lyapunov``, 1/s) of a sweep result over
    two of its axes, in a diverging colour scale centred on zero, its zero drawn dashed.

    ``stability`` (:func:`rattlesweep.stability.stability_dataset` of the same sweep, or
    any dataset with ``growth_rate`` over the drawn axes) adds the linear stability of
    steady upright spin: its boundary (growth rate 0) as a black line, the side where
    steady spin is unstable hatched. The legend tells the regions apart: regular motion
    (exponent near zero), exponential separation (positive: chaos, or the escape from
    an unstable steady spin, which the hatching shows) and settling (negative). Other
    arguments as for :func:`rattlesweep.plot.reversal_map`.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if "lyapunov" not in ds.data_vars:
        raise ValueError(
            "the dataset has no lyapunov variable: run the sweep with lyapunov = true "
            "(or run_batch(..., lyapunov=True))"
        )
    if stability is not None and "growth_rate" not in stability.data_vars:
        raise ValueError(
            "stability: expected a linear-stability dataset with growth_rate "
            "(rattlesweep.stability.stability_dataset)"
        )
    panels = [None] if facet is None else list(ds[facet].values)
    growth = (
        []
        if stability is None
        else [
            _growth_on(
                stability, ds, x, y, {**(select or {}), **({facet: v} if facet else {})}
            )
            for v in panels
        ]
    )
    colours = mpl_cmap(cmap)
    shown = _shown_regions(ds["lyapunov"], select, reduce)
    handles: list[Any] = [
        Patch(color=colours(v), label=text)
        for (v, text), there in zip(_REGIONS, shown)
        if there
    ]
    if any(bool((g > 0.0).any()) for g in growth):
        handles.append(
            Patch(
                facecolor="none",
                edgecolor="0.2",
                hatch="//",
                label="hatched: steady upright spin linearly unstable",
            )
        )
    if any(_boundary(g)[0].any() or _boundary(g)[1].any() for g in growth):
        handles.append(
            Line2D([], [], color="black", lw=1.5, label="linear stability boundary")
        )
    fig = reversal_map(
        ds,
        x,
        y,
        "lyapunov",
        facet=facet,
        select=select,
        reduce=reduce,
        title=title,
        ncols=ncols,
        cmap=cmap,
        zero_line=LYAPUNOV_ZERO,
        centred=True,
        handles=handles,
    )
    # room for the legend's lines below the panels
    width, height = fig.get_size_inches()
    fig.set_size_inches(width, height + 0.2 * (len(handles) + 1))
    axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    for ax, g in zip(axes, growth):
        _draw_stability(ax, ds, x, y, g)
    return fig


def _shown_regions(
    da: xr.DataArray, select: Mapping[str, Any] | None, reduce: str | None
) -> tuple[bool, bool, bool]:
    """Whether the map shows a positive, a near-zero and a negative exponent: a value
    beyond a tenth of the colour scale's end m (the 95th percentile of the magnitudes,
    as :func:`rattlesweep.plot.reversal_map` takes it) either way, or within it."""
    import numpy as np

    if select:
        da = _select(da, select)
    values = da.values[np.isfinite(da.values)]
    if values.size == 0:
        return (False, False, False)
    if reduce == "mean":  # the drawn means lie within the values' range
        values = np.array([values.min(), values.max(), values.mean()])
    m = centred_limit(values)
    return (
        bool((values > 0.1 * m).any()),
        bool((np.abs(values) <= 0.1 * m).any()),
        bool((values < -0.1 * m).any()),
    )


def _boundary(growth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where an unstable cell (growth > 0) meets a stable one (growth < 0; a neutral
    cell, growth 0, meets neither): (between columns i and i + 1, (ny, nx - 1); between
    rows j and j + 1, (ny - 1, nx))."""
    up, down = growth > 0.0, growth < 0.0
    across = (up[:, :-1] & down[:, 1:]) | (down[:, :-1] & up[:, 1:])
    along = (up[:-1, :] & down[1:, :]) | (down[:-1, :] & up[1:, :])
    return across, along


def _growth_on(
    stability: xr.Dataset, ds: xr.Dataset, x: str, y: str, where: Mapping[str, Any]
) -> np.ndarray:
    """The growth rate of ``stability`` on the map's cells (y, x) of one panel."""
    growth = stability["growth_rate"]
    if "mode" in stability:  # a growth rate of rounding size is neutral, not unstable
        from ..stability import NEUTRAL

        growth = growth.where(stability["mode"] != NEUTRAL, 0.0)
    growth = overlay_panel(growth, x, y, where, "stability: growth_rate")
    extra = [d for d in growth.dims if d not in (x, y)]
    if extra:
        growth = growth.isel({d: 0 for d in extra})
    try:
        growth = growth.sel({x: ds[x].values, y: ds[y].values})
    except KeyError:
        raise ValueError(
            f"stability: its {x} and {y} values are not those of the map"
        ) from None
    return growth.transpose(y, x).values


def _draw_stability(ax: Axes, ds: xr.Dataset, x: str, y: str, growth: np.ndarray) -> None:
    """Hatch the cells where steady spin is unstable and draw the boundary on ``ax``."""
    import numpy as np

    if not (growth > 0.0).any():
        return
    edges = []
    for dim in (x, y):
        values, labels = _axis_values(ds["lyapunov"], dim)
        log = labels is None and is_log_spaced(values)
        edges.append(_edges(values, log))
    unstable = np.ma.masked_where(~(growth > 0.0), np.ones(growth.shape))
    ax.pcolor(*edges, unstable, facecolor="none", edgecolor="0.2", hatch="//", lw=0)
    # the boundary along the cells' edges, where an unstable cell meets a stable one
    xe, ye = edges
    across, along = _boundary(growth)
    segments = [
        [(xe[i + 1], ye[j]), (xe[i + 1], ye[j + 1])] for j, i in zip(*across.nonzero())
    ]
    segments += [
        [(xe[i], ye[j + 1]), (xe[i + 1], ye[j + 1])] for j, i in zip(*along.nonzero())
    ]
    if segments:
        from matplotlib.collections import LineCollection

        ax.add_collection(LineCollection(segments, colors="black", linewidths=1.5))


def poincare_plot(
    section: xr.Dataset, x: str = "gamma_x", y: str = "gamma_y", *, title: str | None = None
) -> Figure:
    """The points of a Poincaré section (:func:`rattlesweep.poincare_section`) in the
    plane of two of its variables, coloured by the time of each crossing."""
    for name in (x, y):
        if name not in section.data_vars:
            raise ValueError(
                f"{name!r} is not a variable of the section; it has "
                f"{sorted(str(v) for v in section.data_vars)}"
            )
    fig = Figure(figsize=(5.2, 4.4), layout="constrained")
    ax = fig.subplots()
    points = ax.scatter(
        section[x].values,
        section[y].values,
        c=section["crossing_time"].values,
        s=4,
        cmap="viridis",
    )
    fig.colorbar(points, ax=ax, label=axis_label(section["crossing_time"], "crossing_time"))
    ax.set_xlabel(axis_label(section[x], x))
    ax.set_ylabel(axis_label(section[y], y))
    plane = section.attrs.get("section", "")
    ax.set_title(title or f"Poincaré section: {plane}", fontsize="medium")
    return fig
