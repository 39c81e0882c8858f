"""Running a sweep: tiles on local threads or a dask.distributed cluster, results written
by this process only (workers send them back through dask), into a resumable output: a
directory of netCDF tiles merged into ``sweep.nc``
(:mod:`~rattlesweep.sweep.outputs.directory`) or a zarr store
(:mod:`~rattlesweep.sweep.outputs.zarr_store`)."""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Mapping

import xarray as xr

from ..._run import kernels_compiled
from ..outputs.directory import (
    CONFIG_NAME,
    RESULT_NAME,
    TILES_DIR,
    TileDirectory,
    read_config,
)
from .execute import run_tiles
from .progress import Progress
from ..config.spec import Sweep
from ..outputs.store import TileStore
from .tiles import TileResult

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "CONFIG_NAME",
    "RESULT_NAME",
    "TILES_DIR",
    "export",
    "open_output",
    "resume",
    "run_sweep",
    "stored_sweep",
]


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def open_output(
    sweep: Sweep,
    out: str | os.PathLike,
    *,
    command: str | None = None,
    storage_options: Mapping[str, Any] | None = None,
) -> TileStore[TileResult]:
    """The output ``sweep.output`` names, at ``out`` (not opened yet)."""
    if sweep.output == "zarr":
        from ..outputs.zarr_store import ZarrStore

        return ZarrStore(sweep, out, storage_options=storage_options, command=command)
    if storage_options or "://" in str(out):
        raise ValueError(
            f"output {out!r}: a netCDF sweep writes into a local directory; "
            'URLs and storage_options are for output = "zarr"'
        )
    return TileDirectory(sweep, out, command=command)


def run_sweep(
    sweep: Sweep,
    out: str | os.PathLike,
    *,
    client: Client | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    command: str | None = None,
    storage_options: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Run ``sweep`` into ``out`` and return the result.

    Each tile (a block of at most ``sweep.tile_size`` points) is one task running the
    kernel's single-threaded ``nogil`` entry, so tasks on different threads or workers
    run in parallel and numba never starts threads of its own inside them. By default
    tasks run on ``workers`` local threads (default: the usable cores). ``client`` (a
    ``distributed.Client``) or ``scheduler`` (the address of a running dask scheduler,
    e.g. ``"tcp://10.0.0.5:8786"``) sends them to that cluster instead; this function
    never starts a cluster. Workers return each tile's results through dask (about 120
    bytes per point) and this process writes them as they arrive, so the workers need
    no access to ``out``; a worker lost mid-sweep has its tiles recomputed elsewhere.

    The output is ``sweep.output``:

    - ``"netcdf"``: ``out`` is a directory holding ``sweep.toml``, a file per finished
      tile (``tiles/``) and the merged result ``sweep.nc`` (netCDF4, zlib), all written
      atomically. The merged dataset is returned.
    - ``"zarr"``: ``out`` is a zarr store, a local path or an fsspec URL
      (``storage_options`` are passed to fsspec), laid out before compute and filled
      tile by tile; a lazy dataset over it (``xarray.open_zarr``) is returned.

    A sweep with ``refine`` runs level by level
    (:mod:`~rattlesweep.sweep.refinement.run`) into a local directory and returns its
    result on the finest grid.

    Rerunning the same sweep into the same output computes only the tiles not written
    yet; a different sweep there is refused, and so is a second sweep while one runs
    (a lock in the output). Ctrl-C stops after the tiles in flight; what finished is
    kept. A failed write (disk full, no permission) raises
    :class:`~rattlesweep.SweepWriteError` and leaves what was written
    intact. ``command`` is recorded in the ``history`` attribute (default: the process's
    command line).
    """
    if not isinstance(sweep, Sweep):
        raise ValueError(f"sweep must be a rattlesweep.Sweep, got {type(sweep).__name__}")
    if not str(out).strip():
        raise ValueError(
            f"out must name a directory or a store, got {str(out)!r} (give "
            "'.' for the current directory)"
        )
    if not sweep.simulates:
        raise ValueError(
            "fixed.t_end: the end time (s) is required to simulate a sweep "
            "(fixed or as an axis)"
        )
    if client is not None and scheduler is not None:
        raise ValueError("give either client or scheduler, not both")
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if workers is not None and (client is not None or scheduler is not None):
        raise ValueError(
            "workers sets the local scheduler's threads; a distributed "
            "cluster's size is set where the cluster is started"
        )
    check_size(sweep)
    announce(sweep)
    if sweep.refine is not None:
        from ..refinement.run import run_refined

        if storage_options or "://" in str(out):
            raise ValueError(
                f"output {out!r}: a refined sweep writes into a local directory"
            )
        with _connect(scheduler) as own_client:
            return run_refined(
                sweep,
                out,
                client=client or own_client,
                workers=workers or _cores(),
                progress=progress,
                command=command,
            )
    store = open_output(sweep, out, command=command, storage_options=storage_options)
    todo = store.open()
    own_client = None
    try:
        left = set(todo)
        done = [t for t in range(sweep.n_tiles) if t not in left]
        bar = Progress(
            sweep.n_tiles,
            sweep.size,
            len(done),
            sum(_points(sweep, t) for t in done),
            enabled=progress,
            compiling=(
                client is None
                and scheduler is None
                and not kernels_compiled(parallel=False, level=sweep.friction_level)
            ),
        )
        for note in getattr(store, "notes", ()):
            bar.note(note)
        if scheduler is not None:
            client = own_client = _client(scheduler)

        def write(result: TileResult) -> None:
            store.write(result)
            bar.update(result.summary())

        try:
            run_tiles(
                sweep,
                todo,
                write,
                client=client,
                workers=workers or _cores(),
                on_wait=bar.tick,
            )
        except KeyboardInterrupt:
            bar.interrupted(store.location)
            raise
        bar.close()
        return store.finish()
    finally:
        if own_client is not None:
            own_client.close()
        store.close()


MERGED_BYTES = 3
"""Bytes held per byte of a point's results while a netCDF sweep merges its tiles (the
merged arrays, a tile read, the writer's buffers)."""
REFINED_BYTES = 1000
"""Bytes a refined sweep holds per point of its finest grid: every result, its inputs
and the ``computed`` flag (about 250 bytes), the level plans and the written dataset."""
TILE_BYTES = 200
"""Bytes held per tile: its done flag, its entry in the list of tiles to compute."""


def check_size(sweep: Sweep) -> None:
    """Refuse, before anything is written or computed, a sweep whose result would not
    fit in the memory available: a netCDF sweep merges the whole grid in memory, a
    refined one holds its finest grid, a zarr one a flag per tile."""
    from ..._validation import check_memory

    for need in size_needs(sweep):
        check_memory(*need)


def size_needs(sweep: Sweep) -> list[tuple[str, str, int, str, str]]:
    """What :func:`check_size` checks: ``(name, value, bytes, what, advice)`` for each
    part of the sweep held in memory at once (the arguments of ``check_memory``)."""
    from .tiles import result_dtypes

    per_point = sum(d.itemsize for d in result_dtypes(sweep).values())
    fine = sweep.finest().shape if sweep.refine is not None else None
    return _needs(sweep.refine, sweep.output, sweep.shape, sweep.n_tiles, per_point, fine)


def check_declared_size(config: Mapping[str, Any]) -> None:
    """Refuse a grid no run could hold, from the declared ``num`` of the axes of a
    normalised configuration: run before any axis's values are made, so that a grid of
    10^16 points is refused at once rather than after gigabytes of axis values. What
    only some runs need (a netCDF merge, a refined sweep's finest grid) is checked by
    :func:`check_size` when a run starts, and reported by a dry run."""
    from ..._validation import check_memory
    from ..config.corners import tile_block

    nums = {
        k: int(a["num"]) if "num" in a else len(a["values"])
        for k, a in config["axes"].items()
    }
    shape = tuple(nums.values()) + ((config["repeats"],) if config["random"] else ())
    points = math.prod(shape)
    declared = " × ".join(f"{k} (num = {n:,})" for k, n in nums.items())
    if len(shape) > len(nums):
        declared += f" × {shape[-1]:,} repeats"
    declared += f" = {points:,} points"
    if points > MAX_POINTS:
        raise ValueError(
            f"axes = {declared}: a sweep has at most 2**63 - 1 = {MAX_POINTS:,} points "
            "(its points are numbered by 64-bit integers); use fewer or shorter axes"
        )
    # every run holds its list of tiles; tiles hold 65536 points at most unless
    # tile_size says more (corners.choose_tile_size)
    block = tile_block(shape, config["tile_size"] or 65536)
    n_tiles = math.prod(-(-n // b) for n, b in zip(shape, block))
    ((name, _, need, what, advice),) = _needs(None, "zarr", shape, n_tiles, 0, None)
    check_memory(name, declared, need, what, advice)


MAX_POINTS = 2**63 - 1
"""The most points of a sweep's grid: flat point indices are 64-bit integers."""


def _needs(
    refine: Mapping[str, Any] | None,
    output: str,
    shape: tuple[int, ...],
    n_tiles: int,
    per_point: int,
    fine: tuple[int, ...] | None,
) -> list[tuple[str, str, int, str, str]]:
    if refine is not None and fine is not None:
        points = math.prod(fine)
        return [
            (
                "refine.levels",
                str(refine["levels"]),
                points * REFINED_BYTES,
                f"the finest grid {fine} ({points:,} points)",
                "refine fewer levels or fewer axes, or start from a coarser grid",
            )
        ]
    needs = [
        (
            "axes",
            f"grid {shape}",
            n_tiles * TILE_BYTES,
            f"the list of its {n_tiles:,} tiles",
            "a larger tile_size",
        )
    ]
    if output == "netcdf":
        size = math.prod(shape)
        needs.append(
            (
                "axes",
                f"grid {shape}",
                size * per_point * MERGED_BYTES,
                f"merging its {size:,} points into sweep.nc",
                'fewer points, or output = "zarr" (written tile by tile)',
            )
        )
    return needs


def announce(sweep: Sweep) -> None:
    """Warn (:class:`~rattlesweep.LongRunWarning`) before a sweep of more than
    :data:`~rattlesweep._steps.LONG_RUN_STEPS` steps at most, with the count. A refined
    sweep simulates an unknown part of its finest grid; its first level is counted."""
    import warnings

    from ..._steps import LONG_RUN_STEPS, LongRunWarning

    total = float(sweep.size) * sweep.max_steps
    if total > LONG_RUN_STEPS:
        warnings.warn(
            f"this sweep takes up to {total:.3g} steps ({sweep.size:,} launches, the "
            f"longest {sweep.max_steps:,} steps): at about 1e6 steps per second on a "
            f"core, up to {total / 1e6 / 60:.3g} core-minutes",
            LongRunWarning,
            stacklevel=3,
        )


def _client(scheduler: str) -> Client:
    """A dask.distributed client of the scheduler at ``scheduler``."""
    try:
        from distributed import Client
    except ImportError:
        raise ValueError(
            "scheduler needs dask.distributed: pip install 'rattlesweep[distributed]'"
        ) from None
    return Client(scheduler)


@contextlib.contextmanager
def _connect(scheduler: str | None) -> Iterator[Client | None]:
    """A client of ``scheduler`` for the duration (None without one)."""
    client = None if scheduler is None else _client(scheduler)
    try:
        yield client
    finally:
        if client is not None:
            client.close()


def _points(sweep: Sweep, tile: int) -> int:
    start, stop = sweep.tile_range(tile)
    return stop - start


def stored_sweep(
    out: str | os.PathLike, storage_options: Mapping[str, Any] | None = None
) -> Sweep:
    """The sweep whose results ``out`` (a sweep directory or zarr store) holds."""
    from ..outputs.zarr_store import is_zarr_store

    if is_zarr_store(out):
        from ..outputs.zarr_store import stored_sweep as from_store

        return from_store(str(out), storage_options)
    config = Path(out) / CONFIG_NAME
    if not config.exists():
        raise ValueError(
            f"{out} holds no sweep ({config} not found, and it is no zarr store)"
        )
    return read_config(config)


def resume(out: str | os.PathLike, **kwargs: Any) -> xr.Dataset:
    """Finish the sweep stored in ``out`` (a sweep directory or zarr store); keyword
    arguments as for :func:`run_sweep`."""
    return run_sweep(stored_sweep(out, kwargs.get("storage_options")), out, **kwargs)


def export(
    store: str | os.PathLike,
    out: str | os.PathLike,
    storage_options: Mapping[str, Any] | None = None,
) -> Path:
    """Write the finished zarr store ``store`` as one netCDF file ``out`` (the file a
    netCDF sweep writes as ``sweep.nc``)."""
    from ..outputs.zarr_store import export_netcdf

    return export_netcdf(str(store), out, storage_options)
