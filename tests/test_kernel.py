"""Batch behaviour: statuses, independence from batch layout, threads, recording."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep._core.workspace import BLOCK, STATUS_NAMES

from conftest import HALF_DEGREE

OBSERVABLES = [
    "first_reversal_time",
    "n_reversals",
    "final_spin",
    "mean_final_spin",
    "max_tilt",
    "energy_lost",
    "slip_fraction",
    "status",
    "t_final",
]


def test_each_status_comes_from_a_launch_that_causes_it(kl):
    toy = rs.Body.preset("toy")
    bodies = np.array([kl, toy, kl, kl], dtype=object)
    omega = np.array(
        [
            [0.0, 0.0, 5.0],  # ordinary launch
            [
                15.0,
                0.0,
                0.0,
            ],  # toy tipped to 80 deg and rolled over: the rim hits the floor
            [60.0, 0.0, 0.0],  # violent roll kick: centripetal demand exceeds gravity
            [np.nan, 0.0, 5.0],  # non-finite input
        ]
    )
    roll = np.radians([0.5, 80.0, 0.5, 0.5])
    ds = rs.run_batch(bodies, omega=omega, roll=roll, mu=0.5, t_end=1.0)
    names = [STATUS_NAMES[s] for s in ds.status.values]
    assert names == ["ok", "capsized", "lifted_off", "non_finite"]
    assert ds.t_final[0] >= 1.0
    assert 0 < ds.t_final[1] < 0.1 and 0 < ds.t_final[2] < 0.1
    assert ds.t_final[3] == 0 and np.isnan(ds.final_spin[3])
    # the capsized toy stopped at its last valid state, tilted nearly 90 degrees
    assert math.radians(85) < float(ds.max_tilt[1]) <= math.pi / 2
    assert set(ds.status.attrs["flag_meanings"].split()) == set(STATUS_NAMES)


def test_simulate_warns_when_a_run_stops(kl):
    with pytest.warns(RuntimeWarning, match="lifted_off"):
        ds = rs.simulate(kl, omega=(60.0, 0.0, 0.0), t_end=0.5)
    assert np.isnan(ds.spin.values[-1])  # samples after the stop are NaN, not made up
    assert np.isfinite(ds.spin.values[0])


def test_result_is_independent_of_position_and_batch_size(kl):
    kw = dict(roll=HALF_DEGREE, mu=0.3, t_end=3.0)
    alone = rs.run_batch(kl, spin=5.0, **kw)
    rng = np.random.default_rng(1)
    for n, pos in ((3, 2), (BLOCK + 5, BLOCK + 1), (100, 37)):
        spins = rng.uniform(-10, 10, n)
        spins[pos] = 5.0
        batch = rs.run_batch(kl, spin=spins, **kw)
        for name in OBSERVABLES:
            np.testing.assert_array_equal(
                batch[name].values[pos], alone[name].values[0], err_msg=name
            )


def test_a_slip_does_not_depend_on_a_neighbour_switching_at_its_step_start():
    """A neighbour whose contact switches at a step start makes the stepper evaluate the
    whole block there again; a slipping lane's result must not change with that (its
    consistent direction's turn rate once came out zero from the second evaluation).
    Found by the property test of batch positions: golden body, tilted launches at rest,
    one step."""
    golden = rs.Body.preset("golden")
    tilted = dict(omega=(0.0, 0.0, 0.0), mu=0.1, t_end=0.0145493)
    alone = rs.run_batch(
        golden, orientation=(0.9980475107, 0.0, 0.0624593178, 0.0), **tilted
    )
    bodies = np.empty(2, dtype=object)
    bodies[:] = [golden, golden]
    pair = rs.run_batch(
        bodies,
        orientation=[
            (0.9980525785, 0.0, 0.0623782862, 0.0),
            (0.9980475107, 0.0, 0.0624593178, 0.0),
        ],
        mu_roll=[0.0625, 0.0],
        **tilted,
    )
    assert float(alone.slip_fraction[0]) == 1.0  # it slips: the case in question
    for name in OBSERVABLES:
        np.testing.assert_array_equal(
            pair[name].values[1], alone[name].values[0], err_msg=name
        )


def test_serial_and_parallel_entries_agree(kl):
    kw = dict(spin=np.linspace(-8, 8, 70), roll=HALF_DEGREE, mu=0.4, t_end=2.0)
    serial = rs.run_batch(kl, parallel=False, **kw)
    threaded = rs.run_batch(kl, parallel=True, threads=2, **kw)
    for name in OBSERVABLES:
        np.testing.assert_array_equal(serial[name].values, threaded[name].values)


def test_per_trajectory_parameters_span_a_grid():
    bodies = [rs.Body.semi_ellipsoid(0.05, 0.01, 0.01, 0.02, d) for d in (-0.1, 0.1)]
    ds = rs.run_batch(
        np.array(bodies, dtype=object)[:, None],
        spin=[[-4.0, 4.0]],
        roll=0.02,
        g=[[9.81, 3.0]],
        t_end=0.5,
        dt=5e-4,
    )
    assert ds.sizes["trajectory"] == 4
    assert ds.attrs["batch_shape"] == [2, 2]
    np.testing.assert_allclose(
        ds.inertia_xy.values[[0, 2]], [bodies[0].inertia[0, 1], bodies[1].inertia[0, 1]]
    )
    np.testing.assert_array_equal(ds.g.values, [9.81, 3.0, 9.81, 3.0])
    # each lane ran with its own parameters: a lone run of lane 3 matches
    lone = rs.run_batch(bodies[1], spin=4.0, roll=0.02, g=3.0, t_end=0.5, dt=5e-4)
    assert float(lone.final_spin[0]) == float(ds.final_spin[3])


def test_default_dt_converges_first_reversal_to_a_millisecond(kl):
    dt = kl.default_dt()
    ds = rs.run_batch(kl, spin=5.0, roll=HALF_DEGREE, dt=[dt, dt / 4], t_end=8.0)
    t_default, t_fine = ds.first_reversal_time.values
    assert np.isfinite(t_fine)
    assert abs(t_default - t_fine) < 1e-3


def test_recording_every_kth_step(kl):
    ds = rs.simulate(kl, spin=2.0, t_end=0.1, dt=1e-3, record_every=10)
    np.testing.assert_allclose(ds.time.values, np.arange(11) * 0.01, atol=1e-15)
    assert ds.spin.values[0] == pytest.approx(2.0)
    default = rs.simulate(kl, spin=2.0, t_end=30.0, dt=1e-3)
    assert default.sizes["time"] <= 10_001


def test_batch_time_series_need_one_dt(kl):
    ds = rs.run_batch(kl, spin=[1.0, -1.0], t_end=0.05, dt=1e-3, record_every=5)
    assert ds.spin.dims == ("trajectory", "time") and ds.sizes["time"] == 11
    with pytest.raises(ValueError, match="record_every needs a single dt"):
        rs.run_batch(kl, spin=1.0, t_end=0.05, dt=[1e-3, 2e-3], record_every=5)


def test_zero_spin_has_no_reversal(kl):
    ds = rs.run_batch(kl, spin=0.0, roll=0.05, t_end=2.0)
    assert int(ds.n_reversals[0]) == 0 and np.isnan(float(ds.first_reversal_time[0]))


def test_reversal_count_and_mean_final_spin(kl):
    # undamped fast launch: reverses, then (slowly) reverses back, rattling each time
    ds = rs.simulate(kl, spin=5.0, roll=HALF_DEGREE, t_end=40.0)
    spin = ds.spin.values
    band = 0.05 * 5.0
    side, count = 1, 0
    for s in spin:  # recount from the recorded series with the same hysteresis rule
        if side * s < -band:
            side, count = -side, count + 1
    assert int(ds.n_reversals) == count >= 1
    tail = spin[ds.time.values > 0.9 * 40.0]
    assert float(ds.mean_final_spin) == pytest.approx(tail.mean(), rel=0.02)


def test_no_allocation_in_the_time_loop(kl):
    """numba's allocation count for a run does not grow with the number of steps: the
    block drivers allocate their workspace once per block, and nothing in the time loop
    allocates (stick, slip and recording paths, serial and parallel entries)."""
    from numba.core.runtime import _nrt_python, rtsys

    from rattlesweep.rattleback.batch import prepare
    from rattlesweep._core.workspace import O_SLIP_FRAC, RK4
    from rattlesweep._run import execute

    def allocations(t_end, parallel):
        # a rolling block and two that slip (mu = 0.02, 0.01): the stick, slip and
        # re-stick code paths all run
        prep = prepare(
            kl,
            spin=np.linspace(-8.0, 8.0, BLOCK),
            roll=math.radians(2.0),
            mu=np.array([math.inf, 0.02, 0.01])[:, None],
            t_end=t_end,
        )
        kw = dict(method=RK4, record_every=5, band=0.05, parallel=parallel)
        obs = execute(prep, **kw).observables  # compiles and warms up outside the count
        slip = obs[O_SLIP_FRAC].reshape(3, BLOCK)
        assert slip[0].max() == 0.0 and (slip[1:].max(axis=1) > 0.0).all()
        before = rtsys.get_allocation_stats()
        execute(prep, **kw)
        after = rtsys.get_allocation_stats()
        return after.alloc - before.alloc, after.free - before.free, int(prep.nsteps.max())

    enabled = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()
    try:
        for parallel in (False, True):
            short = allocations(0.01, parallel)
            long = allocations(1.0, parallel)
            assert long[2] > 50 * short[2]
            assert long[:2] == short[:2]
            assert short[0] == short[1] > 0  # every allocation freed; the count is live
    finally:
        if not enabled:
            _nrt_python.memsys_disable_stats()


def test_cached_kernels_are_dropped_when_any_kernel_source_changes(tmp_path):
    """numba keys a cached kernel on its own file only; a stepper compiled with an older
    model must not be loaded after the model's file changed."""
    from rattlesweep._core.jit import drop_stale_cache

    (tmp_path / "model.py").write_text("x = 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    kernel_file = cache / "stepper.advance_block-1.py311.nbi"
    kernel_file.write_bytes(b"old")
    assert drop_stale_cache(tmp_path) and not kernel_file.exists()
    kernel_file.write_bytes(b"new")  # compiled from the current sources
    assert not drop_stale_cache(tmp_path) and kernel_file.exists()
    (tmp_path / "model.py").write_text("x = 2\n")
    assert drop_stale_cache(tmp_path) and not kernel_file.exists()


def test_kernels_that_inline_another_package_go_with_its_changes(tmp_path):
    """A cache of kernels that inline another package's (the tests' own) is dropped when
    that package's sources change, and kept while neither changed."""
    from rattlesweep._core.jit import drop_stale_cache

    tests, package = tmp_path / "tests", tmp_path / "package"
    tests.mkdir()
    package.mkdir()
    (tests / "test_design.py").write_text("x = 1\n")
    (package / "model.py").write_text("y = 1\n")
    kernel_file = tests / "__pycache__" / "test_design.rhs-1.py311.nbi"
    assert drop_stale_cache(tests, depends_on=(package,))
    kernel_file.write_bytes(b"compiled from the current sources")
    assert not drop_stale_cache(tests, depends_on=(package,)) and kernel_file.exists()
    (package / "model.py").write_text("y = 2\n")
    assert drop_stale_cache(tests, depends_on=(package,)) and not kernel_file.exists()


def test_stale_kernels_are_dropped_where_numba_caches_them(tmp_path, monkeypatch):
    """With NUMBA_CACHE_DIR set, or from a read-only installation (the user's cache),
    numba caches a package's kernels outside it, one directory per source directory:
    those are dropped when any source changes (an upgrade in place of a read-only
    installation keeps its path, so numba alone would load the old stepper), and the
    package itself is not written to."""
    import numba.core.config

    from rattlesweep._core.jit import drop_stale_cache

    package = tmp_path / "package"
    (package / "model").mkdir(parents=True)
    (package / "stepper.py").write_text("x = 1\n")
    (package / "model" / "hooks.py").write_text("y = 1\n")
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(tmp_path / "cache"))
    assert drop_stale_cache(package)
    (stepper_cache,) = (tmp_path / "cache").glob("package_*")
    (model_cache,) = (tmp_path / "cache").glob("model_*")
    assert (stepper_cache / "kernel-sources.sha256").is_file()
    kernels = [
        stepper_cache / "stepper.advance_block-1.py311.nbi",
        model_cache / "hooks.rhs-1.py311.1.nbc",
    ]
    for kernel in kernels:
        kernel.write_bytes(b"compiled from the current sources")
    assert not drop_stale_cache(package) and all(k.exists() for k in kernels)
    (package / "model" / "hooks.py").write_text("y = 2\n")
    assert drop_stale_cache(package) and not any(k.exists() for k in kernels)
    assert sorted(p.name for p in package.rglob("*")) == ["hooks.py", "model", "stepper.py"]


def test_kernels_compiled_says_whether_a_first_call_compiles(tmp_path):
    """Here the kernels are cached (a run just used the entry); in a process whose numba
    cache is an empty directory they are not."""
    import os
    import subprocess
    import sys

    from rattlesweep._run import kernels_compiled

    from rattlesweep._core.workspace import ROLLING

    rs.simulate(rs.Body.preset("toy"), spin=5.0, t_end=0.01)  # rolling: mu = inf
    assert kernels_compiled(level=ROLLING)
    probe = (
        "from rattlesweep._run import kernels_compiled; "
        "print(kernels_compiled(level=0), kernels_compiled())"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)},
        check=True,
    )
    assert out.stdout.split() == ["False", "False"]
