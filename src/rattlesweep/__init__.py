"""rattlesweep: fast batch simulation of rattlebacks with Coulomb stick/slip friction.

Every name below is imported on first use, so that ``import rattlesweep`` (and the
``rattlesweep`` command's start, which must answer Ctrl-C from its first instant) loads
none of numpy, numba or xarray; the sweep machinery (:mod:`rattlesweep.sweep`,
:class:`Sweep`, :func:`run_sweep`, :func:`resume`) brings in dask and netCDF4 too.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

from ._version import __version__

# the names and modules the API reference documents (docs/api.rst), and the planar
# model's module, which its guide imports from
__all__ = [
    "Body",
    "CoarseStepWarning",
    "DesignRefused",
    "LongRunWarning",
    "PRESETS",
    "PlanarBody",
    "Sweep",
    "SweepLocked",
    "SweepWriteError",
    "UnitsWarning",
    "compile_kernels",
    "decode",
    "design",
    "explore",
    "fit",
    "fitting",
    "inputs",
    "kernel_cache",
    "planar",
    "plot",
    "poincare_section",
    "rattleback",
    "resume",
    "run_batch",
    "run_planar_batch",
    "run_sweep",
    "simulate",
    "simulate_planar",
    "stability",
    "sweep",
    "to_csv",
    "to_table",
    "unstack",
    "__version__",
]

_FROM = {
    "Body": ".rattleback",
    "PRESETS": ".rattleback",
    "run_batch": ".rattleback",
    "simulate": ".rattleback",
    "UnitsWarning": ".rattleback",
    "decode": ".tidy",
    "to_csv": ".tidy",
    "to_table": ".tidy",
    "unstack": ".tidy",
    "PlanarBody": ".planar",
    "run_planar_batch": ".planar",
    "simulate_planar": ".planar",
    "Sweep": ".sweep",
    "resume": ".sweep._execution.run",
    "run_sweep": ".sweep._execution.run",
    "CoarseStepWarning": "._steps",
    "LongRunWarning": "._steps",
    "SweepWriteError": ".sweep._outputs.store",
    "SweepLocked": ".sweep._execution.lock",
    "DesignRefused": ".design.constraints",
    "compile_kernels": ".kernel_cache",
    "fit": ".fitting",
    "poincare_section": ".chaos",
}
"""Each name of the package and the module it comes from."""

if TYPE_CHECKING:
    # what __getattr__ imports on first use, seen by type checkers as it is
    from . import design, explore, fitting, inputs, kernel_cache, planar, plot
    from . import rattleback, stability, sweep
    from .chaos import poincare_section
    from .fitting import fit
    from . import io as io  # documented; out of __all__, not to shadow the stdlib's
    from .design.constraints import DesignRefused
    from .kernel_cache import compile_kernels
    from ._steps import CoarseStepWarning, LongRunWarning
    from .planar import PlanarBody, run_planar_batch, simulate_planar
    from .rattleback import PRESETS, Body, UnitsWarning, run_batch
    from .rattleback.simulate import simulate
    from .sweep import Sweep
    from .sweep._execution.lock import SweepLocked
    from .sweep._execution.run import resume, run_sweep
    from .sweep._outputs.store import SweepWriteError
    from .tidy import decode, to_csv, to_table, unstack
else:
    # hidden from type checkers, which would give any other name its result type
    def __getattr__(name: str) -> Any:
        if name in _FROM:
            value = getattr(importlib.import_module(_FROM[name], __name__), name)
        elif (
            not name.startswith("_")
            and importlib.util.find_spec(f"{__name__}.{name}") is not None
        ):
            value = importlib.import_module(f".{name}", __name__)  # a module: rs.stability
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    """The public names, and the submodules imported so far (``rs.tidy``)."""
    loaded = {
        k
        for k, v in globals().items()
        if not k.startswith("_") and getattr(v, "__name__", "").startswith(f"{__name__}.")
    }
    return sorted(set(__all__) | loaded)
