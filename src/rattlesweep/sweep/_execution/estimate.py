"""What a sweep will cost, before it runs (``rattlesweep sweep CONFIG --dry-run``).

The time comes from a timed calibration: a sample of the grid's own points, spread evenly
over it, is run through the kernel on one thread exactly as a tile would run them (the
stop rule included) for a bounded number of steps each, so the calibration takes about a
second however long the launches are; the time per step is scaled by the steps every
launch takes (a launch that ended before its bound, at its first reversal or a capsize,
by the steps it took), then to the grid and the number of workers; the sweep layer's
own cost (starting, writing each tile) is added from figures measured on a 2-core
machine. The memory comes from sizes known before anything runs: the bytes of the result
variables per point, and the kernel's working set per launch in flight (about 830 bytes,
measured by ``benchmarks/bench_kernel.py``), on top of what this process holds now.
Nothing is written.
"""

from __future__ import annotations

import dataclasses
import resource
import time

import numpy as np

from ... import _results as results
from ... import _run as engine
from ..._options import check_method
from ...rattleback.batch import MODEL, prepare
from .._config.sizes import check_size, size_needs
from .._config.spec import Sweep
from .tiles import result_dtypes

__all__ = ["Estimate", "KERNEL_BYTES_PER_LAUNCH", "estimate", "format_estimate"]

# working set of one launch in flight in the kernel (state, stages, packed inputs):
# benchmarks/bench_kernel.py measured about 830 bytes per trajectory
KERNEL_BYTES_PER_LAUNCH = 830
# the sweep layer around the kernel, measured on a 2-core machine with tiny launches: about
# 0.3 s to start (the tile files' first write, the lock, the merge's setup) and 15 ms per
# tile (written by this process alone, one after another)
_START_SECONDS = 0.3
_TILE_SECONDS = 0.015
# calibration budget: this many trajectory-steps in all (each of at most _MAX_SAMPLE
# launches runs at most _SAMPLE_STEPS / _MAX_SAMPLE steps), and the kernels' loading run
# of one launch at most _WARM_STEPS steps
_SAMPLE_STEPS = 2e6
_MAX_SAMPLE = 64
_WARM_STEPS = 100


@dataclasses.dataclass(frozen=True)
class Estimate:
    """The expected cost of a sweep.

    ``points`` is the grid the first (or only) level simulates and ``tiles`` its tiles;
    ``finest_points`` the grid a refined sweep's result lies on (``points`` when not
    refined). ``seconds`` is the wall time expected for ``points`` on ``workers`` workers,
    ``finest_seconds`` that for every point of the finest grid (an upper bound for a
    refined sweep). ``sample`` launches ran ``sample_steps`` steps in all in
    ``sample_seconds`` on one thread, of the ``sample_full_steps`` they take in a sweep;
    the time is scaled by the ratio.
    ``result_bytes`` is the size of the results (on the finest grid), ``held_bytes``
    what the process holds of them and of its tiles' list (the figures a run checks
    against the memory available before it starts:
    :func:`~rattlesweep.sweep._config.sizes.size_needs`), ``in_flight_bytes`` the kernel's
    working set of the tiles running at once, ``process_bytes`` this process's size after
    the calibration and ``peak_bytes`` the sum: the peak resident memory expected.
    ``refused`` is the error a run would stop with now for want of memory, or None."""

    points: int
    tiles: int
    tile_size: int
    finest_points: int
    workers: int
    sample: int
    sample_seconds: float
    sample_steps: int
    sample_full_steps: int
    seconds: float
    finest_seconds: float
    result_bytes: int
    held_bytes: int
    in_flight_bytes: int
    process_bytes: int
    peak_bytes: int
    refused: str | None = None


def _process_bytes() -> int:
    # peak resident size so far (kB on Linux), the kernels loaded by the calibration
    # included
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def _calibrate(sweep: Sweep, index: np.ndarray, most: int) -> tuple[float, int, int]:
    """Run the points at flat indices ``index`` through the kernel on this thread, as
    :func:`~rattlesweep.sweep._execution.tiles.compute_points` does, each for at most
    ``most`` steps. Returns the seconds taken, the steps run and the steps the launches take
    in a sweep: a launch that ended before ``most`` (its stop rule, a capsize) takes the
    steps it ran, one stopped at ``most`` all of its own."""
    bodies, kwargs = sweep.points_at(index)
    prep = prepare(
        bodies, stop=sweep.stop, lyapunov=sweep.lyapunov, announce=False, **kwargs
    )
    bounded = dataclasses.replace(prep, nsteps=np.minimum(prep.nsteps, most))
    t0 = time.perf_counter()
    raw = engine.execute(
        bounded,
        method=check_method(sweep.method),
        record_every=None,
        band=sweep.reversal_band,
        parallel=False,
    )
    seconds = time.perf_counter() - t0
    ran = results.observables_dataset(MODEL, raw.observables, "point")["steps"].values
    ran = ran.astype(np.int64)
    own = prep.per_trajectory(prep.nsteps[:, None, :])[0]
    cut = bounded.per_trajectory(bounded.nsteps[:, None, :])[0]
    full = np.where(ran < cut, ran, own)
    return seconds, int(ran.sum()), int(full.sum())


def estimate(sweep: Sweep, workers: int) -> Estimate:
    """Time a sample of the sweep's points on one thread and size its results; see the
    module docstring. ``workers`` is the number of tasks running at once (>= 1)."""
    if not sweep.simulates:
        raise ValueError(
            "the sweep has no t_end, so it simulates nothing (it serves "
            "`rattlesweep stability` only)"
        )
    workers = max(1, int(workers))
    n = sweep.size
    _calibrate(sweep, np.zeros(1, dtype=np.int64), _WARM_STEPS)  # loads the kernels
    m = min(_MAX_SAMPLE, n)
    # capped: n - 1 above 2**53 rounds up to n as a float
    sample = np.unique(np.minimum(np.linspace(0, n - 1, m).astype(np.int64), n - 1))
    sample_seconds, run, full = _calibrate(sweep, sample, max(1, int(_SAMPLE_STEPS // m)))
    per_point = sample_seconds * (full / max(run, 1)) / len(sample)
    finest = sweep.finest()
    # a refined sweep's first level runs its declared points in runs of tile_size
    # (level_stages), not in the blocks of the grid a uniform sweep's tiles are
    tiles = -(-n // sweep.tile_size) if sweep.refine is not None else sweep.n_tiles
    # the points shared among the workers, but never less than one whole tile (a tile
    # runs on one worker)
    seconds = (
        per_point * max(n / workers, min(n, sweep.tile_size))
        + _START_SECONDS
        + _TILE_SECONDS * tiles
    )
    finest_seconds = per_point * finest.size / workers
    per_result = sum(np.dtype(d).itemsize for d in result_dtypes(sweep).values())
    result_bytes = per_result * finest.size
    process = _process_bytes()
    in_flight = KERNEL_BYTES_PER_LAUNCH * sweep.tile_size * min(workers, tiles)
    needs = size_needs(sweep)
    held = int(sum(need for _, _, need, _, _ in needs))
    refused = None
    try:
        check_size(sweep)
    except ValueError as exc:
        refused = str(exc)
    return Estimate(
        points=n,
        tiles=tiles,
        tile_size=sweep.tile_size,
        finest_points=finest.size,
        workers=workers,
        sample=len(sample),
        sample_seconds=sample_seconds,
        sample_steps=run,
        sample_full_steps=full,
        seconds=seconds,
        finest_seconds=finest_seconds,
        result_bytes=result_bytes,
        held_bytes=held,
        in_flight_bytes=in_flight,
        process_bytes=process,
        peak_bytes=process + in_flight + held,
        refused=refused,
    )


def _duration(seconds: float) -> str:
    if seconds < 1:
        return "under a second"
    if seconds < 60:
        return f"about {seconds:.2g} s" if seconds < 10 else f"about {seconds:.0f} s"
    if seconds < 3600:
        return f"about {seconds / 60:.1f} min"
    return f"about {seconds / 3600:.1f} h"


def _size(n: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} bytes"


def format_estimate(sweep: Sweep, e: Estimate, where: str) -> str:
    """The dry run's report, ``where`` naming the workers (``"2 local threads"``)."""
    dims = ", ".join(f"{d} ({k})" for d, k in zip(sweep.dims, sweep.shape))
    lines = [
        f"{sweep.name}: dry run, nothing written (only a few launches timed)",
        f"  dimensions: {dims}",
        f"  points: {e.points:,} in {e.tiles:,} tile{'s' if e.tiles > 1 else ''} of "
        f"at most {e.tile_size:,}",
    ]
    if sweep.refine is not None:
        fine = ", ".join(
            f"{d} ({k})" for d, k in zip(sweep.finest().dims, sweep.finest().shape)
        )
        lines.append(
            f"  refined {sweep.refine['levels']} levels to: {fine} = "
            f"{e.finest_points:,} points; each level simulates only the cells "
            "where the outcome changes (the demo: 9 % of its finest grid)"
        )
    stop = ", each launch stopped at its first reversal" if sweep.stop else ""
    bounded = (
        f" ({e.sample_steps:,} of their {e.sample_full_steps:,} steps, the time "
        "scaled by steps)"
        if e.sample_steps < e.sample_full_steps
        else ""
    )
    lines.append(
        f"  calibration: {e.sample} of its launches{bounded} took "
        f"{e.sample_seconds:.2f} s on one thread{stop}"
    )
    declared = " for the declared grid" if sweep.refine is not None else ""
    time_line = (
        f"  time: {_duration(e.seconds)}{declared} on {where}, once the kernels "
        "are compiled"
    )
    if sweep.refine is not None:
        time_line += (
            "; if every finer point were simulated, "
            f"{_duration(e.finest_seconds)} more at most"
        )
    lines.append(time_line)
    held = f", results held {_size(e.held_bytes)}" if e.held_bytes else ""
    lines.append(
        f"  memory: about {_size(e.peak_bytes)} at peak (this process "
        f"{_size(e.process_bytes)}, tiles in flight {_size(e.in_flight_bytes)}"
        f"{held})"
    )
    if e.refused:
        lines.append(f"  refused: a run would stop before it starts: {e.refused}")
    return "\n".join(lines)
