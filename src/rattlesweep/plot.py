"""Matplotlib pictures of results. Functions return a ``matplotlib.figure.Figure`` and
never touch pyplot's global state, so they work headless and inside libraries."""

from __future__ import annotations

from typing import Sequence

import xarray as xr
from matplotlib.figure import Figure


def _label(da: xr.DataArray, fallback: str) -> str:
    name = da.attrs.get("long_name", fallback)
    units = da.attrs.get("units")
    return f"{name} [{units}]" if units and units != "1" else name


def spin_history(runs: Sequence[xr.Dataset], labels: Sequence[str] | None = None,
                 *, title: str | None = None) -> Figure:
    """Spin (rad/s) against time (s) for one or more :func:`rattlesweep.simulate` results,
    with each run's first reversal marked."""
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    labels = labels or [f"run {i}" for i in range(len(runs))]
    for ds, label in zip(runs, labels):
        (line,) = ax.plot(ds.time, ds.spin, label=label)
        t_rev = float(ds.first_reversal_time)
        if t_rev == t_rev:  # not NaN
            ax.axvline(t_rev, color=line.get_color(), ls=":", lw=1)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(_label(runs[0].time, "time"))
    ax.set_ylabel(_label(runs[0].spin, "spin"))
    ax.legend()
    if title:
        ax.set_title(title)
    return fig
