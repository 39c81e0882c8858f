"""Fitting a measured rattleback: its friction, damping and launch, with intervals.

:func:`fit` takes a measurement (a Tracker video export, a phyphox gyroscope export, a
CSV or a netCDF file: :func:`read_measurement`) and the inputs to free with their
bounds, searches them with batches of thousands of candidate runs, and reports each
fitted input with its 95 % interval, saying plainly what the data cannot pin down.
:func:`write_fit` writes ``fit.toml`` (loads as a body and fixed inputs), ``fit.nc`` and
``fit.png``. :func:`compare_models` ranks rolling contact, Coulomb friction and
Coulomb with spin friction on the same data.
"""

from .api import FitResult, Fitted, fit
from .files import write_fit
from .measurement import Measurement, read_measurement
from .models import ModelComparison, ModelScore, compare_models

__all__ = [
    "FitResult",
    "Fitted",
    "Measurement",
    "ModelComparison",
    "ModelScore",
    "compare_models",
    "fit",
    "read_measurement",
    "write_fit",
]
