"""Parameter sweeps: specification, tiled execution on threads or dask, resumable netCDF
or zarr output.

:func:`run_sweep` and :func:`resume` are imported on first use, so making or reading a
:class:`Sweep` does not import dask or netCDF4.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .outcomes import OUTCOME_NAMES, classify
from .spec import Sweep

__all__ = ["OUTCOME_NAMES", "Sweep", "classify", "resume", "run_sweep"]

_FROM_RUN = ("resume", "run_sweep")

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from .run import resume, run_sweep
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _FROM_RUN:
            value = getattr(importlib.import_module(".run", __name__), name)
            globals()[name] = value
            return value
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
