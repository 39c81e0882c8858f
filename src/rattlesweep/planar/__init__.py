"""The planar rocking semi-ellipse of docs/model.md, on the rattlesweep engine.

A half-ellipse lamina (semi-axes a along the flat edge, b normal to it) rocks by the angle
θ on a line, with Coulomb friction that sticks or slips under the same switching rules as
the 3-D rattleback. :class:`PlanarBody` holds the body, :func:`simulate_planar` runs one
launch with time series, :func:`run_planar_batch` runs arrays of launches.
"""

from .batch import run_planar_batch
from .body import ContactPoint, PlanarBody
from .simulate import simulate_planar

__all__ = ["ContactPoint", "PlanarBody", "run_planar_batch", "simulate_planar"]
