"""The sweep's progress bar: what it says while the first run compiles the kernels."""

import io
import time

from rattlesweep.sweep.progress import Progress


def test_a_compiling_first_tile_is_announced_and_left_out_of_the_eta():
    out = io.StringIO()
    bar = Progress(4, 400, 0, 0, stream=out, every=0.0, compiling=True)
    assert "compiling the simulation kernels (first run only" in out.getvalue()
    time.sleep(0.2)  # the first tile: compile and compute
    bar.update({"n": 100})
    assert bar.rate == 0.0 and out.getvalue().rstrip().endswith("ETA ?")
    time.sleep(0.05)
    bar.update({"n": 100})  # the second tile: the rate is that of this tile alone
    assert 100 / 0.2 < bar.rate <= 100 / 0.05
    assert "ETA ?" not in out.getvalue().splitlines()[-1]


def test_without_compiling_the_rate_counts_every_tile():
    out = io.StringIO()
    bar = Progress(2, 200, 0, 0, stream=out, every=0.0)
    assert "compiling" not in out.getvalue()
    time.sleep(0.05)
    bar.update({"n": 100})
    assert bar.rate > 0.0
    resumed = Progress(2, 200, 2, 200, stream=io.StringIO(), compiling=True)
    assert "compiling" not in resumed.stream.getvalue()  # nothing left to compute
