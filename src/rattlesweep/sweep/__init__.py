"""Parameter sweeps: specification, tiled execution on threads or dask, resumable netCDF
or zarr output.

The subpackages hold, by what they hold:

* :mod:`~rattlesweep.sweep.config`: the :class:`Sweep` specification, its parameters,
  grid, checks, TOML and body files;
* :mod:`~rattlesweep.sweep.execution`: running a sweep's tiles on threads or a cluster,
  progress, estimates and the output's lock;
* :mod:`~rattlesweep.sweep.outputs`: where the tiles go (a netCDF directory or a zarr
  store), merging, verifying, and the outcome classification results carry;
* :mod:`~rattlesweep.sweep.refinement`: the adaptive refinement of a sweep's grid.

:func:`run_sweep` and :func:`resume` are imported on first use, so making or reading a
:class:`Sweep` does not import dask or netCDF4.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .config.spec import Sweep
from .outputs.outcomes import OUTCOME_NAMES, classify

__all__ = ["OUTCOME_NAMES", "Sweep", "classify", "resume", "run_sweep"]

_FROM_RUN = ("resume", "run_sweep")

_MODULES = {"compare": ".outputs.compare", "estimate": ".execution.estimate"}
"""Modules the API reference named directly under ``rattlesweep.sweep`` before the
subpackages, reached there as attributes still (``rattlesweep.sweep.estimate.estimate``)."""

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from .execution.run import resume, run_sweep
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _FROM_RUN:
            value = getattr(importlib.import_module(".execution.run", __name__), name)
        elif name in _MODULES:
            value = importlib.import_module(_MODULES[name], __name__)
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
