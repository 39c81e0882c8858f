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

from ..rattleback.body import Body
from .coins import DEFAULT_COIN, Coin, coin_preset
from .constraints import check_coin_fits, check_margin, check_shell, max_coin_mass
from .mass import Part, body_of, moments_of
from .printing import MATERIALS, Material, PrintSettings, material_preset, require
from .progress import Progress, quiet
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
        t_end = self.launches.t_end
        lines = [
            f"shell {2 * p.a * 1e3:.4g} x {2 * p.b * 1e3:.4g} x {p.c * 1e3:.4g} mm "
            f"({p.settings.material.name}, infill {p.settings.infill:.0%}, wall "
            f"{p.settings.wall * 1e3:g} mm): print {pred['print_mass'] * 1e3:.3g} g, with "
            f"2 x {c.name} {self.body.mass * 1e3:.3g} g",
            f"coins at (x, y) = ({p.x * 1e3:+.1f}, {p.y * 1e3:+.1f}) and "
            f"({-p.x * 1e3:+.1f}, {-p.y * 1e3:+.1f}) mm; misalignment "
            f"{pred['misalignment_deg']:+.2f} deg; G {pred['com_height'] * 1e3:.3g} mm "
            f"above the contact point (limit {pred['com_height_limit'] * 1e3:.3g} mm)",
            f"prefers {self.prefer} (seen from above); spun {pred['bad_sense']} "
            f"(spins {min(self.launches.spins):g}-{max(self.launches.spins):g} rad/s, "
            f"tilts below 1 deg) "
            f"{_reverses(self.launches.mu[0], pred['first_reversal_time_mu_low'], t_end)}; "
            f"{_reverses(self.launches.mu[1], pred['first_reversal_time_mu_high'], t_end)}",
            f"search: {self.search.launches} launches "
            f"({self.search.table.sizes['candidate']}"
            f" placements, {self.search.levels} refinement levels); "
            + (
                "robust: every wrong-way launch reversed and no right-way one did within "
                f"{t_end:g} s of spinning"
                if self.robust
                else "NOT ROBUST (see below)"
            ),
        ]
        if not self.robust:
            lines += self.not_robust_report()
        return "\n".join(lines)

    @property
    def robust(self) -> bool:
        """Whether every bad-sense launch of the search reversed and no preferred-sense
        one did, within ``launches.t_end``."""
        return self.search.robust

    def not_robust_report(self) -> list[str]:
        """For a design that is not robust: what failed (fractions of the launches, the
        spins and friction values where) and what to try, from the numbers of the
        design. Empty for a robust design."""
        return [] if self.robust else not_robust_report(self)


def _reverses(mu: float, t: dict[str, float], t_end: float) -> str:
    """How the wrong-way launches at friction ``mu`` reverse: after what times, and how
    many of them do not within ``t_end`` (s)."""
    if not math.isfinite(t["min"]):
        return (
            f"it does not reverse at mu = {mu:g} within {t_end:g} s of spinning, in any "
            f"of its {t['launches']:g} launches"
        )
    if not math.isfinite(t["max"]):
        verb = "does" if t["not_reversed"] == 1 else "do"
        return (
            f"it reverses at mu = {mu:g} after {t['min']:.2g} s at the quickest, but "
            f"{t['not_reversed']:g} of its {t['launches']:g} launches {verb} not within "
            f"{t_end:g} s of spinning"
        )
    return (
        f"it reverses at mu = {mu:g} after {t['min']:.2g}-{t['max']:.2g} s (median "
        f"{t['median']:.2g} s) of spinning"
    )


def _count(mask: np.ndarray) -> str:
    return f"{int(mask.sum())} of {mask.size}"


def not_robust_report(d: Design) -> list[str]:
    """Lines saying why ``d`` is not robust and what to try (see
    :meth:`Design.not_robust_report`)."""
    best, launches, pred, p = d.search.best, d.launches, d.prediction, d.part
    t_end = launches.t_end
    bad = best.first_reversal_time.sel(sense="bad")
    good = best.first_reversal_time.sel(sense="good")
    missed = bad.isnull()
    spurious = good.notnull()
    lines = [
        "NOT ROBUST: no placement tried reverses every wrong-way launch and no "
        "right-way one:"
    ]
    hints: list[str] = []
    if bool(missed.any()):
        per_spin = missed.sum(["mu", "tilt"])
        per_mu = missed.sum(["spin", "tilt"])
        spins = [f"{float(s):g}" for s in per_spin.spin[per_spin > 0]]
        mus = [f"{float(m):g}" for m in per_mu.mu[per_mu > 0]]
        lines.append(
            f"  spun {pred['bad_sense']} (the wrong way), {_count(missed.values)} launches "
            f"({float(missed.mean()):.0%}) did not reverse within {t_end:g} s of spinning: "
            f"at spins {', '.join(spins)} rad/s, mu {', '.join(mus)}"
        )
        ok_spins = [float(s) for s in per_spin.spin[per_spin == 0]]
        if ok_spins and min(ok_spins) > float(per_spin.spin.min()):
            hints.append(
                f"flicked at {min(ok_spins):g} rad/s or faster it does reverse "
                "every time: the design may do if you spin it hard"
            )
        if len(mus) < len(per_mu) and len(per_mu) > 1:
            fine = [float(m) for m in per_mu.mu[per_mu == 0]]
            hints.append(
                f"a narrower friction range (--mu {min(fine):g} {max(fine):g}) "
                "if your table is known to be in it"
            )
        edge = abs(p.y) / p.b
        if edge < 0.3:
            hints.append(
                f"the coins sit near the long axis (|y| = {abs(p.y) * 1e3:.1f} mm of a "
                f"{p.b * 1e3:.3g} mm half width): a coin this wide leaves little room off "
                f"the axis for a bias; a smaller coin, or a wider shell (e.g. --b "
                f"{p.b * 1.1:.3g}) gives a stronger one"
            )
        if pred["com_height"] < 0.9 * pred["com_height_limit"] and not bool(spurious.any()):
            # (with right-way reversals too, a heavier coin would make those worse)
            most = pred["max_coin_mass"]
            hints.append(
                "a heavier coin of the same size biases it more"
                + (
                    f" (up to {most * 1e3:.3g} g keeps G within the margin; --coin-mass)"
                    if math.isfinite(most)
                    else " (--coin-mass)"
                )
            )
    if bool(spurious.any()):
        lines.append(
            f"  spun {pred['preferred_sense']} (the right way), {_count(spurious.values)} "
            f"launches ({float(spurious.mean()):.0%}) reversed within {t_end:g} s of "
            "spinning, which it should not"
        )
        if bool(missed.any()):
            hints.append(
                "some wrong-way launches do not reverse while some right-way ones do: the "
                "bias is too weak for the first and too strong for the second, so no coin "
                "mass mends both; a different shell, or a narrower friction range"
            )
        else:
            hints.append(
                "a lighter coin (--coin-mass): the bias is so strong that the right way is "
                "unstable too"
            )
    if pred["com_height"] >= 0.9 * pred["com_height_limit"]:
        lighter = "" if bool(missed.any()) else "a lighter coin or "
        hints.append(
            f"G is {pred['com_height'] * 1e3:.3g} mm above the contact point, near its "
            f"limit of {pred['com_height_limit'] * 1e3:.3g} mm: {lighter}a lower shell "
            "(smaller c) rocks more steadily"
        )
    hints.append(
        "a different shell (a, b, c) or coin; the files are written so that you "
        "can look at the map and the sheet, but a print may disappoint"
    )
    return lines + ["  what to try:"] + [f"  - {h}" for h in hints]


def make_coin(
    coin: str | Coin | None = None,
    *,
    mass: float | None = None,
    diameter: float | None = None,
    thickness: float | None = None,
) -> Coin:
    """A coin from a preset name, a :class:`Coin`, or its numbers (kg, m): mass,
    diameter and thickness all given, or each overriding the preset's."""
    if coin is None and mass is not None and diameter is not None and thickness is not None:
        return Coin("custom", mass, diameter, thickness)
    base = (
        coin
        if isinstance(coin, Coin)
        else coin_preset(DEFAULT_COIN if coin is None else coin)
    )
    numbers = {"mass": mass, "diameter": diameter, "thickness": thickness}
    given = {k: v for k, v in numbers.items() if v is not None}
    if not given:
        return base
    return dataclasses.replace(
        base,
        name=f"{base.name} (modified)",
        source=f"{base.source}; changed by the user: {', '.join(sorted(given))}",
        **given,
    )


def _material(material: str | Material, density: float | None) -> Material:
    """The material, its density overridden by ``density`` (kg/m³) when given."""
    if density is None:
        return material if isinstance(material, Material) else material_preset(material)
    rho = require(
        "density",
        density,
        "in kg/m^3, from 100 (a foam) to 25000",
        lambda v: 100 <= v <= 25000,
        lambda v: (
            f"{v:g} looks like g/cm^3: {v:g} g/cm^3 is {v * 1e3:g} kg/m^3"
            if 0 < v < 30
            else None
        ),
    )
    name = material.name if isinstance(material, Material) else str(material)
    source = (
        "given by the user"
        if name not in MATERIALS
        else f"given by the user (the {name} preset's: {MATERIALS[name].density:g} kg/m^3)"
    )
    return Material(name or "custom", rho, source)


def _prediction(
    part: Part,
    body: Body,
    result: SearchResult,
    launches: Launches,
    margin: float,
    prefer: str,
) -> dict[str, Any]:
    t = result.best.first_reversal_time.sel(sense="bad")

    def stats(mu: float) -> dict[str, float]:
        v = t.sel(mu=mu, method="nearest").values.ravel()
        v = np.where(np.isfinite(v), v, np.inf)
        return {
            "min": float(v.min()),
            "median": float(np.median(v)),
            "max": float(v.max()),
            "not_reversed": int(np.isinf(v).sum()),
            "launches": int(v.size),
        }

    radius = min(body.radii_of_curvature)
    return {
        "preferred_sense": prefer,
        "bad_sense": "ccw" if prefer == "cw" else "cw",
        "robust": result.robust,
        "first_reversal_time_mu_low": stats(launches.mu[0]),
        "first_reversal_time_mu_high": stats(launches.mu[1]),
        "bad_sense_reversed_fraction": float(result.best.bad_reversed),
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
    a: float,
    b: float,
    c: float,
    *,
    coin: str | Coin | None = None,
    coin_mass: float | None = None,
    coin_diameter: float | None = None,
    coin_thickness: float | None = None,
    coins: int = 2,
    infill: float = 0.2,
    material: str | Material = "pla",
    density: float | None = None,
    wall: float = 1.2e-3,
    clearance: float = 0.4e-3,
    rim: float = 2.0e-3,
    mu: tuple[float, float] = (0.2, 0.5),
    margin: float = 0.1,
    prefer: str = "cw",
    launches: Launches | None = None,
    grid: tuple[int, int] = (10, 6),
    refine: int = 2,
    out: str | Path | None = None,
    overwrite: bool = False,
    reversal_map: bool = True,
    progress: Progress | None = None,
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
        A coin by its numbers (kg, m), all three; or any of them overriding the figure of
        the preset ``coin`` (default ``"eur_1"``).
    coins : int
        Number of coins: 2 (a pair symmetric about the centre).
    infill : float
        Infill fraction of the print's core, in (0, 1].
    material : str or Material
        ``"pla"`` (default), ``"petg"``, ``"abs"`` or a :class:`Material`; with
        ``density``, any name.
    density : float, optional
        Density of the material (kg/m³), overriding the preset's.
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
        and ``.pdf``, ``design.toml``, ``sweep.toml``, ``search.nc``,
        ``reversal_map.png`` and ``.nc``. It must be new or empty unless ``overwrite``;
        the files are written to a temporary directory beside it first, then moved in,
        so a run that fails leaves no half design. A design that is not robust is
        written too, marked NOT ROBUST on the sheet and the map.
    overwrite : bool
        Allow ``out`` to hold files already: the design's files replace theirs
        namesakes, other files stay.
    reversal_map : bool
        Compute the reversal map (written with ``out``).
    progress : callable, optional
        Called with one line at each stage (compiling the kernels on a first run,
        searching, refining, the map, writing files); default: silent.

    Returns
    -------
    Design

    Raises
    ------
    ValueError
        For bad inputs, naming the parameter, the value and the rule, before any
        simulation; :class:`DesignRefused` (a ValueError) when the coins would lift G
        above the margin, with the largest coin mass that would do; ValueError when
        ``out`` holds anything and ``overwrite`` is not given.
    """
    t0 = time.perf_counter()
    say = progress or quiet
    if coins != 2:
        raise ValueError(
            f"coins = {coins!r} is invalid: it must be 2 (a pair symmetric "
            "about the centre)"
        )
    bad_sign(prefer)
    margin = require("margin", margin, "a fraction in [0, 1)", lambda v: 0 <= v < 1)
    mat = _material(material, density)
    settings = PrintSettings(mat, infill, wall, clearance, rim)
    the_coin = make_coin(
        coin, mass=coin_mass, diameter=coin_diameter, thickness=coin_thickness
    )
    if len(mu) != 2:
        raise ValueError(f"mu = {mu!r} is invalid: it must be (low, high)")
    if launches is None:
        launches = Launches(mu=(mu[0], mu[1]))
    elif tuple(mu) != (0.2, 0.5) and tuple(mu) != launches.mu:
        raise ValueError(
            f"mu = {mu!r} differs from launches.mu = {launches.mu!r}: give "
            "the friction range once"
        )
    a, b, c = check_shell(a, b, c, settings)
    part = Part(a, b, c, the_coin, 0.0, 0.0, settings)
    check_coin_fits(a, b, c, part)
    check_margin(part, margin)
    out_dir = None if out is None else Path(out)
    if out_dir is not None:
        from .files import check_out
        from .mesh import trimesh_module

        check_out(out_dir, overwrite)
        trimesh_module()  # now, not after the search: see trimesh_module
    result = search(part, launches, prefer, grid=grid, refine=refine, progress=say)
    body = body_of(result.part, name="printed rattleback")
    prediction = _prediction(result.part, body, result, launches, margin, prefer)
    d = Design(result.part, body, prefer, margin, launches, result, prediction)
    if reversal_map:
        from .maps import reversal_map_data

        say("reversal map: 41 spins x 9 friction values...")
        d.reversal_map = reversal_map_data(body, launches, n_spin=41, n_mu=9)
    if out_dir is not None:
        from .files import write_files

        say(f"writing files into {out_dir}...")
        d.files = write_files(d, out_dir, overwrite)
    d.seconds = time.perf_counter() - t0
    return d
