"""Printable rattlebacks: a semi-ellipsoid shell printed flat face down with two coins in
pockets in its flat face, placed where simulation says the body reverses quickly in one
sense and spins on in the other.

:func:`design` does it all; the modules hold one job each: :mod:`.coins` (coin and
washer presets with sources), :mod:`.printing` (materials and print settings),
:mod:`.mass` (the mass model of a print), :mod:`.constraints` (what a design must
satisfy), :mod:`.search` (the placement search), :mod:`.mesh` (meshes and the STL),
:mod:`.sheet` (the 1:1 placement sheet), :mod:`.maps` (the reversal map) and
:mod:`.record` / :mod:`.files` (``design.toml`` and the other files). The meshes need
the ``design`` extra (trimesh and manifold3d).
"""

from __future__ import annotations

from .api import Design, design, make_coin
from .coins import COINS, DEFAULT_COIN, Coin
from .constraints import DesignRefused
from .mass import Part, body_of
from .printing import MATERIALS, Material, PrintSettings
from .record import load_body
from .search import Launches

__all__ = [
    "COINS",
    "DEFAULT_COIN",
    "Coin",
    "Design",
    "DesignRefused",
    "Launches",
    "MATERIALS",
    "Material",
    "Part",
    "PrintSettings",
    "body_of",
    "design",
    "load_body",
    "make_coin",
]
