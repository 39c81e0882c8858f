"""Sweeps and comparisons shared by the sweep tests."""

import math
import signal
import subprocess
import sys

import xarray as xr

from rattlesweep.sweep import Sweep

KILL_TOML = """\
name = "kill test"
tile_size = 256
[axes]
spin = { start = -20, stop = 20, num = 32 }
delta_deg = { start = -6, stop = 6, num = 64 }
[fixed]
t_end = 30.0
mu = 0.3
roll_deg = 0.5
"""
"""Eight tiles of about a second each on one core: long enough to act mid-sweep."""

MANY_TILES_TOML = """\
name = "many small tiles"
tile_size = 2
[axes]
spin = { start = -20, stop = 20, num = 30 }
delta_deg = { start = -6, stop = 6, num = 20 }
[fixed]
t_end = 0.05
mu = 0.3
roll_deg = 0.5
"""
"""300 tiles of 2 short launches: a tile is written every few milliseconds, so an
interrupt often lands in a write."""

REFINED_TOML = """\
name = "refined toy"
tile_size = 64
[axes]
spin = { start = -24, stop = 24, num = 9 }
delta_deg = { start = -8, stop = 8, num = 5 }
[fixed]
t_end = 3.0
roll_deg = 0.5
mu = 0.3
[refine]
levels = 2
"""
"""A refined sweep of toy semi-ellipsoids over 9 x 5 points, two levels finer."""


def small_sweep(**overrides) -> Sweep:
    """A few dozen short launches of toy semi-ellipsoids, a random roll per repeat."""
    args = dict(
        axes={
            "spin": {"start": -12.0, "stop": 12.0, "num": 4},
            "delta_deg": [-4.0, 3.0],
            "mu": [0.3, math.inf],
        },
        fixed={"t_end": 3.0, "damping": 1e-7},
        random={"roll_deg": {"uniform": [0.3, 0.8]}},
        repeats=2,
        seed=7,
        tile_size=5,
    )
    args.update(overrides)
    return Sweep(**args)


def as_zarr(sweep: Sweep) -> Sweep:
    return Sweep(**{**sweep.to_dict(), "output": "zarr"})


def without_history(ds: xr.Dataset) -> xr.Dataset:
    ds = ds.copy()
    ds.attrs.pop("history")
    return ds


def without_config(ds: xr.Dataset) -> xr.Dataset:
    """The dataset less the attributes that name the output format and the command."""
    ds = ds.copy()
    for key in ("history", "sweep_config", "sweep_config_hash"):
        ds.attrs.pop(key)
    return ds


def assert_same_file(path_a, path_b):
    with xr.open_dataset(path_a) as a, xr.open_dataset(path_b) as b:
        xr.testing.assert_identical(without_history(a.load()), without_history(b.load()))


def file_stats(root, pattern):
    """Inode and modification time of every file under ``root`` matching ``pattern``: a
    file rewritten gets a new inode (atomic writes) or a new time."""
    return {
        str(p.relative_to(root)): (p.stat().st_ino, p.stat().st_mtime_ns)
        for p in root.rglob(pattern)
        if p.is_file()
    }


def start_sweep(config, out, workers):
    """``rattlesweep sweep CONFIG --out OUT`` in a new process, its stderr piped, started
    as from a terminal: a parent that ignores SIGINT (a background job of a
    non-interactive shell, as CI may be) would pass SIG_IGN on, and Python keeps it."""
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "sweep",
            str(config),
            "--out",
            str(out),
            "--workers",
            str(workers),
        ],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
