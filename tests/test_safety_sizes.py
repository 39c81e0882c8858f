"""What a call would hold is estimated before anything is allocated: a grid, a refined
grid, a batch broadcast, and a record too large for the machine are refused naming the
parameter, the figure and the memory available (not a MemoryError after minutes)."""

import time

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.sweep import Sweep, run_sweep

TOY = rs.Body.preset("toy")
HUGE = r"would need about [\d.e+]+ GiB, more than the [\d.e+]+ GiB of memory available"


def _refused(match, call):
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=match):
        call()
    assert time.perf_counter() - t0 < 5  # refused before any work


def test_axis_of_1e11_values_refused():
    _refused(
        r"axes\.spin\.num = 100000000000: 100,000,000,000 axis values " + HUGE,
        lambda: Sweep(
            axes={"spin": {"start": 1, "stop": 2, "num": 10**11}}, fixed={"t_end": 1.0}
        ),
    )


def test_refined_grid_too_large_refused_before_anything_is_written(tmp_path):
    s = Sweep(
        axes={
            "spin": {"start": 1, "stop": 2, "num": 5},
            "mu": {"start": 0.1, "stop": 0.5, "num": 5},
        },
        fixed={"t_end": 1.0},
        refine=12,
    )
    _refused(
        r"refine\.levels = 12: the finest grid \(16385, 16385\) \(268,468,225 "
        r"points\) " + HUGE,
        lambda: run_sweep(s, tmp_path / "out", progress=False),
    )
    assert not (tmp_path / "out").exists()


def test_netcdf_grid_too_large_to_merge_refused(tmp_path):
    s = Sweep(
        axes={
            "spin": {"start": 1, "stop": 2, "num": 100_000},
            "mu": {"start": 0.1, "stop": 0.5, "num": 100_000},
        },
        fixed={"t_end": 1.0},
    )
    _refused(
        r"axes = grid \(100000, 100000\): merging its 10,000,000,000 points into "
        r"sweep\.nc " + HUGE + r"; .*output = \"zarr\"",
        lambda: run_sweep(s, tmp_path / "out", progress=False),
    )
    assert not (tmp_path / "out").exists()


def test_batch_broadcast_too_large_refused():
    _refused(
        r"launches = 100,000,000 \(the broadcast of .*spin \(10000, 1\)\).*" + HUGE,
        lambda: rs.run_batch(
            TOY, spin=np.ones((10_000, 1)), mu=np.ones((1, 10_000)), t_end=1.0
        ),
    )


def test_the_check_uses_the_memory_available(monkeypatch):
    import rattlesweep._validation as validation

    # a batch of 1000 launches (about 1 MB) on a machine with 100 kB available
    monkeypatch.setattr(validation, "available_memory", lambda: 100_000)
    _refused(
        r"launches = 1,000 \(the broadcast of spin \(1000,\)\): a batch of 1,000 "
        r"launches would need about 0.000954 GiB, more than the 9.31e-05 GiB",
        lambda: rs.run_batch(TOY, spin=np.ones(1000), t_end=0.01),
    )
    monkeypatch.setattr(validation, "available_memory", lambda: 10**9)
    assert rs.run_batch(TOY, spin=np.ones(1000), t_end=0.01).sizes["trajectory"] == 1000


def test_an_axis_is_refused_for_what_building_the_grid_holds(monkeypatch):
    """A billion values of one axis on a machine with 20 GiB available: building the grid
    holds about two copies of its 8 GB (16.7 GB measured), so it is refused before that,
    not after (the values alone would fit)."""
    import rattlesweep._validation as validation

    monkeypatch.setattr(validation, "available_memory", lambda: 20 * 2**30)
    _refused(
        r"axes\.spin\.num = 1000000000: 1,000,000,000 axis values " + HUGE,
        lambda: Sweep(
            axes={"spin": {"start": 1, "stop": 2, "num": 10**9}},
            fixed={"t_end": 1.0},
            output="zarr",
        ),
    )
