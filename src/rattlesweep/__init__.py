"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction.

Every name below is imported on first use, so that ``import rattlesweep`` (and the
``rattlesweep`` command's start, which must answer Ctrl-C from its first instant) loads
none of numpy, numba or xarray; the sweep machinery (:mod:`rattlesweep.sweep`,
:class:`Sweep`, :func:`run_sweep`, :func:`resume`) brings in dask and netCDF4 too.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from typing import TYPE_CHECKING, Any

from ._version import __version__

__all__ = ["Body", "CoarseStepWarning", "DesignRefused", "LongRunWarning", "PRESETS",
           "PlanarBody", "Sweep", "SweepLocked", "SweepWriteError", "UnitsWarning",
           "decode", "design", "planar", "plot", "resume", "run_batch", "run_planar_batch",
           "run_sweep", "simulate", "simulate_planar", "stability", "sweep", "to_csv",
           "to_table", "unstack", "__version__"]

_FROM = {"Body": ".body", "PRESETS": ".body", "run_batch": ".batch",
         "simulate": ".simulate", "UnitsWarning": ".launch", "decode": ".tidy",
         "to_csv": ".tidy", "to_table": ".tidy", "unstack": ".tidy",
         "PlanarBody": ".planar", "run_planar_batch": ".planar",
         "simulate_planar": ".planar", "Sweep": ".sweep", "resume": ".sweep.run",
         "run_sweep": ".sweep.run", "CoarseStepWarning": ".engine",
         "LongRunWarning": ".engine", "SweepWriteError": ".sweep.store",
         "SweepLocked": ".sweep.lock", "DesignRefused": ".design.constraints"}
"""Each name of the package and the module it comes from."""

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from . import design, planar, plot, stability, sweep
    from .batch import run_batch
    from .body import PRESETS, Body
    from .design.constraints import DesignRefused
    from .engine import CoarseStepWarning, LongRunWarning
    from .launch import UnitsWarning
    from .planar import PlanarBody, run_planar_batch, simulate_planar
    from .simulate import simulate
    from .sweep import Sweep
    from .sweep.lock import SweepLocked
    from .sweep.run import resume, run_sweep
    from .sweep.store import SweepWriteError
    from .tidy import decode, to_csv, to_table, unstack
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _FROM:
            value = getattr(importlib.import_module(_FROM[name], __name__), name)
        elif not name.startswith("_") and importlib.util.find_spec(
                f"{__name__}.{name}") is not None:
            value = importlib.import_module(f".{name}", __name__)  # a module: rs.engine
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """The package's module: ``rattlesweep.simulate`` stays the function when its module
    of the same name is imported (the import system binds every submodule to its name
    in the package, which the function must keep)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _FUNCTION_MODULES and isinstance(value, types.ModuleType):
            value = getattr(value, name)
        super().__setattr__(name, value)


_FUNCTION_MODULES = ("simulate",)
"""Names of the package that are functions of the submodule of the same name."""

sys.modules[__name__].__class__ = _Package
