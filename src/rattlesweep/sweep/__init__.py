"""Parameter sweeps: specification, tiled execution on dask, resumable netCDF output."""

from .spec import Sweep
from .outcomes import OUTCOME_NAMES, classify
from .run import resume, run_sweep

__all__ = ["OUTCOME_NAMES", "Sweep", "classify", "resume", "run_sweep"]
