"""The sweep's progress bar: what it says while the first run compiles the kernels,
and a rate without the compile time."""

import io
import time

from rattlesweep.sweep._execution.progress import Progress


def test_a_compiling_first_tile_on_workers_is_announced_and_left_out_of_the_eta():
    out = io.StringIO()
    bar = Progress(4, 400, 0, 0, stream=out, every=0.0, compiling=True)
    assert "the workers compile the simulation kernels first" in out.getvalue()
    time.sleep(0.2)  # the first tile: compile and compute
    bar.update({"n": 100})
    assert bar.rate == 0.0 and out.getvalue().rstrip().endswith("ETA ?")
    time.sleep(0.05)
    bar.update({"n": 100})  # the second tile: the rate is that of this tile alone
    assert 100 / 0.2 < bar.rate <= 100 / 0.05
    assert "ETA ?" not in out.getvalue().splitlines()[-1]


def test_time_compiling_in_this_process_is_left_out_of_the_rate_and_said_apart():
    compiled = [0.0]
    out = io.StringIO()
    bar = Progress(2, 200, 0, 0, stream=out, every=0.0, compile_clock=lambda: compiled[0])
    time.sleep(0.3)
    compiled[0] = 0.25  # of the 0.3 s, 0.25 s went to compiling
    bar.update({"n": 100})
    assert 100 / 0.3 * 2 < bar.rate < 100 / 0.04  # the 0.05 s computing alone
    bar.close()
    last = out.getvalue().splitlines()[-1]
    assert "100 trajectories in 0.1 s" in last or "100 trajectories in 0.0 s" in last
    assert last.endswith(", and 0.2 s compiling the kernels") or last.endswith(
        ", and 0.3 s compiling the kernels"
    )


def test_without_compiling_the_rate_counts_every_tile():
    out = io.StringIO()
    bar = Progress(2, 200, 0, 0, stream=out, every=0.0)
    assert "compiling" not in out.getvalue()
    time.sleep(0.05)
    bar.update({"n": 100})
    assert bar.rate > 0.0
    resumed = Progress(2, 200, 2, 200, stream=io.StringIO(), compiling=True)
    assert "compiling" not in resumed.stream.getvalue()  # nothing left to compute


def test_a_tile_held_back_by_the_interval_is_shown_while_the_next_one_runs():
    out = io.StringIO()  # no terminal: a line every `every` seconds at most
    bar = Progress(3, 300, 0, 0, stream=out, every=0.2)
    bar.update({"n": 100})
    bar.update({"n": 100})  # written at once after the first: held back
    assert out.getvalue().splitlines()[-1].split("] ")[1].startswith("1/3 tiles")
    bar.tick()  # too soon: still held back
    assert len(out.getvalue().splitlines()) == 1
    time.sleep(0.25)
    bar.tick()  # the runner's wait for the third tile
    assert out.getvalue().splitlines()[-1].split("] ")[1].startswith("2/3 tiles")
    bar.tick()  # nothing new: no line
    assert len(out.getvalue().splitlines()) == 2


def test_the_runner_shows_every_tile_written_while_it_waits_for_the_next():
    from rattlesweep.sweep._execution.execute import run_tiles
    from sweep_helpers import small_sweep

    def compute(sweep, tile):
        time.sleep(0.8 if tile == 2 else 0.0)  # the last tile takes long
        return tile

    out = io.StringIO()
    bar = Progress(3, 300, 0, 0, stream=out, every=0.2)
    run_tiles(
        small_sweep(),
        [0, 1, 2],
        lambda tile: bar.update({"n": 100}),
        workers=1,
        compute=compute,
        on_wait=bar.tick,
    )
    lines = [line.split("] ")[1].split(" tiles")[0] for line in out.getvalue().splitlines()]
    # tile 1, written within 0.2 s of tile 0, is shown before tile 2 ends
    assert lines == ["1/3", "2/3", "3/3"]


def test_a_wait_for_long_tiles_after_ctrl_c_is_explained_and_a_short_one_is_not():
    """After a first Ctrl-C the tiles running finish, which for long launches took as
    long as they had left without a word: the wait looked like a hang."""
    import os
    import signal
    import threading

    import pytest

    from rattlesweep.sweep._execution import execute
    from sweep_helpers import small_sweep

    def interrupt_after(*delays):
        for delay in delays:
            threading.Timer(delay, os.kill, (os.getpid(), signal.SIGINT)).start()

    for seconds, expected in ((0.3, []), (execute.STOPPING_NOTE + 1.5, [1])):
        told = []
        interrupt_after(0.2) if seconds < 1 else interrupt_after(0.2, seconds - 0.5)
        with pytest.raises(KeyboardInterrupt):
            execute.run_tiles(
                small_sweep(),
                [0, 1, 2, 3],
                lambda result: None,
                workers=1,
                compute=lambda sweep, tile: time.sleep(seconds),
                on_stopping=told.append,
            )
        assert told == expected  # the one tile running; queued ones were dropped


def test_counts_read_as_english_and_a_resume_with_nothing_to_do_says_so():
    import io

    from rattlesweep.sweep._execution.progress import Progress

    out = io.StringIO()
    bar = Progress(1, 10, 1, 10, stream=out, enabled=True)
    bar.close()
    text = out.getvalue()
    assert "resuming: 1 of 1 tile already done" in text
    assert "0 tiles computed, 1 reused, nothing to compute" in text
    assert "traj/s" not in text
