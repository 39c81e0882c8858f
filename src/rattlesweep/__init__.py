"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction."""

from ._version import __version__
from .body import PRESETS, Body
from .batch import run_batch
from .simulate import simulate
from . import planar
from .planar import PlanarBody, run_planar_batch, simulate_planar
from . import stability, sweep
from .sweep import Sweep, resume, run_sweep

__all__ = ["Body", "PRESETS", "PlanarBody", "Sweep", "planar", "resume", "run_batch",
           "run_planar_batch", "run_sweep", "stability", "sweep",
           "simulate", "simulate_planar", "__version__"]
