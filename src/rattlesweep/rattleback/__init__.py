"""The rattleback (3-D model) of docs/model.md, on the rattlesweep engine.

A rigid body with an ellipsoidal bottom rolls, slides and spins on a flat floor, with
Coulomb friction that sticks or slips. :class:`Body` holds the body, :func:`simulate`
runs one launch with time series, :func:`run_batch` runs arrays of launches;
:mod:`~rattlesweep.rattleback.launch` holds the launch conventions and
:mod:`~rattlesweep.rattleback.contact` the contact kinematics of a recorded run.
"""

from .batch import run_batch
from .body import PRESETS, Body
from .launch import UnitsWarning
from .simulate import simulate

__all__ = ["Body", "PRESETS", "UnitsWarning", "run_batch", "simulate"]
