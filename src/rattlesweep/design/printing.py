"""What is assumed of a print: the material and the slicer settings.

The model of a print (used by :mod:`.mass` and :mod:`.mesh` alike):

- the part is solid material within ``wall`` (m) of every surface: the curved outer
  surface, the flat face and the walls and floors of the pockets (the perimeters and the
  top and bottom solid layers of a slicer, taken as one thickness);
- the rest, the core, is infill: a lattice whose cell is much smaller than the part, so
  it is taken as a uniform material of density ``infill`` × the material's density;
- the core is the semi-ellipsoid with semi-axes (a − wall, b − wall, c − wall) below
  the plane ``wall`` under the flat face, less a cylinder of radius (pocket radius +
  wall) reaching ``wall`` below each pocket's floor. Along the axes the outer wall is
  then ``wall`` thick; in between it is somewhat thinner (the gap between two scaled
  ellipsoids is at most the difference of their semi-axes), as a slicer's perimeters
  are not;
- glue, the elephant's foot of the first layer and seams are ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

__all__ = [
    "MATERIALS",
    "Material",
    "PrintSettings",
    "material_preset",
    "millimetres_hint",
    "require",
]


@dataclass(frozen=True)
class Material:
    """A printing material: name, density (kg/m³) and the source of the density."""

    name: str
    density: float
    source: str


MATERIALS: dict[str, Material] = {
    m.name: m
    for m in (
        Material(
            "pla",
            1240.0,
            "NatureWorks Ingeo 4043D technical data sheet: specific gravity 1.24",
        ),
        Material(
            "petg",
            1270.0,
            "Eastman Eastar copolyester 6763 data sheet: specific gravity 1.27",
        ),
        Material(
            "abs", 1040.0, "typical ABS, e.g. INEOS Terluran GP-22 data sheet: 1040 kg/m^3"
        ),
    )
}
"""Named printing materials with their densities and sources."""


def material_preset(name: str) -> Material:
    """The named material; a ValueError lists the names."""
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(
            f"material {name!r} is unknown; choose one of {sorted(MATERIALS)} "
            "or give its density (--density KG_M3; from Python, "
            "density=...)"
        ) from None


def require(
    name: str,
    value: object,
    rule: str,
    test: Callable[[float], bool],
    hint: Callable[[float], str | None] | None = None,
) -> float:
    """``value`` as a float when it is a finite number passing ``test``; otherwise a
    ValueError naming the parameter, the value and the rule, and what ``hint`` says of
    the value (a likely mistake of units) when it says something."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not math.isfinite(v) or not test(v):
        extra = hint(v) if hint is not None and math.isfinite(v) else None
        raise ValueError(
            f"{name} = {value!r} is invalid: it must be {rule}"
            + (f"; {extra}" if extra else "")
        )
    return v


MIN_PRINTED = 1e-4
"""m: the smallest size a printed part or its fit can have (a tenth of a millimetre)."""


def millimetres_hint(test: Callable[[float], bool]) -> Callable[[float], str | None]:
    """A hint for :func:`require`: the value looks like millimetres when a thousandth of
    it passes ``test`` and is a size a print can have (0.1 mm or more: 0.05 given for a
    wall is 50 mm too thick, not 0.05 mm)."""

    def hint(v: float) -> str | None:
        if v > 0 and v * 1e-3 >= MIN_PRINTED and test(v * 1e-3):
            return f"{v:g} looks like millimetres: give metres, e.g. {v * 1e-3:g}"
        return None

    return hint


def _percent_hint(v: float) -> str | None:
    if 1 < v <= 100:
        return f"it is a fraction: {v:g} % is {v / 100:g}"
    return None


@dataclass(frozen=True)
class PrintSettings:
    """The print assumed (SI units).

    Parameters
    ----------
    material : Material
        The filament and its density.
    infill : float
        Infill fraction of the core, in (0, 1] (1: solid).
    wall : float
        Thickness of the solid wall along every surface (m). Default 1.2 mm: three
        perimeters of a 0.4 mm nozzle.
    clearance : float
        Pocket diameter minus coin diameter (m). Default 0.4 mm.
    rim : float
        Least material left between a pocket and the edge of the flat face, and between
        the two pockets (m). Default 2 mm.
    """

    material: Material = MATERIALS["pla"]
    infill: float = 0.2
    wall: float = 1.2e-3
    clearance: float = 0.4e-3
    rim: float = 2.0e-3

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "infill",
            require(
                "infill",
                self.infill,
                "a fraction in (0, 1]",
                lambda v: 0 < v <= 1,
                _percent_hint,
            ),
        )
        for name, top in (("wall", 0.02), ("clearance", 0.005), ("rim", 0.05)):
            low = "> 0" if name == "wall" else ">= 0"

            def test(v: float, low: str = low, top: float = top) -> bool:
                return (v > 0 if low == "> 0" else v >= 0) and v <= top

            value = require(
                name,
                getattr(self, name),
                f"{low} and at most {top} m (SI units: m)",
                test,
                millimetres_hint(test),
            )
            object.__setattr__(self, name, value)
        require(
            "material density",
            self.material.density,
            "a finite number > 0 (kg/m^3)",
            lambda v: v > 0,
        )

    def describe(self) -> dict[str, object]:
        """Plain-number description (SI units)."""
        return {
            "material": self.material.name,
            "density": self.material.density,
            "density_source": self.material.source,
            "infill": self.infill,
            "wall": self.wall,
            "clearance": self.clearance,
            "rim": self.rim,
        }
