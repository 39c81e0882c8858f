"""The design's reversal map: first reversal time over launch spin × friction."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from ..rattleback.batch import run_batch
from ..rattleback.body import Body
from .search import Launches

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["map_figure", "map_tilt", "reversal_map_data", "write_map"]


def map_tilt(launches: Launches) -> tuple[float, float]:
    """(roll, pitch) (rad) of the launches of the map: the search's first tilt."""
    return launches.tilts[0]


def reversal_map_data(
    body: Body, launches: Launches, n_spin: int = 41, n_mu: int = 9
) -> xr.Dataset:
    """First reversal time (s) of ``body`` over ``n_spin`` spins from −12 to 12 rad/s
    and ``n_mu`` friction values over the launches' range, tilted by
    :func:`map_tilt` (one of the search's tilts), each launch run to its first reversal
    or ``launches.t_end``."""
    roll, pitch = map_tilt(launches)
    spin = np.linspace(-12.0, 12.0, n_spin)
    mu = (
        np.linspace(launches.mu[0], launches.mu[1], n_mu)
        if n_mu > 1
        else np.array(launches.mu[:1])
    )
    ds = run_batch(
        body,
        spin=spin[:, None],
        mu=mu[None, :],
        roll=roll,
        pitch=pitch,
        t_end=launches.t_end,
        stop="first_reversal",
    )
    t = ds.first_reversal_time.values.reshape(n_spin, n_mu)
    t = np.where(ds.status.values.reshape(n_spin, n_mu) == 0, t, np.nan)
    return xr.Dataset(
        {
            "first_reversal_time": (
                ("spin", "mu"),
                t,
                {"units": "s", "long_name": "first reversal time (NaN: none within t_end)"},
            )
        },
        coords={
            "spin": ("spin", spin, {"units": "rad s-1", "long_name": "launch spin"}),
            "mu": ("mu", mu, {"units": "1", "long_name": "friction coefficient"}),
        },
        attrs={
            "t_end": launches.t_end,
            "roll_deg": math.degrees(roll),
            "pitch_deg": math.degrees(pitch),
            "launches": int(t.size),
        },
    )


def map_figure(
    data: xr.Dataset, prefer: str, spins: tuple[float, float], not_robust: str | None = None
) -> "Figure":
    """Picture of :func:`reversal_map_data`: colour is the first reversal time, grey
    no reversal within t_end; dashed lines bound the spins ``spins`` (rad/s) of a
    person's flick, in each sense. ``not_robust``: a line saying why the design is not
    robust, shown in red above the map."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.0 if not_robust else 3.6))
    ax = fig.add_subplot()
    ax.set_facecolor("0.85")
    t = data.first_reversal_time.transpose("mu", "spin")
    mesh = ax.pcolormesh(
        data.spin.values,
        data.mu.values,
        t.values,
        shading="nearest",
        cmap="viridis_r",
        vmin=0.0,
        vmax=float(data.attrs["t_end"]),
    )
    fig.colorbar(mesh, ax=ax, label="first reversal time (s)")
    for i, s in enumerate((-spins[1], -spins[0], spins[0], spins[1])):
        ax.axvline(
            s,
            color="k",
            ls="--",
            lw=0.8,
            label=None
            if i
            else f"a person's flick: {spins[0]:g} to {spins[1]:g} rad/s, either sense "
            "(the search's spins)",
        )
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), fontsize=7, frameon=False)
    ax.set_xlabel("launch spin n (rad/s; > 0 counter-clockwise seen from above)")
    ax.set_ylabel("friction coefficient mu")
    ax.set_title(
        f"reversal map (grey: no reversal within {data.attrs['t_end']:g} s; "
        f"prefers {'counter-' if prefer == 'ccw' else ''}clockwise)\nlaunch tilt "
        f"{data.attrs['roll_deg']:.2g} deg roll, {data.attrs['pitch_deg']:.2g} "
        "deg pitch (one of the search's tilts)",
        fontsize=8,
    )
    if not_robust:
        fig.suptitle(not_robust, color="red", fontsize=8, fontweight="bold")
    fig.tight_layout()
    return fig


def write_map(
    data: xr.Dataset,
    prefer: str,
    spins: tuple[float, float],
    path: Path,
    not_robust: str | None = None,
) -> Path:
    """Write the map picture (PNG) to ``path``."""
    map_figure(data, prefer, spins, not_robust).savefig(path, dpi=120)
    return path
