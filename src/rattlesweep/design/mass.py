"""The mass model of a printed rattleback with coins: its parts, their moments, the Body.

The printed part is described by :class:`Part` (the printing assumptions are in
:mod:`.printing`): a semi-ellipsoid with semi-axes a, b, c (m) whose flat face is the
plane z = 0 of the body frame (docs/model.md: z up out of the flat face, the curved surface
below), with two cylindrical pockets in the flat face at (x, y) and (−x, −y), each as
deep as a coin is thick, and a coin in each, its top flush with the face.

Its mass distribution is a signed sum of simple solids (:func:`solids`), each with a
density: the outer semi-ellipsoid at the material's density, the pockets removed, the
infill core removed at (1 − infill) of the density, the solid walls around the pockets
given back to the core, and the coins. The moments of each solid are closed forms
(:func:`segment_moments`, :func:`cylinder_moments`); :mod:`.mesh` builds the same solids
as triangle meshes, which is how the two are checked against each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial

from ..rattleback.body import Body
from .coins import Coin
from .printing import PrintSettings

__all__ = [
    "Moments",
    "Part",
    "Solid",
    "body_of",
    "cylinder_moments",
    "moments_of",
    "segment_moments",
    "solids",
]


@dataclass(frozen=True)
class Moments:
    """Mass (kg), first moment ∫r dm (kg m) and second moment tensor ∫r rᵀ dm (kg m²)
    about the body origin C. Moments of parts add."""

    mass: float
    first: np.ndarray
    second: np.ndarray

    def __add__(self, other: "Moments") -> "Moments":
        return Moments(
            self.mass + other.mass, self.first + other.first, self.second + other.second
        )

    def scaled(self, k: float) -> "Moments":
        """These moments for a density ``k`` times as large."""
        return Moments(k * self.mass, k * self.first, k * self.second)

    @property
    def com(self) -> np.ndarray:
        """Centre of mass (m)."""
        return self.first / self.mass

    @property
    def inertia(self) -> np.ndarray:
        """Inertia tensor about the centre of mass (kg m²), I = ∫(|r|²𝟙 − r rᵀ) dm."""
        g = self.com
        s = self.second - self.mass * np.outer(g, g)
        return np.trace(s) * np.eye(3) - s


ZERO = Moments(0.0, np.zeros(3), np.zeros((3, 3)))


def segment_moments(a: float, b: float, c: float, z_low: float, z_high: float) -> Moments:
    """Unit-density moments of the slice z_low ≤ z ≤ z_high (m) of the solid ellipsoid
    x²/a² + y²/b² + z²/c² ≤ 1 centred at the origin (−c ≤ z_low < z_high ≤ c)."""
    s2 = Polynomial([1.0, 0.0, -1.0 / c**2])  # (cross-section semi-axes / (a, b))²
    z = Polynomial([0.0, 1.0])

    def integral(p: Polynomial) -> float:
        q = p.integ()
        return float(q(z_high) - q(z_low))

    area = math.pi * a * b
    volume = area * integral(s2)
    first = np.array([0.0, 0.0, area * integral(z * s2)])
    s4 = integral(s2 * s2)
    second = np.diag(
        [
            math.pi * a**3 * b * s4 / 4.0,
            math.pi * a * b**3 * s4 / 4.0,
            area * integral(z * z * s2),
        ]
    )
    return Moments(volume, first, second)


def cylinder_moments(
    radius: float,
    z_low: float,
    z_high: float,
    x: float = 0.0,
    y: float = 0.0,
    inner_radius: float = 0.0,
) -> Moments:
    """Unit-density moments of an upright cylinder (annulus with ``inner_radius`` > 0)
    centred on (x, y), from z_low to z_high (m)."""
    h = z_high - z_low
    r2 = radius**2 + inner_radius**2
    volume = math.pi * (radius**2 - inner_radius**2) * h
    p = np.array([x, y, 0.5 * (z_low + z_high)])
    local = volume * np.diag([r2 / 4.0, r2 / 4.0, h * h / 12.0])
    return Moments(volume, volume * p, local + volume * np.outer(p, p))


@dataclass(frozen=True)
class Part:
    """A printed shell with a coin pair: the semi-axes (m), the coin, the placement of
    the first pocket's centre (x, y) (m; the second is at (−x, −y)), the print."""

    a: float
    b: float
    c: float
    coin: Coin
    x: float
    y: float
    settings: PrintSettings

    @property
    def pocket_radius(self) -> float:
        """Radius of a pocket (m): half the coin's diameter plus the clearance."""
        return 0.5 * (self.coin.diameter + self.settings.clearance)

    @property
    def pockets(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Centres (x, y) of the two pockets (m)."""
        return (self.x, self.y), (-self.x, -self.y)

    def mirrored(self) -> "Part":
        """The mirror image (y → −y): the opposite preferred sense."""
        return Part(self.a, self.b, self.c, self.coin, self.x, -self.y, self.settings)

    def at(self, x: float, y: float) -> "Part":
        """The same part with the first pocket at (x, y) (m)."""
        return Part(self.a, self.b, self.c, self.coin, x, y, self.settings)


@dataclass(frozen=True)
class Solid:
    """One signed piece of the mass model: ``kind`` "segment" (ellipsoid slice with
    semi-axes ``size`` = (a, b, c)) or "cylinder" (``size`` = (radius, inner radius,
    0) centred on ``centre`` = (x, y)), from ``z_low`` to ``z_high`` (m), of density
    ``density`` (kg/m³, negative where material is removed), in group ``group``
    ("print", "core" or "coins")."""

    kind: str
    size: tuple[float, float, float]
    z_low: float
    z_high: float
    density: float
    group: str
    centre: tuple[float, float] = (0.0, 0.0)

    def moments(self) -> Moments:
        """Moments of this solid at its density."""
        if self.kind == "segment":
            m = segment_moments(*self.size, self.z_low, self.z_high)
        else:
            m = cylinder_moments(
                self.size[0],
                self.z_low,
                self.z_high,
                *self.centre,
                inner_radius=self.size[1],
            )
        return m.scaled(self.density)


def solids(part: Part, *, coins: bool = True) -> list[Solid]:
    """The signed solids whose sum is the part's mass distribution (with the coins
    unless ``coins`` is False)."""
    s = part.settings
    rho, w, t = s.material.density, s.wall, part.coin.thickness
    rp = part.pocket_radius
    out = [Solid("segment", (part.a, part.b, part.c), -part.c, 0.0, rho, "print")]
    out += [
        Solid("cylinder", (rp, 0.0, 0.0), -t, 0.0, -rho, "print", p) for p in part.pockets
    ]
    void = -(1.0 - s.infill) * rho
    if void != 0.0:
        out.append(
            Solid(
                "segment",
                (part.a - w, part.b - w, part.c - w),
                -(part.c - w),
                -w,
                void,
                "core",
            )
        )
        out += [
            Solid("cylinder", (rp + w, 0.0, 0.0), -(t + w), -w, -void, "core", p)
            for p in part.pockets
        ]
    if coins:
        coin = part.coin
        out += [
            Solid(
                "cylinder",
                (coin.diameter / 2, coin.inner_diameter / 2, 0.0),
                -t,
                0.0,
                coin.density,
                "coins",
                p,
            )
            for p in part.pockets
        ]
    return out


def moments_of(part: Part, *, coins: bool = True) -> Moments:
    """The part's moments about C (with the coins unless ``coins`` is False)."""
    total = ZERO
    for solid in solids(part, coins=coins):
        total = total + solid.moments()
    return total


def body_of(part: Part, name: str = "printed") -> Body:
    """The rigid :class:`~rattlesweep.Body` of the printed part with its coins."""
    m = moments_of(part)
    return Body(part.a, part.b, part.c, m.mass, m.com, m.inertia, name=name)
