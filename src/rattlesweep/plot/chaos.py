"""Pictures of chaos: maps of the largest Lyapunov exponent over a sweep, with the linear
stability of steady spin over them, and Poincaré sections of single runs."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

import xarray as xr
from matplotlib.figure import Figure

from .labels import axis_label
from .maps import _select, mpl_cmap, reversal_map

if TYPE_CHECKING:
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
    colours = mpl_cmap(cmap)
    handles: list[Any] = [Patch(color=colours(v), label=text) for v, text in _REGIONS]
    if stability is not None:
        handles += [
            Patch(
                facecolor="none",
                edgecolor="0.2",
                hatch="//",
                label="hatched: steady upright spin linearly unstable",
            ),
            Line2D([], [], color="black", lw=1.5, label="linear stability boundary"),
        ]
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
    if stability is not None:
        values = [None] if facet is None else list(ds[facet].values)
        panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
        for ax, value in zip(panels, values):
            where = {**(select or {}), **({facet: value} if facet else {})}
            _draw_stability(ax, stability, x, y, where)
    return fig


def _draw_stability(
    ax: Axes, stability: xr.Dataset, x: str, y: str, where: Mapping[str, Any]
) -> None:
    """Hatch where steady spin is unstable and draw the boundary on ``ax``."""
    import numpy as np

    growth = stability["growth_rate"]
    for dim in (x, y):
        if dim not in growth.dims:
            raise ValueError(
                f"stability: growth_rate has no dimension {dim!r} ({list(growth.dims)})"
            )
    growth = _select(growth, {k: v for k, v in where.items() if k in growth.dims})
    extra = [d for d in growth.dims if d not in (x, y)]
    if extra:
        growth = growth.isel({d: 0 for d in extra})
    z = growth.transpose(y, x).values
    if not np.nanmax(z) > 0.0:
        return
    xs, ys = growth[x].values, growth[y].values
    ax.contourf(xs, ys, z, levels=[0.0, np.inf], colors="none", hatches=["//"])
    if np.nanmin(z) < 0.0:
        ax.contour(xs, ys, z, levels=[0.0], colors="black", linewidths=1.5)


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
