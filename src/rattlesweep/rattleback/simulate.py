"""One launch, with its time series: :func:`simulate`."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import _results as results
from .._options import check_band, check_method, check_record_every
from .._run import execute
from ..inputs import RATTLEBACK as INPUTS
from .._keywords import check_keywords, document
from .batch import ACCEPTED, LAUNCH, prepare, run_attrs, split_angles
from .body import Body
from .metadata import attrs_for

__all__ = ["simulate"]


@document(INPUTS, scalar=True)
def simulate(
    body: Body,
    *,
    method: str = INPUTS["method"].default,
    record_every: int | None = None,
    reversal_band: float = INPUTS["reversal_band"].default,
    lyapunov: bool = False,
    **inputs: ArrayLike | None,
) -> xr.Dataset:
    """Simulate one launch and return its time series.

    The inputs are those of :func:`rattlesweep.run_batch`, as scalars (``omega`` (3,),
    ``orientation`` (4,), ``velocity`` (2,)); angles in radians, or in degrees as
    ``roll_deg``, ``pitch_deg``, ``yaw_deg``. ``record_every`` defaults to the smallest
    stride that keeps at most 10 000 samples (1 for runs of up to 10 000 steps).
    ``lyapunov=True`` adds the launch's largest finite-time Lyapunov exponent as
    ``lyapunov`` (1/s), as in :func:`rattlesweep.run_batch`.

    Parameters
    ----------
    body : Body
        The body.
    {inputs}

    Returns
    -------
    xarray.Dataset
        Over ``time`` (s): ``spin`` (rad/s), ``heading`` (rad: the long axis' direction
        seen from above, unwrapped), ``energy`` (J), ``tilt`` (rad),
        ``slipping``, ``normal_force`` (N), ``friction_force`` (N), ``friction_impulse``
        (N s, the plastic impulses that bring a slipping contact to rest, summed since
        the previous sample), ``slip_velocity`` and ``slip_speed`` (m/s),
        ``quaternion``, ``omega`` (rad/s), ``position`` (m) and ``velocity`` (m/s) of G;
        the per-run observables of :func:`run_batch` as scalar variables; every input as
        an attribute (units in ``<name>_units``, long name in ``<name>_long_name``), named
        as the coordinates of :func:`run_batch` (``launch_spin``, ``roll_deg`` ...).

    Raises
    ------
    ValueError
        For any invalid input, naming the parameter, the value and the rule.
    TypeError
        For a name that is neither an input nor an option, listing both; for a
        required input not given (``t_end``).

    Warns
    -----
    UnitsWarning
        When a roll or pitch in radians can only be degrees typed as radians.
    RuntimeWarning
        When the run ends with a status other than ``ok``.
    CoarseStepWarning
        When a given ``dt`` is more than 4 times the default step.
    """
    if not isinstance(body, Body):
        raise ValueError(f"body must be a Body, got {body!r}")
    check_keywords(simulate, inputs, ACCEPTED, INPUTS)
    m = check_method(method)
    rec_every = check_record_every(record_every)
    band = check_band(reversal_band)
    given, radians, degrees = split_angles(body, inputs)
    # every launch input, None where not given (the configuration the result keeps)
    launch: dict[str, Any] = {k: radians.get(k, given.get(k)) for k in LAUNCH}
    for name, value in launch.items():
        width = INPUTS[name].width
        if value is None:
            continue
        if width == 1 and np.ndim(value) != 0:
            raise ValueError(
                f"{name} must be a scalar for simulate(); use run_batch for arrays"
            )
        if width > 1 and np.shape(value) != (width,):
            raise ValueError(f"{name} must have shape ({width},), got {np.shape(value)}")
    prep = prepare(body, degrees=degrees, lyapunov=lyapunov, **launch)
    rec_every = results.default_record_every(prep, rec_every)
    raw = execute(prep, method=m, record_every=rec_every, band=band, parallel=False)
    config = {
        "body": body.describe(),
        "launch": {
            k: (np.asarray(v).tolist() if v is not None else None)
            for k, v in launch.items()
        },
        "dt_used": float(prep.coords["dt"][1][0]),
        "method": method,
        "record_every": rec_every,
        "reversal_band": band,
        "lyapunov": prep.lanes is not None,
    }
    attrs = run_attrs(method, rec_every, band, lyapunov=prep.lanes is not None)
    return results.run_dataset(prep, raw, rec_every, attrs_for, attrs, config)
