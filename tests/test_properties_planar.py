"""Property-based tests (hypothesis) of the planar model's launches: every input gets
a ``ValueError`` naming a parameter the caller got wrong, or a result whose ``ok``
trajectories are finite with an energy that does not rise beyond the integrator's error,
and each launch's result does not depend on its position in the batch.

The number of examples per property comes from the hypothesis profile chosen in
tests/conftest.py (``ci`` by default; ``HYPOTHESIS_PROFILE=long`` for a long run).
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np
import pytest

pytest.importorskip("hypothesis")

from hypothesis import event, given
from hypothesis import strategies as st

import rattlesweep as rs
from rattlesweep._core.workspace import OK
from rattlesweep import CoarseStepWarning
from rattlesweep.planar.batch import prepare as prepare_planar
from strategies import (
    any_scalar,
    finite,
)
from property_checks import (
    assert_names,
    check_energy,
    rerun_batch,
)

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

# --- the planar model -----------------------------------------------------------------
PLANAR_OBSERVABLES = (
    "energy_initial",
    "energy_final",
    "energy_lost",
    "slip_fraction",
    "max_angle",
    "final_angle",
    "final_rate",
    "t_final",
    "steps",
    "status",
)
PLANAR_ARGS = (
    "theta",
    "rate",
    "velocity",
    "mu",
    "mu_static",
    "mu_roll",
    "g",
    "dt",
    "t_end",
)


@st.composite
def planar_launch(draw, body):
    g = draw(finite(1.0, 20.0))
    dt0 = body.default_dt(g)
    mu = draw(st.sampled_from([0.0, 0.2, 0.5, math.inf]) | finite(0.0, 2.0))
    kw = {
        "theta": draw(finite(-1.2, 1.2)),
        "rate": draw(finite(-5.0, 5.0)),
        "mu": mu,
        "g": g,
        "dt": draw(finite(0.1, 1.0)) * dt0,
    }
    kw["t_end"] = draw(st.integers(1, 300)) * kw["dt"]
    if math.isfinite(mu) and draw(st.booleans()):
        kw["mu_static"] = mu + draw(finite(0.0, 0.5))
        kw["velocity"] = draw(finite(-0.5, 0.5))
    if draw(st.booleans()):
        kw["mu_roll"] = draw(finite(0.0, 0.1)) * body.b
    return kw


@given(a=finite(0.02, 0.3), ratio=finite(0.1, 1.3), mass=finite(0.01, 2.0), data=st.data())
def test_planar_launches(a, ratio, mass, data):
    """The planar model: a valid launch with at most one argument replaced by an arbitrary
    value is refused naming it, or runs clean; results do not depend on the position."""
    body = rs.PlanarBody(a, ratio * a, mass)
    kw = data.draw(planar_launch(body))
    bad = data.draw(st.none() | st.sampled_from(PLANAR_ARGS))
    if bad is not None:
        kw[bad] = data.draw(
            any_scalar(finite(-1, 1))
            if bad not in ("dt", "t_end")
            else any_scalar(finite(1e-4, 1e-2)),
            label=bad,
        )
    partners = {"mu": {"mu_static"}, "mu_static": {"velocity"}, "velocity": {"mu_static"}}
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", CoarseStepWarning)
            if prepare_planar(body, **kw).nsteps.max(initial=0) > 5000:
                kw["t_end"] = 1e-3
            ds = rs.run_planar_batch(body, **kw)
    except ValueError as exc:
        assert bad is not None, f"a valid launch was refused: {exc}"
        assert_names(exc, {bad} | partners.get(bad, set()))
        event("refused")
        return
    event("accepted")
    ok = ds.status.values == OK
    for name in PLANAR_OBSERVABLES:
        assert np.all(np.isfinite(ds[name].values[ok])), name
    if not caught and bad not in ("theta", "rate", "velocity", "g", "dt"):
        check_energy(ds, rerun_batch(functools.partial(rs.run_planar_batch, body), ds, kw))
    if ds.sizes["trajectory"] >= 2:
        rev = rs.run_planar_batch(
            body,
            **{k: (np.asarray(v)[..., ::-1] if np.ndim(v) else v) for k, v in kw.items()},
        )
        for name in PLANAR_OBSERVABLES:
            np.testing.assert_array_equal(ds[name].values[::-1], rev[name].values)
