"""What a design must satisfy, checked before any simulation.

- The shell: semi-axes finite and > 0 (SI: m), the empty print (no pockets, no coins)
  stable upright (its centre of mass below both centres of curvature, docs/model.md: the
  body), and deep enough for a pocket with a wall below it.
- The coin: its pocket, with a rim on each side, no wider than the flat face.
- A placement: each pocket inside the flat face with ``rim`` left to the edge, its solid
  surround (pocket radius + wall, down to wall below its floor) inside the infill core
  of the mass model, and the two pockets ``max(rim, 2 wall)`` apart.
- The margin: G of the loaded part at most (1 − margin) of the smaller radius of
  curvature at the bottom, min(a²/c, b²/c), above the contact point. Coins at the flat
  face raise G whatever their (x, y), so this does not depend on the placement; a design
  that fails it is refused (:class:`DesignRefused`) with the largest coin mass that
  would pass.
"""

from __future__ import annotations

import math

import numpy as np

from .mass import Part, moments_of, segment_moments
from .printing import PrintSettings, millimetres_hint, require

__all__ = [
    "DesignRefused",
    "check_coin_fits",
    "check_margin",
    "check_shell",
    "max_coin_mass",
    "placement_problem",
]

_CIRCLE = np.linspace(0.0, 2.0 * math.pi, 721)[:-1]


class DesignRefused(ValueError):
    """A design that cannot meet the stability margin; ``max_coin_mass`` (kg) is the
    largest mass of the same coin (size unchanged) that would, 0 when none would."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so

    def __init__(self, message: str, max_coin_mass: float) -> None:
        super().__init__(message)
        self.max_coin_mass = max_coin_mass

    def __reduce__(self) -> tuple[type[DesignRefused], tuple[str, float]]:
        # the arguments __init__ takes (BaseException's reduce would give the message only)
        return type(self), (str(self), self.max_coin_mass)


def check_shell(
    a: object, b: object, c: object, settings: PrintSettings
) -> tuple[float, float, float]:
    """The semi-axes (m) as floats, after checking them and the stability of the empty
    print; ValueError naming the parameter otherwise."""

    def length(x: float) -> bool:
        return 0 < x <= 1.0

    axes = tuple(
        require(
            k,
            v,
            "a finite length > 0 and at most 1 m (SI units: m)",
            length,
            millimetres_hint(length),
        )
        for k, v in (("a", a), ("b", b), ("c", c))
    )
    a_, b_, c_ = axes
    w = settings.wall
    if min(axes) <= 3 * w:
        name, least = min(zip("abc", axes), key=lambda kv: kv[1])
        raise ValueError(
            f"wall = {w:g} m is too thick for this shell: three walls ({3 * w:g} m) must "
            f"fit in each semi-axis to leave an infill core, and {name} = {least:g} m; "
            "give a thinner --wall (a slicer's 2 to 4 perimeters: 0.0008 to 0.0016 m) or a "
            "larger shell"
        )
    rho, void = (
        settings.material.density,
        (1.0 - settings.infill) * settings.material.density,
    )
    m = segment_moments(a_, b_, c_, -c_, 0.0).scaled(rho) + segment_moments(
        a_ - w, b_ - w, c_ - w, -(c_ - w), -w
    ).scaled(-void)
    ell = c_ + float(m.com[2])
    radius = min(a_**2 / c_, b_**2 / c_)
    if radius <= ell:
        which = "a**2/c" if a_ < b_ else "b**2/c"
        raise ValueError(
            f"shell a = {a_!r}, b = {b_!r}, c = {c_!r} m cannot rock stably: the empty "
            f"print's centre of mass is {ell * 1e3:.3g} mm above the contact point, above "
            f"the centre of curvature at the bottom ({which} = {radius * 1e3:.3g} mm); "
            "the rule is min(a**2/c, b**2/c) > height of G, so make c smaller or b larger"
        )
    return a_, b_, c_


def check_coin_fits(a: float, b: float, c: float, part: Part) -> None:
    """ValueError when the coin's pocket cannot fit the flat face or the shell's depth."""
    s = part.settings
    width = 2 * part.pocket_radius + 2 * s.rim
    if width > 2 * min(a, b):
        raise ValueError(
            f"coin diameter = {part.coin.diameter!r} m is too wide for the flat face: the "
            f"pocket ({2 * part.pocket_radius * 1e3:.4g} mm with the clearance) plus a rim "
            f"of {s.rim * 1e3:g} mm on each side must be at most the face's width 2b = "
            f"{2 * min(a, b) * 1e3:.4g} mm"
        )
    depth = part.coin.thickness + 2 * s.wall
    if depth >= c:
        raise ValueError(
            f"coin thickness = {part.coin.thickness!r} m is too thick for the shell: the "
            f"pocket plus a wall below it and a core ({depth * 1e3:.3g} mm) must be less "
            f"than c = {c * 1e3:.4g} mm"
        )


def _circle_inside(x: float, y: float, r: float, a: float, b: float) -> bool:
    px, py = x + r * np.cos(_CIRCLE), y + r * np.sin(_CIRCLE)
    return bool(np.all((px / a) ** 2 + (py / b) ** 2 <= 1.0))


def placement_problem(part: Part) -> str | None:
    """Why the part's pockets are placed where they cannot be, or None when they can."""
    s, rp = part.settings, part.pocket_radius
    x, y = part.x, part.y
    if not _circle_inside(x, y, rp + s.rim, part.a, part.b):
        return (
            f"pocket closer than the rim ({s.rim * 1e3:g} mm) to the edge of the flat face"
        )
    w, depth = s.wall, part.coin.thickness + s.wall
    shrink = 1.0 - (depth / (part.c - w)) ** 2
    if shrink <= 0 or not _circle_inside(
        x, y, rp + w, (part.a - w) * math.sqrt(shrink), (part.b - w) * math.sqrt(shrink)
    ):
        return "pocket floor too close to the curved surface (less than a wall under it)"
    gap = 2.0 * math.hypot(x, y) - 2.0 * rp
    if gap < max(s.rim, 2 * w):
        return f"pockets {gap * 1e3:.3g} mm apart, less than {max(s.rim, 2 * w) * 1e3:g} mm"
    return None


def _height_limit(part: Part, margin: float) -> float:
    """The highest G may sit above the contact point (m)."""
    return (1.0 - margin) * min(part.a**2 / part.c, part.b**2 / part.c)


def max_coin_mass(part: Part, margin: float) -> float:
    """The largest mass (kg) of the part's coin (same size) that keeps G within the
    margin; 0 when even the part without coins does not."""
    shell = moments_of(part, coins=False)
    z_max = _height_limit(part, margin) - part.c  # highest allowed G_z
    z_coin = -0.5 * part.coin.thickness
    # G_z = (M z_s + 2 m z_coin) / (M + 2 m) = z_max, solved for m
    gap = z_coin - z_max
    if gap <= 0:
        return math.inf
    return max(0.0, shell.mass * (z_max - float(shell.com[2])) / (2.0 * gap))


def check_margin(part: Part, margin: float) -> None:
    """:class:`DesignRefused` unless G of the loaded part is within the margin."""
    limit = _height_limit(part, margin)
    ell = part.c + float(moments_of(part).com[2])
    if ell <= limit:
        return
    m_max = max_coin_mass(part, margin)
    radius = min(part.a**2 / part.c, part.b**2 / part.c)
    advice = (
        f"the largest coin mass that would do, at this coin's size, is "
        f"{m_max * 1e3:.3g} g per coin"
        if m_max > 0
        else "no coin of this size would do: make the shell lower (c) or wider (b)"
    )
    raise DesignRefused(
        f"design refused: with two coins of {part.coin.mass * 1e3:.3g} g "
        f"({part.coin.name}) "
        f"the centre of mass is {ell * 1e3:.3g} mm above the contact point, but the "
        f"stability margin of {margin:.0%} needs it at most {limit * 1e3:.3g} mm "
        f"((1 - margin) x the smaller radius of curvature, {radius * 1e3:.3g} mm); "
        f"{advice}",
        m_max,
    )
