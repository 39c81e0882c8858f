"""Maps of sweep and stability results over two of their axes, and the comparison of
simulated reversal times with linear growth rates."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Hashable, Mapping, Sequence

import xarray as xr
from matplotlib.figure import Figure

from .labels import axis_label as _label
from .labels import value_label

if TYPE_CHECKING:
    import numpy as np
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.collections import QuadMesh
    from matplotlib.colors import Colormap, Normalize

__all__ = [
    "FLAG_COLOURS",
    "OUTCOME_COLOURS",
    "reversal_map",
    "mpl_cmap",
    "reversed_fraction",
    "stability_map",
    "reversal_vs_growth",
]


OUTCOME_COLOURS = {
    "no_reversal": "#d9d9d9",
    "reversed": "#1f77b4",
    "several_reversals": "#17becf",
    "stopped": "#f2b701",
    "capsized": "#d62728",
    "lifted_off": "#9467bd",
    "numerical_failure": "#000000",
}
"""Fixed colours of outcome classes, so maps from different sweeps read alike."""

FLAG_COLOURS = {**OUTCOME_COLOURS, "filled": "#d9d9d9", "simulated": "#1f77b4"}
"""Colours of every category a map draws: outcomes, and a refined result's ``computed``
flag (simulated points dark, filled ones light)."""


def _select(da: xr.DataArray, select: Mapping[str, Any]) -> xr.DataArray:
    """Select exact matches as they are and other numeric values by the nearest
    coordinate (exact first, so that inf selects inf)."""
    import numpy as np

    for dim, value in select.items():
        values = da[dim].values
        numeric = values.dtype.kind in "fiu"
        if numeric and isinstance(value, str):
            raise ValueError(f"select: {dim} takes a number, got {value!r}")
        if not numeric and value not in values:
            raise ValueError(
                f"select: {value!r} is not a value of {dim} "
                f"({', '.join(str(v) for v in values)})"
            )
        if numeric and not (np.min(values) <= value <= np.max(values)):
            # the nearest value of an axis is taken for a value within it only
            raise ValueError(
                f"select: {dim} = {value} is not within its axis, "
                f"{np.min(values):g} .. {np.max(values):g}"
            )
        if value in values or not numeric:
            da = da.sel({dim: value})
        else:
            da = da.sel({dim: value}, method="nearest")
    return da


def _axis_values(da: xr.DataArray, dim: str) -> tuple[np.ndarray, list[str] | None]:
    """Plot positions and tick labels (None for numeric axes) of a dimension. A numeric
    axis with a non-finite value (``mu = [0.1, 0.3, inf]``: rolling beside friction) is
    drawn as categories, one cell per value, labelled with the values."""
    import numpy as np

    values = da[dim].values
    if values.dtype.kind in "OUS":
        return np.arange(len(values)), [str(v) for v in values]
    if values.dtype.kind == "f" and not np.all(np.isfinite(values)):
        return np.arange(len(values)), [
            "∞" if v == np.inf else ("−∞" if v == -np.inf else f"{v:g}") for v in values
        ]
    return values, None


def _fmt_coord(ds: xr.Dataset | xr.DataArray, dim: Hashable, value: object) -> str:
    return value_label(ds, dim, value)


def is_log_spaced(values: np.ndarray) -> bool:
    """True for at least three finite, positive, increasing values in a constant ratio
    other than 1 (a ``scale = "log"`` sweep axis): such an axis is drawn on a log
    scale."""
    import numpy as np

    v = np.asarray(values)
    if v.dtype.kind not in "fiu" or v.size < 3:
        return False
    v = v.astype(float)
    if not (np.all(np.isfinite(v)) and np.all(v > 0) and np.all(np.diff(v) > 0)):
        return False
    ratio = v[1:] / v[:-1]
    return bool(np.allclose(ratio, ratio[0], rtol=1e-6) and ratio[0] > 1.0 + 1e-6)


def _edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around plot positions: geometric midpoints on a log axis,
    arithmetic ones otherwise (half a step beyond the ends; ±0.5 for one value)."""
    import numpy as np

    v = np.asarray(values, dtype=float)
    if v.size == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    w = np.log(v) if log else v
    mid = 0.5 * (w[1:] + w[:-1])
    edges = np.concatenate([[w[0] - (mid[0] - w[0])], mid, [w[-1] + (w[-1] - mid[-1])]])
    return np.exp(edges) if log else edges


def reversal_map(
    ds: xr.Dataset,
    x: str,
    y: str,
    var: str = "outcome",
    *,
    facet: str | None = None,
    select: Mapping[str, Any] | None = None,
    reduce: str | None = None,
    title: str | None = None,
    ncols: int = 3,
    cmap: str = "viridis",
    overlay: xr.Dataset | None = None,
    zero_line: str | None = None,
    centred: bool = False,
    handles: Sequence[Artist] = (),
) -> Figure:
    """Map of a sweep result over two of its axes.

    Parameters
    ----------
    ds : a sweep result (:func:`rattlesweep.sweep.run_sweep`, or the netCDF file opened
        with ``xarray.open_dataset``).
    x, y : dimension names for the horizontal and vertical axes.
    var : result variable. Variables with CF ``flag_values``/``flag_meanings`` (``outcome``,
        ``status``) are drawn as categories with a legend; others with a colour bar
        labelled with their long name and units. NaN (e.g. ``first_reversal_time`` of a
        launch that never reversed) is drawn grey.
    facet : a third dimension; one panel per value.
    select : values of any other dimensions, e.g. ``{"mu": 0.3}`` (nearest match).
    reduce : ``"mean"`` averages a continuous variable over the dimensions left over
        (e.g. ``repeat``); categorical maps need every other dimension selected.
    overlay : a sweep result on the same axes: its simulated reversal boundary (where
        the fraction of launches that reversed at least once crosses 1/2) is drawn on
        every panel as a black line, e.g. over a stability map.
    zero_line : a continuous variable's zero drawn on every panel as a dashed white
        line, with this label in the legend (a growth rate's: the linear stability
        boundary).
    centred : a continuous variable's colour scale runs from -m to m, so that zero sits
        in the middle of a diverging ``cmap``; m is the 95th percentile of the values'
        magnitudes (a few extreme values, such as those of launches that capsize, take
        the end colours instead of washing out the rest).
    handles : more legend entries (matplotlib artists with labels), for what a caller
        draws on the panels.

    Returns a matplotlib Figure.
    """
    import numpy as np
    from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize
    from matplotlib.patches import Patch

    if var not in ds.data_vars:
        raise ValueError(
            f"var {var!r} is not in the dataset; it has "
            f"{sorted(str(name) for name in ds.data_vars)}"
        )
    da = ds[var]
    for role, dim in (("x", x), ("y", y), ("facet", facet)):
        if dim is not None and dim not in da.dims:
            raise ValueError(
                f"{role} {dim!r} is not a dimension of {var!r}; its dimensions "
                f"are {list(da.dims)}"
            )
    if len({x, y, facet} - {None}) != len([d for d in (x, y, facet) if d is not None]):
        raise ValueError(
            f"x, y and facet must be different dimensions, got {x!r}, {y!r}, {facet!r}"
        )
    if select:
        for dim in select:
            if dim in (x, y, facet):
                role = {x: "x", y: "y", facet: "facet"}[dim]
                raise ValueError(
                    f"select: {dim!r} is drawn (as {role}); select fixes only the "
                    "dimensions not drawn"
                )
            if dim not in da.dims:
                raise ValueError(
                    f"select: {dim!r} is not a dimension of {var!r} ({list(da.dims)})"
                )
        da = _select(da, select)
    if overlay is not None and "outcome" not in overlay.data_vars:
        raise ValueError(
            "overlay: expected a sweep result (with outcome), to draw its simulated "
            "reversal boundary"
        )
    categorical = "flag_values" in da.attrs
    extra = [d for d in da.dims if d not in (x, y, facet)]
    if extra:
        if reduce == "mean" and not categorical:
            da = da.mean(extra, keep_attrs=True)
        else:
            hint = "" if categorical else ", or reduce='mean'"
            raise ValueError(
                f"{var!r} also varies along {extra}; pick values with "
                f"select={{{extra[0]!r}: ...}}, or facet={extra[0]!r}{hint}"
            )
    elif reduce not in (None, "mean"):
        raise ValueError(f"reduce must be None or 'mean', got {reduce!r}")

    panels = (
        [(None, da)]
        if facet is None
        else [(v, da.sel({facet: v})) for v in da[facet].values]
    )
    ncols = max(1, min(ncols, len(panels)))
    nrows = -(-len(panels) // ncols)
    fig = Figure(figsize=(4.0 * ncols + 2.2, 3.4 * nrows + 0.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True, sharey=True)

    cm: Colormap
    norm: Normalize
    if categorical:
        meanings = da.attrs["flag_meanings"].split()
        flags = list(da.attrs["flag_values"])
        colours = [FLAG_COLOURS.get(m, f"C{i}") for i, m in enumerate(meanings)]
        cm = ListedColormap(colours)
        norm = BoundaryNorm(np.arange(len(flags) + 1) - 0.5, len(flags))
    else:
        cm = mpl_cmap(cmap)
        finite = da.values[np.isfinite(da.values)]
        norm = Normalize(*(finite.min(), finite.max()) if finite.size else (0, 1))
        if centred and finite.size:
            m = centred_limit(finite)
            norm = Normalize(-m, m)
    xs, xlabels = _axis_values(da, x)
    ys, ylabels = _axis_values(da, y)
    xlog = xlabels is None and is_log_spaced(xs)
    ylog = ylabels is None and is_log_spaced(ys)
    mesh: QuadMesh | None = None
    any_nan = False
    drew_zero = False
    zero_colour = "0.2" if centred else "white"
    for k, (value, panel) in enumerate(panels):
        ax = axes[k // ncols][k % ncols]
        z = panel.transpose(y, x).values.astype(float)
        if categorical:
            z = np.vectorize({f: i for i, f in enumerate(flags)}.get, otypes=[float])(z)
        any_nan |= bool(np.isnan(z).any())
        if xlog or ylog:  # cells between geometric midpoints along a log axis
            mesh = ax.pcolormesh(
                _edges(xs, xlog), _edges(ys, ylog), z, cmap=cm, norm=norm, shading="flat"
            )
        else:
            mesh = ax.pcolormesh(xs, ys, z, cmap=cm, norm=norm, shading="nearest")
        if xlog:
            ax.set_xscale("log")
        if ylog:
            ax.set_yscale("log")
        if overlay is not None:
            _draw_boundary(
                ax, overlay, x, y, {**(select or {}), **({facet: value} if facet else {})}
            )
        if zero_line and not categorical and np.nanmin(z) < 0.0 < np.nanmax(z):
            # white on a sequential scale; dark on a diverging one, white at zero
            ax.contour(xs, ys, z, levels=[0.0], colors=zero_colour, linestyles="--")
            drew_zero = True
        if value is not None and facet is not None:  # a value comes with its facet
            ax.set_title(_fmt_coord(da, facet, value), fontsize="medium")
        if xlabels:
            ax.set_xticks(xs, xlabels)
        if ylabels:
            ax.set_yticks(ys, ylabels)
        if k // ncols == nrows - 1:
            ax.set_xlabel(_label(da[x], x))
        if k % ncols == 0:
            ax.set_ylabel(_label(da[y], y))
    for k in range(len(panels), nrows * ncols):
        axes[k // ncols][k % ncols].set_visible(False)

    entries: list[Artist] = list(handles)
    if categorical:
        present = set(np.unique(da.values[~np.isnan(da.values.astype(float))]).tolist())
        entries += [
            Patch(color=c, label=m.replace("_", " "))
            for f, m, c in zip(flags, meanings, colours)
            if f in present
        ]
    else:
        assert mesh is not None  # there is a panel
        low = bool(finite.size and finite.min() < norm.vmin)
        high = bool(finite.size and finite.max() > norm.vmax)
        extend = {(True, True): "both", (True, False): "min", (False, True): "max"}.get(
            (low, high), "neither"
        )
        fig.colorbar(mesh, ax=axes.ravel().tolist(), label=_label(da, var), extend=extend)
    if overlay is not None:
        from matplotlib.lines import Line2D

        entries.append(
            Line2D([], [], color="black", lw=1.5, label="simulated reversal boundary")
        )
    if drew_zero:
        from matplotlib.lines import Line2D

        shown = zero_colour if centred else "0.4"  # white would not show in the legend
        entries.append(Line2D([], [], color=shown, ls="--", lw=1.2, label=zero_line))
    if any_nan:
        # matplotlib takes an RGBA array as a colour; its stubs' ColorType has no arrays
        bad = cm.get_bad() if not categorical else "white"
        entries.append(Patch(color=bad, label="no value (NaN)"))  # type: ignore[arg-type]
    if entries:
        # beside the panels, level with their middle: clear of the title above them
        fig.legend(
            handles=entries,
            loc="outside right center" if categorical else "outside lower center",
            title=da.attrs.get("long_name", var) if categorical else None,
        )
    # the values selected, then the configuration's fixed values (a store sorts its
    # coordinates), then the defaults
    order = [*(select or {}), *_given_fixed(ds)]
    scalars = [c for c in da.coords if da[c].ndim == 0 and da[c].dtype.kind in "fiu"]
    scalars.sort(key=lambda c: order.index(c) if c in order else len(order))
    fixed = [_fmt_coord(da, c, da[c].values.item()) for c in scalars]
    body = _body_named(ds)
    items = ([f"{body} body"] if body else []) + fixed[:6]
    fig.suptitle(title or _wrap_items(items, fig), fontsize="small")
    return fig


def _body_named(ds: xr.Dataset) -> str | None:
    """The name of the fixed body of the sweep that made ``ds`` (a preset's, or the
    name of a body table), from its ``sweep_config``; None when there is none."""
    import tomllib

    try:
        config = tomllib.loads(str(ds.attrs.get("sweep_config", "")))
    except tomllib.TOMLDecodeError:
        return None
    body = config.get("fixed", {}).get("body")
    if isinstance(body, dict):
        body = body.get("name")
    return body if isinstance(body, str) and body else None


def _given_fixed(ds: xr.Dataset) -> list[str]:
    """The result names of the fixed values a sweep's configuration (its
    ``sweep_config`` attribute) gives, in its order; none for other datasets."""
    import tomllib

    from ..sweep._config.params import result_name

    try:
        fixed = tomllib.loads(str(ds.attrs.get("sweep_config", ""))).get("fixed", {})
    except tomllib.TOMLDecodeError:
        return []
    return [result_name(key) for key in fixed if key != "body"]


def _wrap_items(items: list[str], fig: Figure) -> str:
    """Comma-separated items broken into lines that fit the figure's width (about 12
    characters of the small title font per inch)."""
    width = max(20, int(12 * fig.get_figwidth()))
    lines: list[str] = []
    for item in items:
        if lines and len(lines[-1]) + 2 + len(item) <= width:
            lines[-1] += ", " + item
        else:
            lines.append(item)
    return "\n".join(lines)


def mpl_cmap(name: str) -> Colormap:
    """A colormap by name, NaN drawn light grey."""
    import matplotlib

    return matplotlib.colormaps[name].with_extremes(bad="0.8")


def reversed_fraction(sweep: xr.Dataset) -> xr.DataArray:
    """Fraction (0 or 1 per launch; averaged by callers) of launches that reversed at
    least once, from a sweep's ``outcome``."""
    from ..sweep._outputs.outcomes import REVERSED, SEVERAL

    return sweep.outcome.isin([REVERSED, SEVERAL]).astype(float)


def centred_limit(finite: np.ndarray) -> float:
    """The end m of a centred colour scale, -m to m, over finite values: the 95th
    percentile of their magnitudes (1 when all are zero)."""
    import numpy as np

    return float(np.percentile(np.abs(finite), 95)) or 1.0


def overlay_panel(
    da: xr.DataArray, x: str, y: str, select: Mapping[str, Any], role: str
) -> xr.DataArray:
    """What another dataset's ``da`` draws on one panel of a map over ``x`` and ``y``:
    its values at the panel's ``select`` (on the dimensions it has), any other
    dimensions left to the caller. A ValueError starting with ``role`` says when it
    lacks ``x`` or ``y``."""
    for dim in (x, y):
        if dim not in da.dims:
            raise ValueError(f"{role} has no dimension {dim!r} ({list(da.dims)})")
    return _select(da, {k: v for k, v in select.items() if k in da.dims})


def _draw_boundary(
    ax: Axes, sweep: xr.Dataset, x: str, y: str, select: Mapping[str, Any]
) -> None:
    import numpy as np

    frac = overlay_panel(reversed_fraction(sweep), x, y, select, "overlay: the sweep")
    extra = [d for d in frac.dims if d not in (x, y)]
    if extra:
        frac = frac.mean(extra)
    z = frac.transpose(y, x).values
    if np.nanmin(z) < 0.5 < np.nanmax(z):
        ax.contour(
            frac[x].values, frac[y].values, z, levels=[0.5], colors="black", linewidths=1.5
        )


GROWTH_ZERO = "growth rate 0: linear stability boundary (stable where < 0)"
"""The legend's words for a growth rate's zero line."""


def stability_map(
    ds: xr.Dataset,
    x: str,
    y: str,
    var: str = "growth_rate",
    *,
    overlay: xr.Dataset | None = None,
    **kwargs: Any,
) -> Figure:
    """Map of a linear-stability result (:func:`rattlesweep.stability.stability_dataset`)
    over two axes: ``growth_rate`` (1/s) by default, or ``mode`` (stable / neutral /
    pitch- or roll-unstable) as categories, any other variable of the file alike.
    ``overlay`` (a sweep result on the same axes) adds the simulated reversal boundary;
    a growth rate's zero, the linear stability boundary, is drawn dashed. Other keyword
    arguments as for :func:`reversal_map`."""
    if var == "growth_rate":
        kwargs.setdefault("zero_line", GROWTH_ZERO)
    return reversal_map(ds, x, y, var, overlay=overlay, **kwargs)


def _log_ticks(axis: Any, values: np.ndarray) -> None:
    """Ticks of a log axis whose labels cannot crowd: plain numbers ("0.05", "2") at 1 to 9
    times the powers of ten for data within a decade, at 1, 2 and 5 times them up to
    three decades, at the powers of ten alone beyond; unlabelled minor ticks."""
    import numpy as np
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    decades = float(np.log10(values.max() / values.min())) if values.size else 0.0
    subs: tuple[float, ...] = (
        tuple(np.arange(1.0, 10.0))
        if decades < 1.0
        else (1.0, 2.0, 5.0)
        if decades <= 3.0
        else (1.0,)
    )
    axis.set_major_locator(LogLocator(base=10.0, subs=subs))
    axis.set_major_formatter(FormatStrFormatter("%g"))
    axis.set_minor_formatter(NullFormatter())


def reversal_vs_growth(
    stability: xr.Dataset,
    sweep: xr.Dataset,
    *,
    color_by: str | None = None,
    title: str | None = None,
) -> Figure:
    """Predicted against simulated: first reversal time (s) of each launch that reversed
    against the linear e-folding time 1/growth_rate (s) at the same grid point, log-log,
    coloured by ``color_by`` (a dimension) when given: a legend when the dimension has up to
    8 values, a colour bar when it has more. A dashed line marks the median ratio of the
    two times: a reversal that follows the linear growth lies near it."""
    import numpy as np

    for ds, role, name, made_by in (
        (stability, "stability", "e_folding_time", "rattlesweep stability"),
        (sweep, "sweep", "first_reversal_time", "a sweep"),
    ):
        if name not in ds.data_vars:
            raise ValueError(
                f"the {role} result has no {name}: expected what {made_by} writes"
            )
    t_rev = sweep.first_reversal_time
    efold = stability.e_folding_time
    shared = [d for d in efold.dims if d in t_rev.dims]
    if not shared:
        raise ValueError(
            f"the files share no dimension: stability {list(efold.dims)}, "
            f"sweep {list(t_rev.dims)}"
        )
    efold, t_rev = xr.align(efold, t_rev, join="inner")
    if efold.size == 0 or t_rev.size == 0:
        apart = [
            d
            for d in shared
            if not np.intersect1d(stability[d].values, sweep[d].values).size
        ]
        raise ValueError(
            f"the files share no grid point: no value of {', '.join(apart)} is in both"
        )
    efold, t_rev = xr.broadcast(efold, t_rev)
    ok = np.isfinite(t_rev.values) & np.isfinite(efold.values) & (efold.values > 0)
    if not ok.any():
        raise ValueError("no grid point both reversed in the sweep and is unstable")
    fig = Figure(figsize=(6.0, 4.8), layout="constrained")
    ax = fig.add_subplot()
    if color_by is not None:
        if color_by not in t_rev.dims:
            raise ValueError(
                f"color_by {color_by!r} is not a dimension ({list(t_rev.dims)})"
            )
        c = np.broadcast_to(
            t_rev[color_by].values.reshape(
                [-1 if d == color_by else 1 for d in t_rev.dims]
            ),
            t_rev.shape,
        )
        values = np.unique(c[ok])
        if t_rev.sizes[color_by] <= 8 or c.dtype.kind not in "fiu":
            for i, v in enumerate(values):
                sel = ok & (c == v)
                ax.scatter(
                    efold.values[sel],
                    t_rev.values[sel],
                    s=8,
                    alpha=0.5,
                    color=f"C{i % 10}",
                    label=_fmt_coord(t_rev, color_by, v.item()),
                )
        else:  # too many values for a legend: a colour bar
            points = ax.scatter(
                efold.values[ok], t_rev.values[ok], s=8, alpha=0.5, c=c[ok], cmap="viridis"
            )
            fig.colorbar(points, ax=ax, label=_label(t_rev[color_by], color_by))
    else:
        ax.scatter(efold.values[ok], t_rev.values[ok], s=8, alpha=0.5)
    ratio = float(np.median(t_rev.values[ok] / efold.values[ok]))
    span = np.array([efold.values[ok].min(), efold.values[ok].max()])
    ax.plot(
        span,
        ratio * span,
        color="0.3",
        ls="--",
        lw=1,
        label=f"first reversal = {ratio:.3g} e-folding times (the median ratio)",
    )
    ax.legend(fontsize="small")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _log_ticks(ax.xaxis, efold.values[ok])
    _log_ticks(ax.yaxis, t_rev.values[ok])
    ax.set_xlabel(_label(stability.e_folding_time, "e-folding time"))
    ax.set_ylabel(_label(sweep.first_reversal_time, "first reversal time"))
    ax.set_title(title or f"{int(ok.sum())} launches that reversed", fontsize="medium")
    return fig
