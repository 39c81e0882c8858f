"""Running a sweep: tiles as dask tasks on the local threaded scheduler or a
dask.distributed cluster, resumable output directories, the merged netCDF file.

An output directory holds ``sweep.toml`` (the configuration), ``tiles/tile-NNNNNN.nc``
(one file per finished tile, written atomically) and ``sweep.nc`` (the merged result).
Workers of a distributed cluster write tile files themselves, so the directory must be on
a filesystem they share with the client (always true for a LocalCluster).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import dask
import xarray as xr
from dask.callbacks import Callback

from ..io import write_netcdf
from .merge import merge_tiles
from .progress import Progress
from .spec import Sweep
from .tiles import CANCEL, compute_tile, tile_is_valid, tile_path

__all__ = ["CONFIG_NAME", "RESULT_NAME", "TILES_DIR", "prepare_directory", "resume",
           "run_sweep", "stored_sweep"]

CONFIG_NAME = "sweep.toml"
RESULT_NAME = "sweep.nc"
TILES_DIR = "tiles"


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _write_text_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def prepare_directory(sweep: Sweep, out_dir: Path) -> list[int]:
    """Create or check ``out_dir`` for ``sweep``; return the tiles still to compute.

    A directory holding a different configuration is refused with a list of what changed;
    leftover temporary files are removed; truncated, corrupt or foreign tile files are
    deleted so they are recomputed.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    config = out_dir / CONFIG_NAME
    if config.exists():
        try:
            stored = Sweep.from_toml(config)
        except ValueError as exc:
            raise ValueError(f"{config} exists but is not a valid sweep configuration "
                             f"({exc}); use another directory") from None
        if stored != sweep:
            changes = "; ".join(stored.differences(sweep))
            raise ValueError(f"{out_dir} holds a different sweep (stored -> new: {changes}); "
                             f"resume it unchanged with `rattlesweep resume {out_dir}`, or "
                             f"use a new directory")
    else:
        _write_text_atomic(config, sweep.to_toml())
    tiles_dir = out_dir / TILES_DIR
    tiles_dir.mkdir(exist_ok=True)
    for stale in tiles_dir.glob(".*.tmp"):
        stale.unlink(missing_ok=True)
    todo = []
    for tile in range(sweep.n_tiles):
        path = tile_path(tiles_dir, tile)
        if not path.exists():
            todo.append(tile)
        elif not tile_is_valid(path, sweep, tile):
            path.unlink()
            todo.append(tile)
    return todo


class _LocalProgress(Callback):
    def __init__(self, progress: Progress) -> None:
        super().__init__()
        self.progress = progress

    def _posttask(self, key, result, dsk, state, worker_id) -> None:
        if isinstance(result, dict) and "tile" in result:
            self.progress.update(result)


def _tasks(sweep: Sweep, todo: list[int], tiles_dir: Path) -> list:
    # the sweep goes into the graph once, shared by every tile task and not traversed
    shared = dask.delayed(sweep, traverse=False, name=f"rattlesweep-config-"
                          f"{sweep.config_hash()[:12]}")
    task = dask.delayed(compute_tile, pure=False)
    return [task(shared, t, str(tiles_dir), dask_key_name=f"rattlesweep-tile-{t}")
            for t in todo]


def _run_local(tasks: list, workers: int, progress: Progress) -> None:
    with _LocalProgress(progress):
        dask.compute(*tasks, scheduler="threads", num_workers=workers)


def _run_distributed(tasks: list, client: Any, progress: Progress) -> None:
    from distributed import as_completed

    futures = client.compute(tasks)
    try:
        for future in as_completed(futures):
            progress.update(future.result())
    except BaseException:
        client.cancel(futures)
        raise


def run_sweep(sweep: Sweep, out_dir: str | os.PathLike, *, client: Any = None,
              scheduler: str | None = None, workers: int | None = None,
              progress: bool = True, command: str | None = None) -> xr.Dataset:
    """Run ``sweep`` into ``out_dir`` and return the merged result.

    Each tile of ``sweep.tile_size`` points is one dask task running the kernel's
    single-threaded ``nogil`` entry, so tasks on different threads or workers run in
    parallel and numba never starts threads of its own inside them. By default tasks run
    on the local threaded scheduler with ``workers`` threads (default: the usable cores).
    ``client`` (a ``distributed.Client``) or ``scheduler`` (the address of a running
    dask scheduler, e.g. ``"tcp://10.0.0.5:8786"``) sends them to that cluster instead;
    this function never starts a cluster.

    Rerunning the same sweep into the same directory computes only missing or damaged
    tiles; a different sweep there is refused. Ctrl-C stops after the tiles in flight;
    what finished is kept. The merged file is ``out_dir/sweep.nc`` (netCDF4, zlib),
    written atomically; ``command`` is recorded in its ``history`` attribute (default:
    the process's command line).
    """
    if not isinstance(sweep, Sweep):
        raise ValueError(f"sweep must be a rattlesweep.Sweep, got {type(sweep).__name__}")
    if not sweep.simulates:
        raise ValueError("fixed.t_end: the end time (s) is required to simulate a sweep "
                         "(fixed or as an axis)")
    if client is not None and scheduler is not None:
        raise ValueError("give either client or scheduler, not both")
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if workers is not None and (client is not None or scheduler is not None):
        raise ValueError("workers sets the local scheduler's threads; a distributed "
                         "cluster's size is set where the cluster is started")
    out = Path(out_dir)
    todo = prepare_directory(sweep, out)
    tiles_dir = out / TILES_DIR
    done = sweep.n_tiles - len(todo)
    done_points = sum(sweep.tile_range(t)[1] - sweep.tile_range(t)[0]
                      for t in set(range(sweep.n_tiles)) - set(todo))
    bar = Progress(sweep.n_tiles, sweep.size, done, done_points, enabled=progress)
    own_client = None
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise ValueError("scheduler needs dask.distributed: pip install "
                             "'rattlesweep[distributed]'") from None
        client = own_client = Client(scheduler)
    CANCEL.clear()
    try:
        if todo:
            tasks = _tasks(sweep, todo, tiles_dir)
            if client is None:
                _run_local(tasks, workers or _cores(), bar)
            else:
                _run_distributed(tasks, client, bar)
    except KeyboardInterrupt:
        CANCEL.set()
        bar.close("interrupted")
        if progress:
            print(f"stopped; finished tiles are kept. Continue with: rattlesweep resume "
                  f"{out}", file=sys.stderr)
        raise
    finally:
        if own_client is not None:
            own_client.close()
    bar.close()
    ds = merge_tiles(sweep, tiles_dir, command=command)
    write_netcdf(ds, out / RESULT_NAME)
    return ds


def stored_sweep(out_dir: str | os.PathLike) -> Sweep:
    """The sweep whose results ``out_dir`` holds (its ``sweep.toml``)."""
    config = Path(out_dir) / CONFIG_NAME
    if not config.exists():
        raise ValueError(f"{out_dir} holds no sweep ({config} not found)")
    return Sweep.from_toml(config)


def resume(out_dir: str | os.PathLike, **kwargs) -> xr.Dataset:
    """Finish the sweep stored in ``out_dir`` (its ``sweep.toml``); keyword arguments as
    for :func:`run_sweep`."""
    return run_sweep(stored_sweep(out_dir), out_dir, **kwargs)
