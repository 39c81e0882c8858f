"""Parameter sweeps: specification, tiled execution on threads or dask, resumable netCDF
or zarr output.

Everything a user reaches is named here: :class:`Sweep`, :func:`run_sweep`,
:func:`resume`, the outcome classification (:func:`classify`, :data:`OUTCOME_NAMES`,
:func:`at_first_reversal`), a refined map's check against the full grid
(:func:`compare_with_full`), a sweep's cost before it runs (:func:`estimate`,
:class:`Estimate`) and the demo's configuration
(:data:`DEMO_TOML`). The private subpackages hold, by what they hold: ``_config`` (the
specification, its parameters, grid, checks, TOML and body files), ``_execution``
(running a sweep's tiles on threads or a cluster, progress, estimates and the output's
lock), ``_outputs`` (where the tiles go, merging, verifying, outcomes) and
``_refinement`` (the adaptive refinement of a sweep's grid).

:func:`run_sweep`, :func:`resume`, :func:`estimate` and :func:`compare_with_full` are
imported on first use, so making or reading a :class:`Sweep` does not import dask or
netCDF4.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._config.demo import DEMO_TOML
from ._config.spec import Sweep
from ._outputs.outcomes import OUTCOME_NAMES, at_first_reversal, classify

__all__ = [
    "DEMO_TOML",
    "Estimate",
    "OUTCOME_NAMES",
    "Sweep",
    "at_first_reversal",
    "classify",
    "compare_with_full",
    "estimate",
    "resume",
    "run_sweep",
]

_FROM = {
    "resume": "._execution.run",
    "run_sweep": "._execution.run",
    "compare_with_full": "._outputs.compare",
    "estimate": "._execution.estimate",
    "Estimate": "._execution.estimate",
}
"""Names imported on first use, and their modules."""

_MODULES = {"compare": "._outputs.compare"}
"""A module reached as an attribute of ``rattlesweep.sweep``: the path of
:func:`compare_with_full` before the subpackages."""

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from ._execution.estimate import Estimate, estimate
    from ._execution.run import resume, run_sweep
    from ._outputs.compare import compare_with_full
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _FROM:
            value = getattr(importlib.import_module(_FROM[name], __name__), name)
        elif name in _MODULES:
            value = importlib.import_module(_MODULES[name], __name__)
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
