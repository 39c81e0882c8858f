"""Stopping at the answer: ``stop="first_reversal"`` ends a launch at its first reversal
and gives the full run's answer to the question asked, bit for bit."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from heading_oracle import heading_reversal_steps, wackelstein
from rattlesweep.sweep import classify
from rattlesweep.sweep._outputs.outcomes import (
    CAPSIZED,
    FAILED,
    NO_REVERSAL,
    OUTCOME_NAMES,
    REVERSED,
    SEVERAL,
    at_first_reversal,
)

TOY = rs.Body.preset("toy")
BAND = 0.05

# spins from fast reversals to slow ones that reverse several times, friction and rolling,
# a pitched launch, and a non-finite spin: 56 launches of one body (one time step)
LAUNCHES = dict(
    spin=np.concatenate([np.linspace(-24, 24, 9), [-2, -1, 1, 2, np.nan]])[:, None, None],
    mu=np.array([0.3, math.inf])[None, :, None],
    pitch_deg=np.array([0.0, 3.0])[None, None, :],
    roll_deg=1.0,
    t_end=8.0,
)


def outcome(ds):
    return classify(
        ds.status.values,
        ds.n_reversals.values,
        ds.mean_final_spin.values,
        ds.initial_spin.values,
        BAND,
    )


@pytest.fixture(scope="module")
def runs():
    return (
        rs.run_batch(TOY, **LAUNCHES, reversal_band=BAND),
        rs.run_batch(TOY, **LAUNCHES, reversal_band=BAND, stop="first_reversal"),
    )


def test_stop_gives_the_full_runs_answer_bit_for_bit(runs):
    full, stop = runs
    full_outcome = outcome(full)
    # the batch holds every kind of launch the rule must get right (several reversals:
    # test_stop_after_several_reversals)
    kinds = set(full_outcome.tolist())
    assert {NO_REVERSAL, REVERSED, CAPSIZED, FAILED} <= kinds, kinds
    assert np.any((full.status.values == 1) & (full.n_reversals.values > 0)), (
        "no launch capsizes after reversing"
    )
    np.testing.assert_array_equal(
        stop.first_reversal_time.values, full.first_reversal_time.values
    )  # NaN equals NaN here
    expected = at_first_reversal(full_outcome, full.n_reversals.values)
    assert [OUTCOME_NAMES[k] for k in outcome(stop)] == [OUTCOME_NAMES[k] for k in expected]
    assert stop.attrs["stop"] == "first_reversal" and "stop" not in full.attrs
    # a launch that never reversed ran exactly as before, to its end or its failure
    never = full.n_reversals.values == 0
    for name in (
        "status",
        "t_final",
        "final_spin",
        "mean_final_spin",
        "energy_lost",
        "slip_fraction",
        "max_tilt",
        "steps",
    ):
        np.testing.assert_array_equal(
            stop[name].values[never], full[name].values[never], err_msg=name
        )
    # one that reversed ended there, with everything taken at that time
    rev = ~never
    np.testing.assert_array_equal(stop.n_reversals.values[rev], 1)
    assert np.all(stop.status.values[rev] == 0)
    t_stop = stop.t_final.values[rev]
    assert np.all(t_stop > stop.first_reversal_time.values[rev])
    assert np.all(t_stop < full.t_final.values[rev])
    assert np.all(stop.steps.values[rev] < full.steps.values[rev])
    spin0 = stop.initial_spin.values[rev]
    assert np.all(np.sign(spin0) * stop.final_spin.values[rev] < -BAND * np.abs(spin0))


def test_stop_time_is_where_spin_and_heading_have_both_reversed(runs):
    """Recorded full runs of the reversing launches say independently when each spin
    first went beyond the band on the other side and when its heading first turned back
    by more than the heading band: the stopped run ends at the later of the two steps."""
    full, stop = runs
    rev = np.flatnonzero(full.n_reversals.values > 0)[::3]
    assert rev.size >= 5
    pick = {k: full[k].values[rev] for k in ("mu", "pitch_deg", "roll_deg")}
    rec = rs.run_batch(
        TOY,
        spin=full.launch_spin.values[rev],
        **pick,
        t_end=8.0,
        reversal_band=BAND,
        record_every=1,
    )
    dt = float(rec.dt[0])
    later = 0
    for i, j in enumerate(rev):
        spin = rec.spin.values[i]
        side = np.sign(spin[0])
        beyond = int(np.argmax(side * spin < -BAND * abs(spin[0])))
        turned = heading_reversal_steps(rec.quaternion.values[i], side)
        if not turned:  # a first reversal still under way at the end: run to the end
            assert stop.steps.values[j] == full.steps.values[j]
            continue
        first = max(beyond, turned[0])
        later += turned[0] > beyond
        assert stop.steps.values[j] == first
        assert stop.t_final.values[j] == pytest.approx(first * dt, rel=1e-12)
        assert stop.final_spin.values[j] == spin[first]
    assert later > 0  # the heading reversal is the later one here


def test_stop_after_several_reversals():
    """A launch that reverses several times (the damped ellipsoid of test_heading) stops
    at its first reversal with the full run's first reversal time."""
    body, launch = wackelstein()
    full = rs.run_batch(body, **launch, t_end=8.0, reversal_band=BAND)
    stop = rs.run_batch(
        body, **launch, t_end=8.0, reversal_band=BAND, stop="first_reversal"
    )
    assert outcome(full)[0] == SEVERAL
    assert (
        outcome(stop)[0]
        == REVERSED
        == at_first_reversal(outcome(full), full.n_reversals.values)[0]
    )
    np.testing.assert_array_equal(
        stop.first_reversal_time.values, full.first_reversal_time.values
    )
    assert stop.steps.values[0] < 0.2 * full.steps.values[0]


def test_stop_ends_lift_off_and_rejects_unknown_rules(kl):
    # a violent roll kick lifts off before any reversal, with or without the rule
    kick = dict(
        omega=[[60.0, 0.0, 0.0], [0.0, 0.0, 5.0]], roll=math.radians(0.5), mu=0.5, t_end=1.0
    )
    a = rs.run_batch(kl, **kick)
    b = rs.run_batch(kl, **kick, stop="first_reversal")
    assert a.status.values[0] == b.status.values[0] == 2
    np.testing.assert_array_equal(a.t_final.values, b.t_final.values)
    with pytest.raises(ValueError, match="stop must be None .* got 'end'"):
        rs.run_batch(kl, spin=5.0, t_end=1.0, stop="end")


def test_a_block_whose_lanes_all_stopped_ends_early():
    """Every lane reversing early: the stopped batch takes a fraction of the steps, and
    the same answers on the serial entry."""
    spin = np.full(64, -20.0)  # the toy's fast-reversing sense at mu = 0.3
    full = rs.run_batch(TOY, spin=spin, mu=0.3, roll=math.radians(0.5), t_end=8.0)
    stop = rs.run_batch(
        TOY,
        spin=spin,
        mu=0.3,
        roll=math.radians(0.5),
        t_end=8.0,
        stop="first_reversal",
        parallel=False,
    )
    assert np.all(full.n_reversals.values >= 1)
    assert stop.steps.values.sum() < 0.5 * full.steps.values.sum()
    np.testing.assert_array_equal(
        stop.first_reversal_time.values, full.first_reversal_time.values
    )


def test_a_sweep_with_the_stop_is_run_batch_with_it(tmp_path):
    from rattlesweep.sweep import Sweep, run_sweep

    s = Sweep(
        axes={"spin": [-20.0, -5.0, 5.0, 20.0], "mu": [0.3, math.inf]},
        fixed={"t_end": 5.0, "roll_deg": 0.5},
        stop="first_reversal",
    )
    ds = run_sweep(s, tmp_path, progress=False)
    ref = rs.run_batch(
        TOY,
        spin=np.array([-20.0, -5.0, 5.0, 20.0])[:, None],
        mu=np.array([0.3, math.inf])[None, :],
        roll=math.radians(0.5),
        t_end=5.0,
        stop="first_reversal",
    )
    for name in ("first_reversal_time", "t_final", "final_spin", "status", "n_reversals"):
        np.testing.assert_array_equal(
            ds[name].values.ravel(), ref[name].values, err_msg=name
        )
    assert ds.attrs["stop"] == "first_reversal"
    assert "stop = first_reversal" in ds.outcome.attrs["comment"]
    assert np.any(ds.t_final.values < 5.0)
