"""What a call would hold is estimated before anything is allocated: a grid, a refined
grid, a batch broadcast, and a record too large for the machine are refused naming the
parameter, the figure and the memory available (not a MemoryError after minutes)."""

import re
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
    monkeypatch.setattr(validation, "memory_left", lambda: (100_000, "memory available"))
    _refused(
        r"launches = 1,000 \(the broadcast of spin \(1000,\)\): a batch of 1,000 "
        r"launches would need about 0.000954 GiB, more than the 9.31e-05 GiB",
        lambda: rs.run_batch(TOY, spin=np.ones(1000), t_end=0.01),
    )
    monkeypatch.setattr(validation, "memory_left", lambda: (10**9, "memory available"))
    assert rs.run_batch(TOY, spin=np.ones(1000), t_end=0.01).sizes["trajectory"] == 1000


def test_an_axis_is_refused_for_what_building_the_grid_holds(monkeypatch):
    """A billion values of one axis on a machine with 20 GiB available: building the grid
    holds about two copies of its 8 GB (16.7 GB measured), so it is refused before that,
    not after (the values alone would fit)."""
    import rattlesweep._validation as validation

    monkeypatch.setattr(validation, "memory_left", lambda: (20 * 2**30, "memory available"))
    _refused(
        r"axes\.spin\.num = 1000000000: 1,000,000,000 axis values " + HUGE,
        lambda: Sweep(
            axes={"spin": {"start": 1, "stop": 2, "num": 10**9}},
            fixed={"t_end": 1.0},
            output="zarr",
        ),
    )


def _two_axes(num, **kw):
    return dict(
        axes={
            "spin": {"start": -20, "stop": 20, "num": num},
            "delta_deg": {"start": -6, "stop": 6, "num": num},
        },
        fixed={"t_end": 1.0},
        **kw,
    )


@pytest.mark.parametrize("output", ["netcdf", "zarr"])
def test_a_grid_too_large_is_refused_from_its_nums_before_any_axis_is_made(output):
    """Two axes of 10^8 values each: 10^16 points. Each axis alone fits, so their values
    were made (1.6 GB, 27 s in all) before the grid was refused; now nothing is."""
    import tracemalloc

    tracemalloc.start()
    try:
        _refused(
            r"^axes = spin \(num = 100,000,000\) × delta_deg \(num = 100,000,000\) = "
            r"10,000,000,000,000,000 points: the list of its [\d,]+ tiles " + HUGE,
            lambda: Sweep(**_two_axes(10**8, output=output)),
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6  # no axis of 800 MB


def test_a_grid_beyond_64_bit_indices_is_refused():
    axes = {k: {"start": 1, "stop": 2, "num": 10**7} for k in ("spin", "mu", "damping")}
    _refused(
        r"^axes = spin \(num = 10,000,000\) × mu \(num = 10,000,000\) × damping "
        r"\(num = 10,000,000\) = 1,000,000,000,000,000,000,000 points: a sweep has at "
        r"most 2\*\*63 - 1",
        lambda: Sweep(axes=axes, fixed={"t_end": 1.0}, tile_size=10**18),
    )


def test_dry_run_of_a_huge_grid_is_refused_at_once(tmp_path, capsys):
    from rattlesweep.cli import main

    config = tmp_path / "big.toml"
    config.write_text(
        'name = "big"\n[axes]\nspin = { start = -20, stop = 20, num = 100000000 }\n'
        "delta_deg = { start = -6, stop = 6, num = 100000000 }\n[fixed]\nt_end = 1.0\n"
    )
    t0 = time.perf_counter()
    assert main(["sweep", str(config), "--dry-run"]) == 2
    assert time.perf_counter() - t0 < 5
    err = capsys.readouterr().err
    assert "spin (num = 100,000,000) × delta_deg (num = 100,000,000)" in err
    assert "out of bounds" not in err


def test_dry_run_says_a_refined_grid_would_be_refused(tmp_path, capsys, monkeypatch):
    """[refine] levels = 12 on a 5 × 5 grid: the dry run said "about 57.2 GB at peak"
    and nothing more, while the run refused it for 250 GiB."""
    import rattlesweep._validation as validation
    from rattlesweep.cli import main

    monkeypatch.setattr(validation, "memory_left", lambda: (16 * 2**30, "memory available"))
    config = tmp_path / "refined.toml"
    config.write_text(
        'name = "fine"\n[axes]\nspin = { start = 1, stop = 2, num = 5 }\n'
        "mu = { start = 0.1, stop = 0.5, num = 5 }\n[fixed]\nt_end = 0.1\n"
        "[refine]\nlevels = 12\n"
    )
    assert main(["sweep", str(config), "--dry-run"]) == 2
    out = capsys.readouterr().out
    # the peak includes what the kernels' calibration measured: about 269 GB here
    assert re.search(r"memory: about 2[67]\d GB at peak", out), out
    assert (
        "refused: a run would stop before it starts: refine.levels = 12: the finest "
        "grid (16385, 16385) (268,468,225 points) would need about 250 GiB, more than "
        "the 16 GiB of memory available" in out
    )
    assert main(["sweep", str(config), "--out", str(tmp_path / "out")]) == 2
    assert "would need about 250 GiB" in capsys.readouterr().err


UNDER_A_LIMIT = """
import resource, sys
import numpy as np
import rattlesweep as rs
rs.run_batch(rs.Body.preset("toy"), spin=[1.0], t_end=0.01)  # loaded before the limit
status = open("/proc/self/status").read().splitlines()
size = next(int(x.split()[1]) * 1024 for x in status if x.startswith("VmSize:"))
resource.setrlimit(resource.RLIMIT_AS, (size + 2**30, resource.RLIM_INFINITY))
for call in (
    lambda: rs.run_batch(rs.Body.preset("toy"), spin=np.zeros(5_000_000), t_end=0.01),
    lambda: rs.simulate(rs.Body.preset("toy"), spin=5.0, t_end=300.0, record_every=1),
):
    try:
        call()
    except ValueError as error:
        print(error)
"""


def test_size_guards_heed_the_process_address_space_limit():
    """Under `ulimit -v` (RLIMIT_AS) with 1 GiB left, a batch of 5e6 launches and a
    long record are refused by name, saying which limit applies, on a machine whose
    memory would hold them (they were MemoryError tracebacks)."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", UNDER_A_LIMIT], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 2, out.stdout + out.stderr[-2000:]
    assert lines[0].startswith("launches = 5,000,000")
    for line in lines:
        assert "address space left under this process's limit (ulimit -v)" in line, line
