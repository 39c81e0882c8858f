"""One planar launch, with its time series: :func:`simulate_planar`."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._options import check_method, check_record_every
from .._run import execute
from .._keywords import check_keywords, document
from ..inputs import PLANAR as INPUTS
from .batch import ACCEPTED, prepare, run_attrs
from .body import PlanarBody
from .metadata import attrs_for

__all__ = ["simulate_planar"]


@document(INPUTS, scalar=True)
def simulate_planar(
    body: PlanarBody,
    *,
    method: str = INPUTS["method"].default,
    record_every: int | None = None,
    **inputs: ArrayLike | None,
) -> xr.Dataset:
    """Simulate one launch of a rocking semi-ellipse and return its time series.

    The inputs are those of :func:`run_planar_batch`, as scalars. ``record_every``
    defaults to the smallest stride that keeps at most 10 000 samples.

    Parameters
    ----------
    body : PlanarBody
        The body.
    {inputs}

    Returns
    -------
    xarray.Dataset
        Over ``time`` (s): ``angle`` (rad), ``rate`` (rad/s), ``x_G``, ``y_G`` (m),
        ``velocity_x``, ``velocity_y`` (m/s, of G), ``slip_velocity`` and ``slip_speed``
        (m/s, of the material contact point), ``normal_force`` and ``friction_force``
        (N), ``energy`` (J), ``slipping`` (0/1); the per-run observables of
        :func:`run_planar_batch` as scalar variables; every input as an attribute (units
        in ``<name>_units``).

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule.
    TypeError
        For a name that is neither an input nor an option, listing both; for a
        required input not given (``theta``, ``t_end``).

    Warns
    -----
    RuntimeWarning
        When the run ends with a status other than ``ok``.
    """
    if not isinstance(body, PlanarBody):
        raise ValueError(f"body must be a PlanarBody, got {body!r}")
    check_keywords(simulate_planar, inputs, ACCEPTED, INPUTS)
    m = check_method(method)
    rec_every = check_record_every(record_every)
    # every launch input, None where not given (the configuration the result keeps)
    launch: dict[str, Any] = {k: inputs.get(k) for k in ACCEPTED}
    for name, value in launch.items():
        if value is not None and np.ndim(value) != 0:
            raise ValueError(
                f"{name} must be a scalar for simulate_planar(); "
                f"use run_planar_batch for arrays"
            )
    prep = prepare(body, **launch)
    rec_every = results.default_record_every(prep, rec_every)
    raw = execute(prep, method=m, record_every=rec_every, parallel=False)
    config = {
        "body": body.describe(),
        "launch": {k: (None if v is None else float(v)) for k, v in launch.items()},
        "dt_used": float(prep.coords["dt"][1][0]),
        "method": method,
        "record_every": rec_every,
    }
    return results.run_dataset(
        prep, raw, rec_every, attrs_for, run_attrs(method, rec_every), config
    )
