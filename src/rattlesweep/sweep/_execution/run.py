"""Running a sweep: tiles on local threads or a dask.distributed cluster, results written
by this process only (workers send them back through dask), into a resumable output: a
directory of netCDF tiles merged into ``sweep.nc``
(:mod:`~rattlesweep.sweep._outputs.directory`) or a zarr store
(:mod:`~rattlesweep.sweep._outputs.zarr_store`)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import xarray as xr

from ..._run import kernels_compiled
from .._outputs.directory import (
    CONFIG_NAME,
    RESULT_NAME,
    TILES_DIR,
    TileDirectory,
    read_config,
)
from .._config.sizes import check_size
from .execute import run_tiles
from .progress import Progress
from .._config.spec import Sweep
from .._outputs.store import SweepInterrupted, TileStore
from .stage import Stage

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
) -> TileStore[Any]:
    """The output of ``sweep`` at ``out`` (not opened yet): a refined sweep's directory of
    levels, or the output ``sweep.output`` names."""
    local = not storage_options and "://" not in str(out)
    if sweep.refine is not None:
        from .._outputs.refined import RefinedDirectory

        if not local:
            raise ValueError(
                f"output {out!r}: a refined sweep writes into a local directory"
            )
        return RefinedDirectory(sweep, out, command=command)
    if sweep.output == "zarr":
        from .._outputs.zarr_store import ZarrStore

        return ZarrStore(sweep, out, storage_options=storage_options, command=command)
    if not local:
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
    (:mod:`~rattlesweep.sweep._refinement.stages`) into a local directory and returns its
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
    store = open_output(sweep, out, command=command, storage_options=storage_options)
    own_client = None
    try:  # open inside: an interrupt just after it still releases the lock
        store.open()
        if scheduler is not None:
            client = own_client = _client(scheduler)
        notes = list(getattr(store, "notes", ()))
        for stage in store.stages():
            _run_stage(stage, store, client, workers or _cores(), progress, notes)
            notes = []
        return store.finish()
    finally:
        if own_client is not None:
            own_client.close()
        store.close()


def _run_stage(
    stage: Stage,
    store: TileStore[Any],
    client: Client | None,
    workers: int,
    progress: bool,
    notes: list[str],
) -> None:
    """Run the tasks of one stage on the workers or the cluster, writing each result into
    ``store`` as it arrives, with a progress bar (``notes`` shown on it first). Ctrl-C
    ends the stage once the tiles in flight are written, and says where the output is."""
    bar = Progress(
        stage.tiles,
        stage.points,
        stage.tiles_done,
        stage.points_done,
        enabled=progress,
        compiling=(
            client is not None and not kernels_compiled(level=stage.sweep.friction_level)
        ),
    )
    for note in notes:
        bar.note(note)

    def write(result: Any) -> None:
        store.write(result)
        bar.update(result.summary())

    try:
        run_tiles(
            stage.sweep,
            stage.todo,
            write,
            client=client,
            workers=workers,
            compute=stage.compute,
            on_wait=bar.tick,
            on_stopping=lambda running: bar.note(
                f"stopping: no tile is started; the {running} running finish and are "
                "written (Ctrl-C again stops at once, without them)"
            ),
        )
    except KeyboardInterrupt:
        bar.interrupted()
        raise SweepInterrupted(
            bar.done_tiles,
            bar.total_tiles,
            store.location,
            f" of {stage.label}" if stage.label else "",
        ) from None
    bar.close(stage.label)


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


def stored_sweep(
    out: str | os.PathLike, storage_options: Mapping[str, Any] | None = None
) -> Sweep:
    """The sweep whose results ``out`` (a sweep directory or zarr store) holds."""
    from .._outputs.zarr_store import is_zarr_store

    if is_zarr_store(out):
        from .._outputs.zarr_store import stored_sweep as from_store

        return from_store(str(out), storage_options)
    config = Path(out) / CONFIG_NAME
    if not Path(out).exists():
        raise ValueError(f"{out} does not exist")
    if not Path(out).is_dir():
        raise ValueError(
            f"{out} is a file: expected a sweep directory (or its {RESULT_NAME}) or a "
            "zarr store"
        )
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
    from .._outputs.zarr_export import export_netcdf
    from .._outputs.zarr_store import is_zarr_store

    if not is_zarr_store(store) and (Path(store) / CONFIG_NAME).is_file():
        raise ValueError(
            f"{store} is a netCDF sweep's directory, not a zarr store: its result is "
            f"{Path(store) / RESULT_NAME} already"
        )
    return export_netcdf(str(store), out, storage_options)
