"""Pictures of single runs: spin histories, time-series panels with the stick/slip
phases shaded, and the contact point's path over the body or the floor."""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from .labels import axis_label

__all__ = [
    "RATTLEBACK_PANELS",
    "PLANAR_PANELS",
    "SLIP_SHADE",
    "spin_history",
    "time_series",
    "contact_path",
]

RATTLEBACK_PANELS = ("spin", "heading", "tilt", "energy", "slip_speed", "normal_force")
PLANAR_PANELS = ("angle", "rate", "energy", "slip_velocity", "normal_force")
SLIP_SHADE = "#fdd9a0"
"""Colour of the slipping phases in time-series panels."""


def _runs(runs: xr.Dataset | Iterable[xr.Dataset]) -> list[xr.Dataset]:
    if isinstance(runs, xr.Dataset):
        return [runs]
    runs = list(runs)
    if not runs or not all(isinstance(r, xr.Dataset) for r in runs):
        raise ValueError("runs must be an xarray.Dataset or a non-empty sequence of them")
    return runs


def _labels(labels: Iterable[str] | None, n: int) -> list[str]:
    if labels is None:
        return [f"run {i}" for i in range(n)] if n > 1 else [""]
    labels = list(labels)
    if len(labels) != n:
        raise ValueError(f"labels has {len(labels)} entries for {n} runs")
    return labels


def spin_history(
    runs: xr.Dataset | Iterable[xr.Dataset],
    labels: Sequence[str] | None = None,
    *,
    title: str | None = None,
) -> Figure:
    """Spin (rad/s) against time (s) for one or more :func:`rattlesweep.simulate` results,
    with each run's first reversal marked."""
    runs = _runs(runs)
    labels = labels or [f"run {i}" for i in range(len(runs))]
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    for ds, label in zip(runs, labels):
        (line,) = ax.plot(ds.time, ds.spin, label=label)
        t_rev = float(ds.first_reversal_time)
        if t_rev == t_rev:  # not NaN
            ax.axvline(t_rev, color=line.get_color(), ls=":", lw=1)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(axis_label(runs[0].time, "time"))
    ax.set_ylabel(axis_label(runs[0].spin, "spin"))
    ax.legend()
    if title:
        ax.set_title(title)
    return fig


def time_series(
    run: xr.Dataset,
    variables: Sequence[str] | None = None,
    *,
    shade_slip: bool = True,
    title: str | None = None,
) -> Figure:
    """Stacked panels of a run's series against time (s), sharing the time axis.

    Parameters
    ----------
    run : xarray.Dataset
        A :func:`rattlesweep.simulate` or :func:`rattlesweep.planar.simulate_planar`
        result, possibly merged with :func:`rattlesweep.rattleback.contact.contact_dataset`.
    variables : sequence of str, optional
        Names of series over ``time``; default ``spin``, ``heading``, ``tilt``, ``energy``,
        ``slip_speed``, ``normal_force`` for a rattleback and ``angle``, ``rate``,
        ``energy``, ``slip_velocity``, ``normal_force`` for the planar model. A series
        with a second dimension (e.g. ``friction_force`` over ``horizontal``) gets one
        line per component.
    shade_slip : bool, optional
        Shade the intervals where ``slipping`` is 1 on every panel (default).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure

    Each panel's label is the series' long name with its units; the spin panel marks
    the first reversal.
    """
    if not isinstance(run, xr.Dataset) or "time" not in run.dims:
        raise ValueError("run must be an xarray.Dataset over 'time' (a simulate() result)")
    if variables is None:
        default = PLANAR_PANELS if "angle" in run else RATTLEBACK_PANELS
        variables = [v for v in default if v in run]
    variables = list(variables)
    if not variables:
        raise ValueError("variables is empty")
    series = [v for v in run.data_vars if "time" in run[v].dims]
    for v in variables:
        if v not in series:
            raise ValueError(
                f"variable {v!r} is not a series over time in this run; it has {series}"
            )
    t = run.time.values
    fig = Figure(figsize=(7.5, 1.5 + 1.6 * len(variables)), layout="constrained")
    axes = fig.subplots(len(variables), 1, sharex=True, squeeze=False)[:, 0]
    slipping = run["slipping"].values > 0.5 if shade_slip and "slipping" in run else None
    for ax, name in zip(axes, variables):
        da = run[name]
        other = [d for d in da.dims if d != "time"]
        if len(other) > 1:
            raise ValueError(
                f"{name!r} has dimensions {list(da.dims)}; time_series draws "
                "series over time with at most one other dimension"
            )
        if other:
            for comp in da[other[0]].values:
                ax.plot(t, da.sel({other[0]: comp}).values, lw=1, label=str(comp))
            ax.legend(fontsize="x-small", loc="upper right", ncols=da.sizes[other[0]])
        else:
            ax.plot(t, da.values, lw=1, color="C0")
        if name == "spin" and "first_reversal_time" in run:
            t_rev = float(run.first_reversal_time)
            if np.isfinite(t_rev):
                ax.axvline(t_rev, color="k", ls=":", lw=1)
                ax.axhline(0.0, color="0.6", lw=0.8)
        if slipping is not None and slipping.any():
            ax.fill_between(
                t,
                0,
                1,
                where=slipping,
                step="post",
                color=SLIP_SHADE,
                transform=ax.get_xaxis_transform(),
                lw=0,
                zorder=0,
            )
        ax.set_ylabel(_wrap(axis_label(da, name)), fontsize="small")
    axes[-1].set_xlabel(axis_label(run.time, "time"))
    axes[-1].set_xlim(t[0], t[-1])
    if slipping is not None and slipping.any():
        from matplotlib.patches import Patch

        # below the time axis: a title of any length has the top to itself
        fig.legend(
            handles=[
                Patch(color=SLIP_SHADE, label="slipping"),
                Patch(facecolor="white", edgecolor="0.7", label="sticking"),
            ],
            loc="outside lower center",
            ncols=2,
            fontsize="small",
        )
    if title:
        fig.suptitle(title, fontsize="medium")
    return fig


def _wrap(text: str, width: int = 22) -> str:
    """Break a long axis label over lines so stacked panels stay narrow and each label
    stays within the height of its panel (about 22 characters of the small font)."""
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) or text


def contact_path(
    runs: xr.Dataset | Iterable[xr.Dataset],
    labels: Sequence[str] | None = None,
    *,
    frame: str = "body",
    title: str | None = None,
) -> Figure:
    """The contact point's path, one panel per run, coloured by time (s).

    ``frame="body"``: where on the body's curved surface it touches, in body x, y (mm;
    the dashed line is the rim x²/a² + y²/b² = 1 where it is in view), the picture of
    the spin-bias argument. Every panel has the same x and y ranges, those of all the
    paths together, so that panels compare at a glance. ``frame="floor"``: the trace on the
    floor in world X, Y (mm), with the centre of mass's ground track in grey. Runs are
    :func:`rattlesweep.simulate` results (or their files).
    """
    from matplotlib.collections import LineCollection

    from ..rattleback.contact import contact_dataset

    if frame not in ("body", "floor"):
        raise ValueError(f"frame must be 'body' or 'floor', got {frame!r}")
    runs = _runs(runs)
    labels = _labels(labels, len(runs))
    fig = Figure(figsize=(4.2 * len(runs) + 1.2, 4.2), layout="constrained")
    axes = fig.subplots(1, len(runs), squeeze=False, sharex=True, sharey=True)[0]
    t_max = max(float(r.time.values[-1]) for r in runs)
    from matplotlib.colors import Normalize

    norm = Normalize(0.0, t_max)
    lines = None
    paths = [contact_dataset(run) for run in runs]
    if frame == "body":
        xys = [c.contact_body.sel(body_axis=["x", "y"]).values * 1e3 for c in paths]
        names = ("contact point, body x", "contact point, body y")
    else:
        xys = [c.contact_floor.values * 1e3 for c in paths]
        names = ("contact point, floor X", "contact point, floor Y")
    lo = np.min([xy.min(0) for xy in xys], axis=0)
    hi = np.max([xy.max(0) for xy in xys], axis=0)
    pad = 0.08 * (hi - lo) + 1e-3  # per axis: a flat path stays a flat picture
    for k, (ax, run, label, c, xy) in enumerate(zip(axes, runs, labels, paths, xys)):
        if frame == "floor":
            ax.plot(
                run.position.sel(axis="X") * 1e3,
                run.position.sel(axis="Y") * 1e3,
                color="0.6",
                lw=0.8,
                label="centre of mass",
            )
        segments = np.stack([xy[:-1], xy[1:]], axis=1)
        # an (n, 2, 2) array is the sequence of segments matplotlib asks for; its stubs
        # take only a Sequence
        lines = LineCollection(segments, cmap="viridis", norm=norm, lw=1.2)  # type: ignore[arg-type]
        lines.set_array(c.time.values[:-1])
        ax.add_collection(lines)
        ax.plot(*xy[0], "o", color="k", ms=4, label="start")
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
        if frame == "body":
            a, b = (float(run.attrs[k]) * 1e3 for k in ("a", "b"))
            phi = np.linspace(0, 2 * np.pi, 721)
            ax.plot(
                a * np.cos(phi),
                b * np.sin(phi),
                "k--",
                lw=0.8,
                scalex=False,
                scaley=False,
                label="rim",
            )
        ax.set_xlabel(f"{names[0]} [mm]")
        if k == 0:  # the shared y axis is labelled once
            ax.set_ylabel(f"{names[1]} [mm]")
        ax.legend(fontsize="x-small", loc="upper right")
        if label:
            ax.set_title(label, fontsize="medium")
    assert lines is not None  # runs is not empty
    fig.colorbar(lines, ax=list(axes), label=axis_label(runs[0].time, "time"))
    if title:
        fig.suptitle(title, fontsize="medium")
    return fig
