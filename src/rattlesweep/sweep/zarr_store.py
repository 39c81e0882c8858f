"""The zarr output of a sweep: one store, laid out before anything is computed and filled
tile by tile.

The store is an xarray dataset over the sweep's dimensions (coordinates, CF attributes,
the configuration and versions as global attributes) whose chunks are the sweep's tiles
(:attr:`~rattlesweep.sweep.Sweep.tile_shape`), so each finished tile is written into
its own chunks and nothing is merged at the end. A point not computed yet reads as NaN
(-1 for integers), with ``status`` and ``outcome`` equal to
:data:`~rattlesweep.sweep.tiles.NOT_COMPUTED`; ``status`` is written after the point's
other variables, so ``xarray.open_zarr`` on a store being written shows every point
either complete or flagged. The group ``rattlesweep`` holds ``tile_done``, one byte per
tile set after the tile's data: a resume reads from it which tiles are complete.

The location is a local path or any fsspec URL (``s3://bucket/run.zarr``, with
``storage_options`` for credentials). Only local stores are locked against a second
sweep (:mod:`.lock`; the lock file ``STORE.lock`` lies beside the store).

zarr is an optional dependency (``pip install 'rattlesweep[zarr]'``), imported here only.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Iterator, Mapping

import numpy as np
import xarray as xr

from .lock import SweepLock
from .merge import grid_coords, result_attrs
from .spec import Sweep
from .store import write_failure
from .tiles import NOT_COMPUTED, TileResult, result_dtypes, variable_attrs

if TYPE_CHECKING:
    from zarr import Group
    from zarr.abc.store import Store

__all__ = ["DONE_ARRAY", "ZarrStore", "export_netcdf", "is_zarr_store", "open_result",
           "stored_sweep", "tiles_done"]

DONE_ARRAY = "rattlesweep/tile_done"
_DONE_CHUNK = 4096


def _zarr() -> ModuleType:
    try:
        import zarr
    except ImportError:
        raise ValueError("a zarr output needs the zarr package: pip install "
                         "'rattlesweep[zarr]'") from None
    return zarr


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Silence zarr's warning that fixed-length unicode (the body-name coordinates) has no
    zarr format 3 specification yet: xarray reads such stores back, and the warning,
    raised on zarr's own I/O thread at every write and read of the metadata, told a user
    nothing they could act on. The filter list is process-wide, so it also covers that
    thread while this one waits for it."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"The data type \(FixedLengthUTF32",
                                category=FutureWarning)
        yield


def _is_local(location: str) -> bool:
    return "://" not in location or location.startswith("file://")


def _local_path(location: str) -> Path:
    return Path(location.removeprefix("file://"))


def is_zarr_store(location: str | os.PathLike) -> bool:
    """True when ``location`` is an existing zarr store (local paths are checked for the
    store's root metadata; a URL is taken to be one)."""
    location = str(location)
    if not _is_local(location):
        return True
    root = _local_path(location)
    return (root / "zarr.json").is_file() or (root / ".zgroup").is_file()


def _fill(dtype: np.dtype, name: str) -> float:
    if name in ("status", "outcome"):
        return NOT_COMPUTED
    return np.nan if dtype.kind == "f" else -1


def _store(location: str, options: Mapping[str, Any] | None) -> Store:
    """The zarr store object for a local path or an fsspec URL."""
    zarr = _zarr()
    if _is_local(location):
        return zarr.storage.LocalStore(_local_path(location))
    return zarr.storage.FsspecStore.from_url(location, storage_options=dict(options or {}))


def _group(location: str, options: Mapping[str, Any] | None, mode: str = "r") -> Group:
    """The store's root group, read from the metadata as it is now (not the
    consolidated copy); FileNotFoundError when there is none."""
    return _zarr().open_group(_store(location, options), mode=mode, use_consolidated=False)


def _consolidate(location: str, options: Mapping[str, Any] | None) -> None:
    # consolidated metadata lets open_zarr read the layout in one request; zarr warns
    # that format 3 does not standardise it yet, which does not matter to xarray
    with _quiet(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Consolidated metadata",
                                category=UserWarning)
        _zarr().consolidate_metadata(_store(location, options))


def stored_sweep(location: str, storage_options: Mapping[str, Any] | None = None
                 ) -> Sweep:
    """The sweep whose results the store at ``location`` holds; ValueError when it is no
    rattlesweep store or its configuration cannot be read."""
    try:
        group = _group(location, storage_options)
    except (FileNotFoundError, KeyError, ValueError) as exc:
        raise ValueError(f"{location} is not a zarr store ({exc})") from None
    text = group.attrs.get("sweep_config")
    if not isinstance(text, str):
        raise ValueError(f"{location} is a zarr store without a sweep configuration "
                         "(attribute sweep_config): not written by rattlesweep")
    try:
        return Sweep.from_toml(text)
    except ValueError as exc:
        raise ValueError(f"{location}: its sweep_config attribute is not a valid sweep "
                         f"configuration ({exc})") from None


def tiles_done(location: str, n_tiles: int,
               storage_options: Mapping[str, Any] | None = None) -> np.ndarray | None:
    """Which tiles of the store are complete (bool per tile), None when the store's
    layout was never finished."""
    try:
        # Any: zarr types a member as an array or a group; this is the array _layout made
        done: Any = _group(location, storage_options)[DONE_ARRAY]
    except KeyError:
        return None
    if done.shape != (n_tiles,):
        return None
    return done[:].astype(bool)


class ZarrStore:
    """The zarr output of ``sweep`` at ``location`` (see the module's description)."""

    def __init__(self, sweep: Sweep, location: str | os.PathLike, *,
                 storage_options: Mapping[str, Any] | None = None,
                 command: str | None = None) -> None:
        _zarr()
        self.sweep = sweep
        self.command = command
        self.location = str(location)
        self.options = dict(storage_options) if storage_options else None
        self.lock = None
        if _is_local(self.location):
            root = _local_path(self.location)
            self.lock = SweepLock(root.with_name(root.name + ".lock"))
        # the root group once open; Any, as zarr types its members as arrays or groups and
        # these are the arrays _layout made
        self.group: Any = None
        self.written = 0

    def open(self) -> list[int]:
        """Lay the store out, or check that it holds this sweep; take its lock; return the
        tiles still to compute."""
        if self.lock is not None:
            self.lock.path.parent.mkdir(parents=True, exist_ok=True)
            self.lock.acquire()
        try:
            return self._prepare()
        except BaseException:
            self.close()
            raise

    def _prepare(self) -> list[int]:
        sweep = self.sweep
        done = None
        if self._exists():
            stored = stored_sweep(self.location, self.options)
            if stored != sweep:
                changes = "; ".join(stored.differences(sweep))
                raise ValueError(f"{self.location} holds a different sweep (stored -> new: "
                                 f"{changes}); resume it unchanged with `rattlesweep resume "
                                 f"{self.location}`, or use a new store")
            done = tiles_done(self.location, sweep.n_tiles, self.options)
        if done is None:
            try:
                self._layout()
            except OSError as exc:
                raise write_failure(f"the layout of {self.location}", exc, 0,
                                    f"rattlesweep resume {self.location}") from exc
            done = np.zeros(sweep.n_tiles, dtype=bool)
        self.group = _group(self.location, self.options, "r+")
        self.written = int(done.sum())
        return [int(t) for t in np.flatnonzero(~done)]

    def _exists(self) -> bool:
        """True for a zarr store at the location; False where there is nothing, and a
        ValueError where something else is there (laying out the store would delete
        it)."""
        if _is_local(self.location):
            root = _local_path(self.location)
            if not is_zarr_store(root):
                if root.exists() and (not root.is_dir() or any(root.iterdir())):
                    raise ValueError(f"{root} exists and is not a zarr store; a zarr "
                                     "output needs a new path (or a store it wrote)")
                return False
        try:
            _group(self.location, self.options)
        except (FileNotFoundError, KeyError, ValueError):
            return False
        return True

    def _layout(self) -> None:
        import dask.array

        sweep = self.sweep
        chunks = sweep.tile_shape
        data, encoding = {}, {}
        for name, dtype in result_dtypes(sweep).items():
            data[name] = (sweep.dims, dask.array.empty(sweep.shape, dtype=dtype, chunks=chunks),
                          variable_attrs(sweep, name))
            encoding[name] = {"chunks": chunks, "fill_value": _fill(dtype, name)}
        template = xr.Dataset(data, coords=grid_coords(sweep),
                              attrs=result_attrs(sweep, self.command))
        with _quiet():
            template.to_zarr(_store(self.location, self.options), mode="w", compute=False,
                             encoding=encoding, consolidated=False, zarr_format=3)
        _group(self.location, self.options, "r+").create_array(DONE_ARRAY, shape=(sweep.n_tiles,), dtype="uint8",
                           chunks=(min(sweep.n_tiles, _DONE_CHUNK),), fill_value=0)
        _consolidate(self.location, self.options)

    def write(self, result: TileResult) -> None:
        """Write a tile into its region: every variable but ``status``, then ``status``,
        then the tile's done flag, so a crash between them leaves the tile to redo."""
        region = self.sweep.tile_region(result.tile)
        block = tuple(r.stop - r.start for r in region)
        try:
            for name in (*(n for n in result.data if n != "status"), "status"):
                self.group[name][region] = result.data[name].reshape(block)
            self.group[DONE_ARRAY][result.tile] = 1
        except OSError as exc:
            raise write_failure(f"tile {result.tile} to {self.location}", exc, self.written,
                                f"rattlesweep resume {self.location}") from exc
        self.written += 1

    def finish(self) -> xr.Dataset:
        """The finished store as a lazy (dask-backed) dataset."""
        _consolidate(self.location, self.options)
        return open_result(self.location, self.options)

    def close(self) -> None:
        if self.lock is not None:
            self.lock.release()


def open_result(location: str, storage_options: Mapping[str, Any] | None = None
                ) -> xr.Dataset:
    """A sweep's zarr store as a lazy dataset (``xarray.open_zarr``)."""
    with _quiet():
        return xr.open_zarr(_store(location, storage_options))


def export_netcdf(location: str, out: str | os.PathLike,
                  storage_options: Mapping[str, Any] | None = None) -> Path:
    """Write a finished store as one netCDF file (what a netCDF sweep writes as
    ``sweep.nc``), atomically, reading one tile at a time. An unfinished store is
    refused."""
    import dask

    from ..io import write_netcdf

    sweep = stored_sweep(location, storage_options)
    done = tiles_done(location, sweep.n_tiles, storage_options)
    if done is None or not done.all():
        missing = sweep.n_tiles if done is None else int((~done).sum())
        raise ValueError(f"{location} is unfinished ({missing} of {sweep.n_tiles} tiles "
                         f"not computed); complete it with `rattlesweep resume {location}`")
    ds = open_result(location, storage_options)
    for var in ds.variables.values():
        var.encoding = {}
    with dask.config.set(scheduler="synchronous"):
        return write_netcdf(ds, out)

