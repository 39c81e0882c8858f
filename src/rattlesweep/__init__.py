"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction."""

from ._version import __version__
from .body import PRESETS, Body
from .batch import run_batch
from .simulate import simulate

__all__ = ["Body", "PRESETS", "run_batch", "simulate", "__version__"]
