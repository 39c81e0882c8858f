"""Checks the property-based tests (test_properties.py, test_properties_planar.py)
apply to every result: the observables compared between batch arrangements, finite
trajectories, an energy that does not rise beyond the integrator's error, and errors
that name the parameter."""

from __future__ import annotations

import re

import numpy as np
from hypothesis import note

from rattlesweep._core.workspace import OK

# observables every trajectory has, compared bit for bit between batch arrangements
OBSERVABLES = (
    "first_reversal_time",
    "n_reversals",
    "initial_spin",
    "final_spin",
    "mean_final_spin",
    "max_tilt",
    "energy_initial",
    "energy_final",
    "energy_lost",
    "slip_fraction",
    "t_final",
    "steps",
    "status",
)

ENERGY_RTOL = 1e-7
"""A run's energy may rise above its launch value by this fraction of it before the
properties ask why. Friction and damping only remove energy, so a larger rise must be
integrator error (RK4's truncation error in violent launches, the O(dt^2) work of a slip
onset decided at a step start), which shrinks with the step at the method's order once
the step resolves the motion (by 8 to 16 per halving in 800 random launches; a frictionless
sliding launch of a flat ellipsoid shrank by 2.6, then 15, 15, 16); a physical defect (a
force of the wrong sign, a lost impulse) does not shrink with the step."""


def names_one_of(exc: Exception, names) -> bool:
    """Whether the message of ``exc`` names one of ``names`` as a word."""
    msg = str(exc)
    return any(re.search(rf"(?<![\w]){re.escape(n)}(?![\w])", msg) for n in names)


def assert_names(exc: Exception, names) -> None:
    assert names_one_of(exc, names), (
        f"{type(exc).__name__}: {exc}\n does not name any of {sorted(names)}"
    )


def energy_rise(ds) -> np.ndarray:
    """Each trajectory's largest energy above its launch value, as a fraction of it (the
    recorded history when there is one, else the final energy)."""
    e0 = ds.energy_initial.values
    top = np.nanmax(ds.energy.values, axis=-1) if "energy" in ds else ds.energy_final.values
    return (top - e0) / np.abs(e0)


def check_trajectories(ds, rerun=None, shrink: float = 8.0) -> None:
    """Every ok trajectory finite (``mean_final_spin`` from 10 steps on, see
    test_mean_final_spin_of_a_short_run_is_finite), its reversal time inside the run, its
    energy at most its launch value within ENERGY_RTOL, or, where it rose more, a rise that
    ``rerun(factor)`` (the same launches with the time step times ``factor``) shows to
    be integrator error: a quarter of the step divides it by at least ``shrink`` (8 for
    RK4, of order 4, whose error a quarter step divides by 256 once the step resolves
    the motion; 2 for the first-order semi-implicit Euler); see :func:`check_energy`."""
    ok = ds.status.values == OK
    for name in OBSERVABLES:
        values = ds[name].values[ok]
        if name == "mean_final_spin":
            values = values[ds.steps.values[ok] >= 10]
        if name == "first_reversal_time":
            t = values[np.isfinite(values)]
            # a crossing interpolated inside the first step may round to a hair below 0
            # when the launch spin is ~0 (the band, a fraction of it, is then ~0 too)
            assert np.all((t >= -1e-15) & (t <= ds.t_final.values[ok][np.isfinite(values)]))
            assert not np.any(np.isinf(values))
        else:
            assert np.all(np.isfinite(values)), (name, values)
    if "energy" in ds:
        assert np.all(np.isfinite(ds.energy.values[ok])), "energy"
        assert np.all(np.isfinite(ds.spin.values[ok])), "spin"
    check_energy(ds, rerun, shrink)


def check_energy(ds, rerun=None, shrink: float = 8.0) -> None:
    """The energy part of :func:`check_trajectories`, for either model: a rise above
    ENERGY_RTOL must shrink by ``shrink`` from the step to a quarter of it, or, where the
    step is too coarse for the asymptotic rate (a switch moving by a step moves the peak),
    from a quarter to a sixteenth of it."""
    rise = energy_rise(ds)
    suspect = (ds.status.values == OK) & (rise > ENERGY_RTOL)
    factor = 1.0
    for _ in range(2):
        if not suspect.any():
            return
        assert rerun is not None, f"energy rose by {rise[suspect]} of its launch value"
        factor /= 4
        finer = rerun(factor)
        finer_rise = energy_rise(finer)
        note(f"energy rise {rise[suspect]}, {finer_rise[suspect]} at dt * {factor}")
        shrunk = finer_rise <= np.maximum(rise / shrink, ENERGY_RTOL)
        suspect &= (finer.status.values == OK) & ~shrunk
        rise = finer_rise
    assert not suspect.any(), f"energy rise {rise[suspect]} does not shrink with the step"


def rerun_batch(run, ds, kw):
    """A ``rerun`` for :func:`check_trajectories`: ``run(**kw)`` with each trajectory's
    time step times ``factor``."""
    shape = tuple(ds.attrs["batch_shape"])
    return lambda factor: run(**{**kw, "dt": ds.dt.values.reshape(shape) * factor})


def assert_same_results(a, b, err="") -> None:
    for name in OBSERVABLES:
        np.testing.assert_array_equal(
            a[name].values, b[name].values, err_msg=f"{name} {err}"
        )
