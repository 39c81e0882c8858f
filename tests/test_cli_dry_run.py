"""``rattlesweep sweep --dry-run`` says what a sweep will cost without computing or
writing it, and a zarr sweep runs without zarr's own warnings. Tiny sweeps."""

import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from rattlesweep import Sweep
from rattlesweep.cli import main
from rattlesweep.sweep._execution.estimate import estimate
from rattlesweep.sweep._config.sizes import MERGED_BYTES, TILE_BYTES

CONFIG = """\
name = "dry"
repeats = 2
seed = 3
[axes]
spin = { start = -6, stop = 6, num = 5 }
body = ["toy", "kane_levinson"]
[fixed]
t_end = 0.2
mu = 0.3
[random]
pitch_deg = { uniform = [-0.3, 0.3] }
"""


def test_dry_run_prints_points_tiles_time_and_memory_and_writes_nothing(tmp_path, capsys):
    config = tmp_path / "dry.toml"
    config.write_text(CONFIG.replace('name = "dry"', 'name = "dry"\ntile_size = 8'))
    out = tmp_path / "never"
    assert (
        main(["sweep", str(config), "--out", str(out), "--dry-run", "--workers", "2"]) == 0
    )
    text = capsys.readouterr().out
    assert not out.exists()
    assert "dry: dry run, nothing written (only a few launches timed)" in text
    assert "spin (5), body (2), repeat (2)" in text
    assert "points: 20 in 3 tiles of at most 8" in text
    assert "on 2 local threads" in text and "memory: about" in text
    assert "calibration: 20 of its launches took" in text


def test_dry_run_of_a_refined_sweep_names_the_finest_grid(tmp_path, capsys):
    config = tmp_path / "refined.toml"
    config.write_text(CONFIG + "[refine]\nlevels = 2\n")
    assert main(["sweep", str(config), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "refined 2 levels to: launch_spin (17), body (2), repeat (2) = 68 points" in text
    assert "for the declared grid" in text


def test_dry_run_counts_a_refined_sweeps_first_level_tiles_as_the_run_makes_them(
    tmp_path, capsys
):
    # it said "45 in 9 tiles" (the uniform grid's blocks) where level 0 ran 6
    config = tmp_path / "refined.toml"
    config.write_text(
        CONFIG.replace('name = "dry"', 'name = "dry"\ntile_size = 8').replace(
            'body = ["toy", "kane_levinson"]', "delta_deg = [-3.0, -1.0, 0.0, 2.0, 4.0]"
        )
        + '[refine]\nlevels = 1\naxes = ["spin"]\n'
    )
    assert main(["sweep", str(config), "--dry-run"]) == 0
    said = capsys.readouterr().out
    assert main(["sweep", str(config), "--out", str(tmp_path / "r"), "--quiet"]) == 0
    made = len(list((tmp_path / "r" / "levels" / "level-0").glob("tile-*.nc")))
    assert made == 7  # 50 points, 8 a tile
    assert f"points: 50 in {made} tiles of at most 8" in said, said


def test_a_sweep_without_out_or_dry_run_is_refused(tmp_path, capsys):
    config = tmp_path / "dry.toml"
    config.write_text(CONFIG)
    assert main(["sweep", str(config)]) == 2
    assert "--out is required" in capsys.readouterr().err


def test_estimate_adds_up():
    sweep = Sweep.from_toml(CONFIG)
    e = estimate(sweep, workers=2)
    assert (e.points, e.tiles, e.finest_points, e.workers) == (20, sweep.n_tiles, 20, 2)
    assert e.sample == 20 and e.sample_seconds > 0
    # one tile holds every point, so two workers cannot share them; the sweep layer's
    # start and the one tile's writing come on top
    assert e.seconds == pytest.approx(e.sample_seconds + 0.3 + 0.015)
    assert e.peak_bytes == e.process_bytes + e.in_flight_bytes + e.held_bytes
    # the figures a run checks before it starts: the tiles' list and, for a netCDF
    # output, the merged grid
    assert e.held_bytes == TILE_BYTES * e.tiles + MERGED_BYTES * e.result_bytes
    zarr = estimate(Sweep(**{**sweep.to_dict(), "output": "zarr"}), workers=2)
    assert zarr.held_bytes == TILE_BYTES * e.tiles  # a store is written tile by tile
    assert e.refused is None and zarr.refused is None


def test_zarr_output_is_quiet(tmp_path, capsys):
    pytest.importorskip("zarr")
    config = tmp_path / "z.toml"
    config.write_text(CONFIG)  # the body axis makes a fixed-length string coordinate
    store = tmp_path / "z.zarr"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert (
            main(["sweep", str(config), "--out", str(store), "--output", "zarr", "--quiet"])
            == 0
        )
        assert main(["info", str(store)]) == 0
        assert main(["export", str(store), str(tmp_path / "z.nc")]) == 0
    assert [str(w.message) for w in caught] == []
    assert "Warning" not in capsys.readouterr().err


LONG = """\
name = "long launches"
[axes]
spin = { start = -6, stop = 6, num = 8 }
[fixed]
t_end = 1.0
damping = 1e3
mu = 0.3
"""
"""Launches of about 3.6e9 steps each (damping = 1e3 shrinks the default step): hours of
kernel time, which a calibration running whole launches spent before answering."""


def test_calibration_of_hours_long_launches_runs_a_bounded_number_of_steps():
    from rattlesweep.sweep._execution import estimate as module

    sweep = Sweep.from_toml(LONG)
    e = estimate(sweep, workers=1)
    assert e.sample == 8
    assert 0 < e.sample_steps <= module._SAMPLE_STEPS
    # every launch takes the sweep's longest step count (dt is the same for all), and the
    # time is scaled from the steps run to those
    assert e.sample_full_steps == 8 * sweep.max_steps > 1e10
    assert e.seconds == pytest.approx(
        e.sample_seconds * e.sample_full_steps / e.sample_steps + 0.3 + 0.015
    )


def test_dry_run_of_hours_long_launches_answers_and_says_it_scaled(tmp_path):
    config = tmp_path / "long.toml"
    config.write_text(LONG)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "sweep",
            str(config),
            "--dry-run",
            "--workers",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "of their 29,042,876,064 steps, the time scaled by steps" in done.stdout
    assert "time: about" in done.stdout and "on 1 local thread" in done.stdout


def _catches_sigint(pid):
    """Whether process ``pid`` has a handler of its own for SIGINT (Linux's /proc): a
    Python interpreter installs it early in its start, before any import of a module of
    the command."""
    status = Path(f"/proc/{pid}/status").read_text()
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGINT - 1)))


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux's /proc")
def test_ctrl_c_at_any_instant_of_a_dry_run_exits_130_with_one_line(tmp_path):
    """From the command's imports (numpy, numba, scipy, xarray: the first second) to the
    calibration's kernel calls: status 130 and 'rattlesweep: interrupted', never a
    traceback or a hang. (Before the command's code runs, in the interpreter's own start
    and the import of its standard library and of the light package, about 0.1 s, a
    Ctrl-C is Python's to handle.)"""
    config = tmp_path / "long.toml"
    config.write_text(LONG.replace("num = 8", "num = 64"))
    statuses = []
    for delay in (0.25, 0.5, 0.8, 1.2):
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rattlesweep.cli",
                "sweep",
                str(config),
                "--dry-run",
                "--workers",
                "1",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        while not _catches_sigint(proc.pid):
            time.sleep(0.002)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)  # hours, had the calibration no bound
        statuses.append(proc.returncode)
        assert proc.returncode in (0, 130, -signal.SIGINT), (delay, err)
        if proc.returncode == 130:
            assert err == "rattlesweep: interrupted\n" and out == ""
        else:  # it had finished already: the signal came in the interpreter's shutdown,
            # which ends by SIGINT (a shell's status 130 too)
            assert "memory: about" in out and "Traceback" not in err
    assert 130 in statuses
