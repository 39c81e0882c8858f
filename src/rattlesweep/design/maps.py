"""The design's reversal map: first reversal time over launch spin × friction."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from ..batch import run_batch
from ..body import Body
from .search import Launches

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["MAP_TILT", "map_figure", "reversal_map_data", "write_map"]

MAP_TILT = (math.radians(0.5), math.radians(0.5))
"""(roll, pitch) (rad) of the launches of the map."""


def reversal_map_data(body: Body, launches: Launches, n_spin: int = 41, n_mu: int = 9
                      ) -> xr.Dataset:
    """First reversal time (s) of ``body`` over ``n_spin`` spins from −12 to 12 rad/s
    and ``n_mu`` friction values over the launches' range, tilted by :data:`MAP_TILT`,
    each launch run to its first reversal or ``launches.t_end``."""
    spin = np.linspace(-12.0, 12.0, n_spin)
    mu = np.linspace(launches.mu[0], launches.mu[1], n_mu) if n_mu > 1 else \
        np.array(launches.mu[:1])
    ds = run_batch(body, spin=spin[:, None], mu=mu[None, :], roll=MAP_TILT[0],
                   pitch=MAP_TILT[1], t_end=launches.t_end, stop="first_reversal")
    t = ds.first_reversal_time.values.reshape(n_spin, n_mu)
    t = np.where(ds.status.values.reshape(n_spin, n_mu) == 0, t, np.nan)
    return xr.Dataset(
        {"first_reversal_time": (("spin", "mu"), t, {
            "units": "s", "long_name": "first reversal time (NaN: none within t_end)"})},
        coords={"spin": ("spin", spin, {"units": "rad s-1", "long_name": "launch spin"}),
                "mu": ("mu", mu, {"units": "1", "long_name": "friction coefficient"})},
        attrs={"t_end": launches.t_end, "roll_deg": math.degrees(MAP_TILT[0]),
               "pitch_deg": math.degrees(MAP_TILT[1]), "launches": int(t.size)})


def map_figure(data: xr.Dataset, prefer: str, spins: tuple[float, float]) -> "Figure":
    """Picture of :func:`reversal_map_data`: colour is the first reversal time, grey
    no reversal within t_end; dashed lines bound the spins ``spins`` (rad/s) of a
    person's flick."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 3.6))
    ax = fig.add_subplot()
    ax.set_facecolor("0.85")
    t = data.first_reversal_time.transpose("mu", "spin")
    mesh = ax.pcolormesh(data.spin.values, data.mu.values, t.values, shading="nearest",
                         cmap="viridis_r", vmin=0.0, vmax=float(data.attrs["t_end"]))
    fig.colorbar(mesh, ax=ax, label="first reversal time (s)")
    for s in (-spins[1], -spins[0], spins[0], spins[1]):
        ax.axvline(s, color="k", ls="--", lw=0.6)
    ax.set_xlabel("launch spin n (rad/s; > 0 counter-clockwise seen from above)")
    ax.set_ylabel("friction coefficient mu")
    ax.set_title(f"reversal map (grey: no reversal within {data.attrs['t_end']:g} s; "
                 f"prefers {'counter-' if prefer == 'ccw' else ''}clockwise; tilt "
                 f"{data.attrs['roll_deg']:.2g} deg roll + {data.attrs['pitch_deg']:.2g} "
                 "deg pitch)", fontsize=8)
    fig.tight_layout()
    return fig


def write_map(data: xr.Dataset, prefer: str, spins: tuple[float, float], path: Path
              ) -> Path:
    """Write the map picture (PNG) to ``path``."""
    map_figure(data, prefer, spins).savefig(path, dpi=120)
    return path
