"""Coins and washers to weigh a printed rattleback down: named presets, each with its
source, and any coin by its numbers.

A coin is a uniform disc (a washer: an annulus) of mass (kg), outer diameter (m),
thickness (m) and, for a washer, inner diameter (m). Reeded edges, relief and rims are
ignored: they change the moments of inertia of a coin by far less than its mass and
position do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["COINS", "DEFAULT_COIN", "Coin", "coin_preset"]


@dataclass(frozen=True)
class Coin:
    """A coin or washer: a uniform disc or annulus.

    Parameters
    ----------
    name : str
        Label.
    mass : float
        Mass (kg).
    diameter : float
        Outer diameter (m).
    thickness : float
        Thickness (m); the depth of its pocket.
    inner_diameter : float
        Diameter of the central hole (m); 0 for a coin.
    source : str
        Where the figures come from.
    """

    name: str
    mass: float
    diameter: float
    thickness: float
    inner_diameter: float = 0.0
    source: str = "given by the user"

    def __post_init__(self) -> None:
        for key in ("mass", "diameter", "thickness"):
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(
                    f"coin {key} must be a finite number > 0 (SI units: kg, m), "
                    f"got {value!r}"
                )
            object.__setattr__(self, key, float(value))
        inner = self.inner_diameter
        if not (
            isinstance(inner, (int, float))
            and math.isfinite(inner)
            and 0 <= inner < self.diameter
        ):
            raise ValueError(
                f"coin inner_diameter must be >= 0 and smaller than the diameter "
                f"{self.diameter!r} m, got {inner!r}"
            )
        object.__setattr__(self, "inner_diameter", float(inner))
        if self.diameter > 0.2 or self.thickness > 0.05 or self.mass > 1.0:
            raise ValueError(
                f"coin mass = {self.mass!r} kg, diameter = {self.diameter!r} m, "
                "thickness = "
                f"{self.thickness!r} m look like other units: a coin is given in kg and m "
                "(at most 1 kg, 0.2 m across and 0.05 m thick)"
            )

    @property
    def density(self) -> float:
        """Mass per volume of the disc (kg/m³)."""
        area = math.pi * (self.diameter**2 - self.inner_diameter**2) / 4.0
        return self.mass / (area * self.thickness)

    def describe(self) -> dict[str, object]:
        """Plain-number description (SI units)."""
        return {
            "name": self.name,
            "mass": self.mass,
            "diameter": self.diameter,
            "thickness": self.thickness,
            "inner_diameter": self.inner_diameter,
            "source": self.source,
        }


_US_MINT = "United States Mint, coin specifications (usmint.gov, 'Coin Specifications')"
_ECB = "European Central Bank, euro coin specifications (ecb.europa.eu, 'Euro coins')"
_ROYAL_MINT = "The Royal Mint, UK coin specifications (royalmint.com, 'Our coins')"
_ISO_7089 = (
    "ISO 7089 (plain washers, normal series, 200 HV) nominal dimensions; mass "
    "computed here for steel of 7850 kg/m^3"
)


def _washer(size: str, d1: float, d2: float, h: float) -> Coin:
    """An ISO 7089 washer from its nominal dimensions (mm), steel of 7850 kg/m³."""
    volume = math.pi * (d2**2 - d1**2) / 4.0 * h * 1e-9
    return Coin(
        f"washer_{size}",
        round(7850.0 * volume, 5),
        d2 * 1e-3,
        h * 1e-3,
        d1 * 1e-3,
        _ISO_7089,
    )


COINS: dict[str, Coin] = {
    c.name: c
    for c in (
        Coin("eur_1", 7.50e-3, 23.25e-3, 2.33e-3, source=_ECB),
        Coin("eur_2", 8.50e-3, 25.75e-3, 2.20e-3, source=_ECB),
        Coin("eur_0.50", 7.80e-3, 24.25e-3, 2.38e-3, source=_ECB),
        Coin("usd_0.25", 5.670e-3, 24.26e-3, 1.75e-3, source=_US_MINT),
        Coin("usd_0.05", 5.000e-3, 21.21e-3, 1.95e-3, source=_US_MINT),
        Coin("usd_0.01", 2.500e-3, 19.05e-3, 1.52e-3, source=_US_MINT),
        Coin("gbp_0.02", 7.12e-3, 25.90e-3, 2.03e-3, source=_ROYAL_MINT),
        Coin("gbp_0.10", 6.50e-3, 24.50e-3, 1.85e-3, source=_ROYAL_MINT),
        _washer("M8", 8.4, 16.0, 1.6),
        _washer("M10", 10.5, 20.0, 2.0),
        _washer("M12", 13.0, 24.0, 2.5),
    )
}
"""Named coins and washers (SI units), each with its source."""

DEFAULT_COIN = "eur_1"
"""The coin used when none is named."""


def coin_preset(name: str) -> Coin:
    """The named coin or washer, the name in any case (``EUR_1``, ``washer_m10``); a
    ValueError lists the names."""
    by_folded = {key.casefold(): coin for key, coin in COINS.items()}
    try:
        return by_folded[str(name).casefold()]
    except KeyError:
        raise ValueError(
            f"coin {name!r} is unknown; choose one of {sorted(COINS)} or give "
            "its mass, diameter and thickness"
        ) from None
