"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction.

The sweep machinery (:mod:`rattlesweep.sweep`, :class:`Sweep`, :func:`run_sweep`,
:func:`resume`) is imported on first use: it brings in dask and netCDF4, which a
simulation does not need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__
from .body import PRESETS, Body
from .batch import run_batch
from .simulate import simulate
from .launch import UnitsWarning
from .tidy import decode, to_csv, to_table, unstack
from . import planar
from .planar import PlanarBody, run_planar_batch, simulate_planar
from . import stability

__all__ = ["Body", "PRESETS", "PlanarBody", "Sweep", "planar", "resume", "run_batch",
           "run_planar_batch", "run_sweep", "stability", "sweep", "UnitsWarning",
           "decode", "to_csv", "to_table", "unstack",
           "simulate", "simulate_planar", "__version__"]

_FROM_SWEEP = ("Sweep", "resume", "run_sweep")

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from . import sweep
    from .sweep import Sweep
    from .sweep.run import resume, run_sweep
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name == "sweep":
            return importlib.import_module(".sweep", __name__)
        if name in _FROM_SWEEP:
            value = getattr(importlib.import_module(".sweep", __name__), name)
            globals()[name] = value
            return value
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
