"""Reversals counted by the heading (the long axis seen from above), not by the spin
n = omega . Z, which also carries the rocking: the kernel's count against an independent
NumPy count from the recorded quaternions, on a published multi-reversal case, on
launches that rock hard without reversing, and on random damped and Coulomb launches."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from heading_oracle import (
    HEADING_BAND,
    heading_from_quaternions,
    heading_reversal_steps,
    largest_turn_back,
    reversal_count,
    wackelstein,
)
from rattlesweep._core.workspace import HEADING_BAND as KERNEL_HEADING_BAND

TOY = rs.Body.preset("toy")


def spin_reversals(spin, band=0.05):
    """Reversals by the spin alone: n beyond the band on the other side, each time."""
    side, count = np.sign(spin[0]), 0
    for n in spin[np.isfinite(spin)]:
        if side * n < -band * abs(spin[0]):
            count += 1
            side = -side
    return count


def test_the_documented_band_is_the_kernels():
    assert KERNEL_HEADING_BAND == HEADING_BAND


def test_wackelstein_reverses_five_times_in_eight_seconds():
    """Kuypers' Wackelstein 1 (Klassische Mechanik, 10th ed., supplement; Wittens 2024,
    sec. 7.1): its heading reverses five times in 8 s while the roll reaches about a
    radian and the spin n swings through zero more often than that."""
    body, launch = wackelstein()
    run = rs.simulate(body, **launch, t_end=8.0, record_every=1)
    q = run.quaternion.values
    assert len(heading_reversal_steps(q, -1.0)) == 5
    assert int(run.n_reversals) == 5
    assert spin_reversals(run.spin.values) >= 7  # what counting by the spin finds
    assert float(run.max_tilt) > 0.8
    # the recorded heading is the unwrapped direction of the long axis
    np.testing.assert_allclose(run.heading.values, heading_from_quaternions(q), atol=1e-9)
    assert run.heading.attrs["units"] == "rad"
    # each reversal is a turning point of the heading: it turns one way, then the other
    # by more than the band, and the spin's first reversal is near the first of them
    steps = heading_reversal_steps(q, -1.0)
    t = run.time.values
    assert float(run.first_reversal_time) == pytest.approx(t[steps[0]], abs=0.15)


def test_rocking_hard_without_reversing_counts_none():
    """The toy spun its preferred way, rolling, pitched 3 degrees: it rocks to a tilt of
    more than a radian and n crosses zero beyond the band, but the heading never turns
    back by even half the band."""
    run = rs.simulate(
        TOY,
        spin=6.0,
        pitch=math.radians(3.0),
        roll=math.radians(1.0),
        t_end=8.0,
        record_every=1,
    )
    assert float(run.max_tilt) > 1.0
    assert spin_reversals(run.spin.values) >= 2
    assert largest_turn_back(run.quaternion.values, 1.0) < 0.5 * HEADING_BAND
    assert int(run.n_reversals) == 0
    assert math.isfinite(float(run.first_reversal_time))  # the spin's own definition


def test_one_reversal_under_large_rocking_counts_one():
    """At mu = 0.3 the same launch reverses once and then rocks hard: n swings through
    zero several times; the heading reverses once."""
    run = rs.simulate(
        TOY,
        spin=6.0,
        mu=0.3,
        pitch=math.radians(3.0),
        roll=math.radians(1.0),
        t_end=10.0,
        record_every=1,
    )
    assert spin_reversals(run.spin.values) >= 4
    assert len(heading_reversal_steps(run.quaternion.values, 1.0)) == 1
    assert int(run.n_reversals) == 1


def test_a_spin_decayed_to_rocking_counts_no_phantoms():
    """kane_levinson with strong air resistance: it reverses once, then its spin decays
    below the rocking's share of n, which then crosses zero again and again."""
    run = rs.simulate(
        rs.Body.preset("kane_levinson"),
        spin=4.0,
        damping=3e-4,
        pitch=math.radians(3.0),
        roll=math.radians(1.0),
        t_end=20.0,
        record_every=2,
    )
    spin = run.spin.values
    assert spin_reversals(spin) >= 10
    assert np.max(np.abs(spin[-len(spin) // 5 :])) < 0.2 * abs(spin[0])  # decayed
    assert reversal_count(run.quaternion.values, spin) == 1
    assert int(run.n_reversals) == 1


def test_kane_levinson_counts_as_before():
    """Small rocking: spin and heading count alike (twice each way in 30 s, rolling)."""
    batch = rs.run_batch(
        rs.Body.preset("kane_levinson"),
        spin=[-5.0, 5.0],
        pitch=math.radians(0.5),
        t_end=30.0,
        record_every=2,
    )
    for i in range(2):
        sense = np.sign(batch.launch_spin.values[i])
        by_heading = len(heading_reversal_steps(batch.quaternion.values[i], sense))
        assert (
            batch.n_reversals.values[i]
            == by_heading
            == spin_reversals(batch.spin.values[i])
            == 2
        )


def test_numpy_count_agrees_on_random_launches():
    """Random damped and Coulomb launches of three bodies, recorded at every step."""
    rng = np.random.default_rng(29)
    n = 12
    body = np.array([TOY, rs.Body.preset("kane_levinson"), wackelstein()[0]], dtype=object)[
        rng.integers(0, 3, n)
    ]
    launch = dict(
        spin=rng.choice([-1.0, 1.0], n) * rng.uniform(2.0, 15.0, n),
        mu=rng.choice([0.15, 0.3, 0.6, math.inf], n),
        damping=rng.choice([0.0, 2e-6, 1e-4], n),
        pitch=np.radians(rng.uniform(-3.0, 3.0, n)),
        roll=np.radians(rng.uniform(-3.0, 3.0, n)),
    )
    batch = rs.run_batch(body, **launch, dt=5e-4, t_end=8.0, record_every=1)
    counts = []
    for i in range(n):
        if batch.status.values[i] != 0:
            continue
        counts.append(reversal_count(batch.quaternion.values[i], batch.spin.values[i]))
        assert batch.n_reversals.values[i] == counts[-1], i
    assert len(counts) >= 8 and max(counts) >= 2 and min(counts) == 0, counts


def test_a_first_reversal_under_way_at_the_end_counts():
    """The kane_levinson launch whose spin crosses zero at 2.85 s and leaves its band at
    2.90 s, run to 3.0 s: the spin is beyond its band the other way and has stayed
    there, while the heading has not yet turned back by the band (it does at 3.18 s).
    Run to 3.3 s, the heading has confirmed it."""
    kl = rs.Body.preset("kane_levinson")
    early = rs.simulate(kl, spin=5.0, pitch=math.radians(0.5), t_end=3.0, record_every=1)
    q, spin = early.quaternion.values, early.spin.values
    assert heading_reversal_steps(q, 1.0) == []
    assert 0.0 < largest_turn_back(q, 1.0) < HEADING_BAND
    assert int(early.n_reversals) == reversal_count(q, spin) == 1
    later = rs.simulate(kl, spin=5.0, pitch=math.radians(0.5), t_end=3.3, record_every=1)
    assert len(heading_reversal_steps(later.quaternion.values, 1.0)) == 1
    assert int(later.n_reversals) == 1
    assert float(early.first_reversal_time) == float(later.first_reversal_time)


def test_a_launch_without_spin_counts_none():
    """Pitched 3 degrees without spin, the toy's rattling turns it by more than a turn:
    no reversal by definition, and its recorded heading still unwraps exactly."""
    run = rs.simulate(TOY, spin=0.0, pitch=math.radians(3.0), t_end=8.0, record_every=1)
    assert int(run.n_reversals) == 0 and math.isnan(float(run.first_reversal_time))
    psi = heading_from_quaternions(run.quaternion.values)
    assert np.ptp(psi) > 2.0 * math.pi
    np.testing.assert_allclose(run.heading.values, psi, atol=1e-9)
