"""``design``: from a shell's semi-axes and a coin to the files to print."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..body import Body
from .coins import DEFAULT_COIN, Coin, coin_preset
from .constraints import check_coin_fits, check_margin, check_shell, max_coin_mass
from .mass import Part, body_of, moments_of
from .printing import Material, PrintSettings, material_preset, require
from .search import Launches, SearchResult, bad_sign, search

__all__ = ["Design", "design", "make_coin"]


@dataclass
class Design:
    """A finished design: the part (shell, coins, placement, print), the simulated
    body, the search, the predicted behaviour and the files written (empty without
    ``out``)."""

    part: Part
    body: Body
    prefer: str
    margin: float
    launches: Launches
    search: SearchResult
    prediction: dict[str, Any]
    reversal_map: xr.Dataset | None = None
    files: dict[str, Path] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def launches_simulated(self) -> int:
        """Launches simulated: the search's and the reversal map's."""
        extra = 0 if self.reversal_map is None else int(self.reversal_map.attrs["launches"])
        return self.search.launches + extra

    def summary(self) -> str:
        """A few lines for people."""
        p, c = self.part, self.part.coin
        pred = self.prediction
        lines = [
            f"shell {2 * p.a * 1e3:.4g} x {2 * p.b * 1e3:.4g} x {p.c * 1e3:.4g} mm "
            f"({p.settings.material.name}, infill {p.settings.infill:.0%}, wall "
            f"{p.settings.wall * 1e3:g} mm): print {pred['print_mass'] * 1e3:.3g} g, with "
            f"2 x {c.name} {self.body.mass * 1e3:.3g} g",
            f"coins at (x, y) = ({p.x * 1e3:+.1f}, {p.y * 1e3:+.1f}) and "
            f"({-p.x * 1e3:+.1f}, {-p.y * 1e3:+.1f}) mm; misalignment "
            f"{pred['misalignment_deg']:+.2f} deg; G {pred['com_height'] * 1e3:.3g} mm "
            f"above the contact point (limit {pred['com_height_limit'] * 1e3:.3g} mm)",
            f"prefers {self.prefer} (seen from above); spun {pred['bad_sense']} it "
            f"reverses after {_span(pred['first_reversal_time_mu_low'])} at mu = "
            f"{self.launches.mu[0]:g}, {_span(pred['first_reversal_time_mu_high'])} at "
            f"mu = {self.launches.mu[1]:g} (spins {min(self.launches.spins):g}-"
            f"{max(self.launches.spins):g} rad/s, tilts below 1 deg)",
            f"search: {self.search.launches} launches ({self.search.table.sizes['candidate']}"
            f" placements, {self.search.levels} refinement levels); "
            f"{'robust' if self.search.robust else 'NOT robust'} within "
            f"{self.launches.t_end:g} s",
        ]
        lines += self.search.notes
        return "\n".join(lines)


def _span(t: dict[str, float]) -> str:
    if not math.isfinite(t["max"]):
        return f"{t['min']:.2g} s to never (within t_end)"
    return f"{t['min']:.2g}-{t['max']:.2g} s (median {t['median']:.2g} s)"


def make_coin(coin: str | Coin | None = None, *, mass: float | None = None,
              diameter: float | None = None, thickness: float | None = None) -> Coin:
    """A coin from a preset name, a :class:`Coin`, or its numbers (kg, m): mass,
    diameter and thickness all given, or each overriding the preset's."""
    if coin is None and mass is not None and diameter is not None and thickness is not None:
        return Coin("custom", mass, diameter, thickness)
    base = coin if isinstance(coin, Coin) else coin_preset(
        DEFAULT_COIN if coin is None else coin)
    numbers = {"mass": mass, "diameter": diameter, "thickness": thickness}
    given = {k: v for k, v in numbers.items() if v is not None}
    if not given:
        return base
    return dataclasses.replace(
        base, name=f"{base.name} (modified)",
        source=f"{base.source}; changed by the user: {', '.join(sorted(given))}", **given)


def _prediction(part: Part, body: Body, result: SearchResult, launches: Launches,
                margin: float, prefer: str) -> dict[str, Any]:
    t = result.best.first_reversal_time.sel(sense="bad")

    def stats(mu: float) -> dict[str, float]:
        v = t.sel(mu=mu, method="nearest").values.ravel()
        v = np.where(np.isfinite(v), v, np.inf)
        return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}

    radius = min(body.radii_of_curvature)
    return {
        "preferred_sense": prefer,
        "bad_sense": "ccw" if prefer == "cw" else "cw",
        "robust": result.robust,
        "first_reversal_time_mu_low": stats(launches.mu[0]),
        "first_reversal_time_mu_high": stats(launches.mu[1]),
        "preferred_sense_reversed_fraction": float(result.best.good_reversed),
        "t_end": launches.t_end,
        "print_mass": moments_of(part, coins=False).mass,
        "total_mass": body.mass,
        "com_height": body.com_height,
        "com_height_limit": (1.0 - margin) * radius,
        "margin": margin,
        "max_coin_mass": max_coin_mass(part, margin),
        "misalignment_deg": math.degrees(body.misalignment),
        "launches_in_search": result.launches,
        "placements_tried": int(result.table.sizes["candidate"]),
        "refinement_levels": result.levels,
    }


def design(
    a: float, b: float, c: float, *, coin: str | Coin | None = None,
    coin_mass: float | None = None, coin_diameter: float | None = None,
    coin_thickness: float | None = None, coins: int = 2, infill: float = 0.2,
    material: str | Material = "pla", wall: float = 1.2e-3, clearance: float = 0.4e-3,
    rim: float = 2.0e-3, mu: tuple[float, float] = (0.2, 0.5), margin: float = 0.1,
    prefer: str = "cw", launches: Launches | None = None, grid: tuple[int, int] = (10, 6),
    refine: int = 2, out: str | Path | None = None, reversal_map: bool = True,
) -> Design:
    """Design a printable rattleback: a semi-ellipsoid shell printed flat face down,
    with two coins in pockets in its flat face placed, symmetric about the centre, where
    simulation says it spins on in the preferred sense and reverses quickly in the other.

    Parameters
    ----------
    a, b, c : float
        Semi-axes of the shell (m): half length, half width, height.
    coin : str or Coin, optional
        A preset of :data:`rattlesweep.design.COINS` (default ``"eur_1"``) or a
        :class:`Coin`.
    coin_mass, coin_diameter, coin_thickness : float, optional
        A coin by its numbers (kg, m), all three; or any of them changing the preset's.
    coins : int
        Number of coins: 2 (a pair symmetric about the centre).
    infill : float
        Infill fraction of the print's core, in (0, 1].
    material : str or Material
        ``"pla"`` (default), ``"petg"``, ``"abs"`` or a :class:`Material`.
    wall, clearance, rim : float
        Solid wall thickness, pocket diameter minus coin diameter, least material
        between a pocket and the face's edge or the other pocket (m).
    mu : (float, float)
        Friction range to design for (default 0.2-0.5: a table top).
    margin : float
        G must be at most (1 − margin) of the smaller radius of curvature at the bottom
        above the contact point; in [0, 1).
    prefer : {"cw", "ccw"}
        The sense (seen from above) in which it spins on.
    launches : Launches, optional
        The launches of the search (default: spins 3, 5, 7, 10 rad/s both senses, three
        tilts below 1 degree, three friction values over ``mu``, 15 s).
    grid, refine : optional
        Candidate grid (columns along x, placements per column) and refinement levels.
    out : path, optional
        Directory to write the files into: ``rattleback.stl``, ``placement_sheet.png``
        and ``.pdf``, ``design.toml``, ``sweep.toml`` and ``reversal_map.png``.
    reversal_map : bool
        Compute the reversal map (written with ``out``).

    Returns
    -------
    Design

    Raises
    ------
    ValueError
        For bad inputs, naming the parameter, the value and the rule, before any
        simulation; :class:`DesignRefused` (a ValueError) when the coins would lift G
        above the margin, with the largest coin mass that would do.
    """
    t0 = time.perf_counter()
    if coins != 2:
        raise ValueError(f"coins = {coins!r} is invalid: it must be 2 (a pair symmetric "
                         "about the centre)")
    bad_sign(prefer)
    margin = require("margin", margin, "a fraction in [0, 1)", lambda v: 0 <= v < 1)
    mat = material if isinstance(material, Material) else material_preset(material)
    settings = PrintSettings(mat, infill, wall, clearance, rim)
    the_coin = make_coin(coin, mass=coin_mass, diameter=coin_diameter,
                         thickness=coin_thickness)
    if len(mu) != 2:
        raise ValueError(f"mu = {mu!r} is invalid: it must be (low, high)")
    if launches is None:
        launches = Launches(mu=(mu[0], mu[1]))
    elif tuple(mu) != (0.2, 0.5) and tuple(mu) != launches.mu:
        raise ValueError(f"mu = {mu!r} differs from launches.mu = {launches.mu!r}: give "
                         "the friction range once")
    a, b, c = check_shell(a, b, c, settings)
    part = Part(a, b, c, the_coin, 0.0, 0.0, settings)
    check_coin_fits(a, b, c, part)
    check_margin(part, margin)
    out_dir = None if out is None else Path(out)
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"out = {str(out_dir)!r} is invalid: it must be a directory")
    result = search(part, launches, prefer, grid=grid, refine=refine)
    body = body_of(result.part, name="printed rattleback")
    prediction = _prediction(result.part, body, result, launches, margin, prefer)
    d = Design(result.part, body, prefer, margin, launches, result, prediction)
    if reversal_map:
        from .maps import reversal_map_data

        d.reversal_map = reversal_map_data(body, launches)
    if out_dir is not None:
        from .files import write_files

        d.files = write_files(d, out_dir)
    d.seconds = time.perf_counter() - t0
    return d

