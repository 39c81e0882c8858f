"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction."""

from ._version import __version__
from .body import PRESETS, Body
from .batch import run_batch
from .simulate import simulate
from . import planar
from .planar import PlanarBody, run_planar_batch, simulate_planar

__all__ = ["Body", "PRESETS", "PlanarBody", "planar", "run_batch", "run_planar_batch",
           "simulate", "simulate_planar", "__version__"]
