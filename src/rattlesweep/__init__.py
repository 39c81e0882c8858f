"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction.

The sweep machinery (:mod:`rattlesweep.sweep`, :class:`Sweep`, :func:`run_sweep`,
:func:`resume` and its errors), the pictures (:mod:`rattlesweep.plot`) and the printable
designs (:mod:`rattlesweep.design`) are imported on first use: they bring in dask,
netCDF4 or matplotlib, which a simulation does not need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__
from ._steps import CoarseStepWarning, LongRunWarning
from .rattleback import PRESETS, Body, UnitsWarning, run_batch, simulate
from .tidy import decode, to_csv, to_table, unstack
from . import planar
from .planar import PlanarBody, run_planar_batch, simulate_planar
from . import stability

__all__ = ["Body", "CoarseStepWarning", "DesignRefused", "LongRunWarning", "PRESETS",
           "PlanarBody", "Sweep", "SweepLocked", "SweepWriteError", "UnitsWarning",
           "decode", "design", "planar", "plot", "resume", "run_batch", "run_planar_batch",
           "run_sweep", "simulate", "simulate_planar", "stability", "sweep", "to_csv",
           "to_table", "unstack", "__version__"]

_LAZY_MODULES = ("design", "plot", "sweep")
"""Subpackages imported on first use as attributes (``rs.plot``)."""

_LAZY_NAMES = {"Sweep": ".sweep", "resume": ".sweep.run", "run_sweep": ".sweep.run",
               "SweepWriteError": ".sweep.store", "SweepLocked": ".sweep.lock",
               "DesignRefused": ".design.constraints"}
"""Names imported on first use, and the module each comes from."""

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from . import design, plot, sweep
    from .design.constraints import DesignRefused
    from .sweep import Sweep
    from .sweep.lock import SweepLocked
    from .sweep.run import resume, run_sweep
    from .sweep.store import SweepWriteError
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _LAZY_MODULES:
            return importlib.import_module(f".{name}", __name__)
        if name in _LAZY_NAMES:
            value = getattr(importlib.import_module(_LAZY_NAMES[name], __name__), name)
            globals()[name] = value
            return value
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
