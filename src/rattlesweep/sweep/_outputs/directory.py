"""The netCDF output of a sweep: a directory holding ``sweep.toml`` (the configuration),
``tiles/tile-NNNNNN.nc`` (one file per finished tile, written atomically) and
``sweep.nc`` (the tiles merged, written when every tile is there)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterator

import netCDF4
import numpy as np
import xarray as xr

from ...io import (
    DIGEST_SUFFIX,
    NETCDF_LOCK,
    stale_temporaries,
    unreadable_files,
    write_netcdf,
    write_text_atomic,
)
from .._execution.lock import LOCK_NAME, SweepLock
from .merge import merge_arrays
from .._config.spec import Sweep
from .store import write_failure
from .._execution.stage import Stage, uniform_stage
from .._execution.tiles import TileResult, result_names, variable_attrs

__all__ = [
    "CONFIG_NAME",
    "RESULT_NAME",
    "SweepDirectory",
    "TILES_DIR",
    "TileDirectory",
    "read_config",
    "read_tile",
    "tile_path",
    "tile_state",
]

CONFIG_NAME = "sweep.toml"
RESULT_NAME = "sweep.nc"
TILES_DIR = "tiles"


def _refuse_dangling(path: Path) -> None:
    """A symbolic link at ``path`` to nothing is named, with where it points: a
    directory cannot be made there, and "[Errno 17] File exists" says nothing."""
    if path.is_symlink() and not path.exists():
        raise ValueError(
            f"{path} is a symbolic link to {os.readlink(path)}, which does not exist: "
            "create that directory, remove the link, or give another path"
        )


def tile_path(tiles_dir: Path, tile: int) -> Path:
    return Path(tiles_dir) / f"tile-{tile:06d}.nc"


def read_config(path: Path) -> Sweep:
    """The sweep a directory's ``sweep.toml`` holds; a ValueError that names the file and
    says what to do when it cannot be read or is no valid configuration."""
    try:
        return Sweep.from_toml(path)
    except ValueError as exc:
        raise ValueError(
            f"{path} is not a valid sweep configuration ({exc}). It holds the "
            "configuration the sweep in this directory was started with: "
            "restore it, or start the sweep in a new directory"
        ) from None


def tile_state(path: Path, sweep: Sweep, tile: int, *, checked: bool = False) -> str:
    """ "valid" for a complete tile file of this sweep, "foreign" for a complete tile of
    another configuration, "damaged" for anything unreadable (truncated, corrupt) or
    differing from the digest recorded when it was written. Checked first, unless
    ``checked`` says the caller did (:func:`~rattlesweep.io.unreadable_files`): damaged
    HDF5 metadata can crash the netCDF library."""
    start, stop = sweep.tile_range(tile)
    if not checked and unreadable_files([path]):
        return "damaged"
    try:
        with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
            if nc.getncattr("config_hash") != sweep.config_hash():
                return "foreign"
            if int(nc.getncattr("tile")) != tile:
                return "damaged"
            for name in (*result_names(sweep), "point"):
                var = nc.variables[name]
                if var.shape != (stop - start,):
                    return "damaged"
                var[:]  # read the data: a truncated file fails here
            return "valid" if nc.variables["point"][0] == start else "damaged"
    except Exception:  # any failure to read means: recompute
        return "damaged"


def read_tile(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The named variables of a tile file as plain arrays."""
    with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        return {name: nc.variables[name][:] for name in names}


def tile_dataset(sweep: Sweep, result: TileResult) -> xr.Dataset:
    """A tile's results as the Dataset of its file, over ``point`` (flat indices)."""
    ds = xr.Dataset(
        {k: ("point", v, variable_attrs(sweep, k)) for k, v in result.data.items()},
        coords={"point": np.arange(result.start, result.stop, dtype=np.int64)},
    )
    ds.attrs.update(
        {
            "config_hash": sweep.config_hash(),
            "tile": result.tile,
            "start": result.start,
            "stop": result.stop,
        }
    )
    return ds


class SweepDirectory:
    """What every output directory of ``sweep`` in ``out_dir`` does: check the path and
    the configuration, hold the lock, write files atomically. Subclasses say which tile
    files it holds (:meth:`_prepare`), write them and finish the result."""

    def __init__(
        self, sweep: Sweep, out_dir: str | os.PathLike[str], *, command: str | None = None
    ) -> None:
        self.sweep = sweep
        self.command = command
        self.out = Path(out_dir)
        self.location = str(self.out)
        self.tiles_dir = self.out / TILES_DIR
        # inside the directory's real path (a symlink to it leads to the same lock, and
        # a refusal names the real path)
        self.lock = SweepLock(self.out.resolve() / LOCK_NAME)
        self.written = 0
        self.notes: list[str] = []
        self.todo: list[int] = []

    def open(self) -> list[int]:
        """Create or check the directory for the sweep and take its lock; return the tiles
        still to compute.

        A directory holding a different configuration is refused with a list of what
        changed, and so is one whose tiles belong to another configuration (a
        ``sweep.toml`` edited after they were written); leftover temporary files are
        removed; truncated or corrupt tile files are deleted so they are recomputed.
        """
        self._check_path()
        self.out.mkdir(parents=True, exist_ok=True)
        self.lock.acquire()
        try:
            self.todo = self._prepare()
            return self.todo
        except BaseException:
            self.lock.release()
            raise

    def stages(self) -> Iterator[Stage]:
        """One stage: the tiles :meth:`open` found still to compute."""
        yield uniform_stage(self.sweep, self.todo)

    def _check_path(self) -> None:
        """Refuse an output path that is no directory, a zarr store, or a directory
        holding files of no sweep (one without ``sweep.toml`` holding anything else than
        what a sweep writes): nothing is written into it, not even the lock."""
        from .zarr_store import is_zarr_store

        _refuse_dangling(self.out)
        if self.out.exists() and not self.out.is_dir():
            raise ValueError(
                f"output {self.out} exists and is not a directory: a netCDF "
                "sweep writes a directory (sweep.toml, tiles/, sweep.nc); "
                "give a new path or an earlier sweep's directory"
            )
        if is_zarr_store(self.out):
            raise ValueError(
                f"output {self.out} is a zarr store: a netCDF sweep writes a "
                "directory of its own (resume the store with `rattlesweep "
                f"resume {self.out}`, or give a new path)"
            )
        if self.out.is_dir() and not (self.out / CONFIG_NAME).exists():
            others = sorted(
                p.name + "/" * p.is_dir()
                for p in self.out.iterdir()
                if not self._own(p.name)
            )
            if others:
                many = len(others) > 1
                raise ValueError(
                    f"output {self.out} holds {len(others)} other "
                    f"file{'s' if many else ''} ({'the first: ' if many else ''}"
                    f"{others[0]}) and no {CONFIG_NAME}, so it is no sweep's directory: a "
                    f"netCDF sweep writes only into a directory of its own ({CONFIG_NAME}, "
                    f"{TILES_DIR}/, {RESULT_NAME}). Give a new or empty directory"
                )

    def _own(self, name: str) -> bool:
        """Whether ``name`` in the output directory is one a sweep writes."""
        return name in (
            CONFIG_NAME,
            RESULT_NAME,
            RESULT_NAME + DIGEST_SUFFIX,
            TILES_DIR,
            self.tiles_dir.name,
        ) or name.startswith((LOCK_NAME, f".{CONFIG_NAME}.", f".{RESULT_NAME}."))

    def _check_unclaimed(self) -> None:
        """In a directory without a configuration file, refuse to touch results this
        sweep cannot be shown to have written: a merged file of another configuration
        (or unreadable), or any tile file."""
        result = self.out / RESULT_NAME
        if result.exists():
            try:
                if unreadable_files([result]):
                    raise ValueError("damaged")
                with NETCDF_LOCK, netCDF4.Dataset(result) as nc:
                    ours = nc.getncattr("sweep_config_hash") == self.sweep.config_hash()
            except Exception:  # unreadable, or no rattlesweep result
                ours = False
            if not ours:
                raise ValueError(
                    f"{self.out} holds {RESULT_NAME} but no {CONFIG_NAME}, and that file "
                    "is not this sweep's result (another configuration, or unreadable): "
                    "not overwriting it. Move it away, or use a new directory"
                )
        if self.tiles_dir.is_dir():
            files = sorted(p for p in self.tiles_dir.rglob("*") if p.is_file())
            if files:
                raise ValueError(
                    f"{self.tiles_dir} holds {len(files)} files (the first: "
                    f"{files[0].name}) "
                    f"but {self.out} has no {CONFIG_NAME}, so they cannot be shown to be "
                    "this sweep's: not touching them. Restore the configuration, or use a "
                    "new directory"
                )

    def _check_config(self) -> Path:
        """Refuse a directory that holds another sweep's configuration, or results of
        unknown origin; return the path of the configuration file."""
        sweep, out = self.sweep, self.out
        config = out / CONFIG_NAME
        if not config.exists():
            self._check_unclaimed()
        if config.exists():
            stored = read_config(config)
            if stored != sweep:
                changes = "; ".join(stored.differences(sweep))
                raise ValueError(
                    f"{out} holds a different sweep (stored -> new: {changes}); "
                    f"resume it unchanged with `rattlesweep resume {out}`, or "
                    f"use a new directory"
                )
        return config

    def make_tiles_dir(self) -> None:
        """Create the directory of the tile files; a ValueError naming the path when
        something else is in its way."""
        _refuse_dangling(self.tiles_dir)
        if self.tiles_dir.exists() and not self.tiles_dir.is_dir():
            raise ValueError(
                f"{self.tiles_dir} is in the way: a sweep keeps its tile files "
                f"in a directory there, and {self.tiles_dir} is a file. Move it "
                "away, or give a new directory"
            )
        self.tiles_dir.mkdir(exist_ok=True)

    def check_digests_in_way(self) -> None:
        """Refuse, before anything is removed, a directory where a file's digest
        (``NAME.b2sum``) is something else than a file: writing it would fail after
        the tile it belongs to is computed, naming the tile."""
        found = (
            self.out / (RESULT_NAME + DIGEST_SUFFIX),
            *self.tiles_dir.rglob("*" + DIGEST_SUFFIX),
        )
        for path in found:
            if (path.exists() or path.is_symlink()) and not path.is_file():
                raise ValueError(
                    f"{path} is in the way: a sweep keeps the digest of "
                    f"{path.name.removesuffix(DIGEST_SUFFIX)} in a file there, and "
                    f"{path} is {'a directory' if path.is_dir() else 'no regular file'}. "
                    "Move it away, then resume"
                )

    def _prepare(self) -> list[int]:
        """With the lock held: check and prepare the directory, return the tiles still to
        compute."""
        raise NotImplementedError

    def _write_file(self, ds: xr.Dataset, path: Path) -> None:
        """Write ``ds`` to ``path`` atomically; a failure is a SweepWriteError that names
        the file, the cause and how to resume."""
        try:
            path.parent.mkdir(exist_ok=True)
            write_netcdf(ds, path, digest=True)
        except (
            OSError,
            RuntimeError,
        ) as exc:  # netCDF4 reports HDF5 failures as RuntimeError
            raise write_failure(
                path, exc, self.written, f"rattlesweep resume {self.out}"
            ) from exc

    def close(self) -> None:
        self.lock.release()


class TileDirectory(SweepDirectory):
    """The netCDF output of ``sweep`` in ``out_dir`` (see the module's description)."""

    def _prepare(self) -> list[int]:
        sweep = self.sweep
        config = self._check_config()
        self.make_tiles_dir()
        self.check_digests_in_way()
        # temporary files of a process killed while writing a tile or the merge of this
        # sweep (a directory without sweep.toml holds none of its files); the lock is
        # held, so no other process writes them now
        if config.exists():
            for stale in (
                *stale_temporaries(self.tiles_dir, "tile-*.nc"),
                *stale_temporaries(self.out, RESULT_NAME),
            ):
                stale.unlink(missing_ok=True)
        todo, damaged, foreign = [], [], []
        paths = [tile_path(self.tiles_dir, tile) for tile in range(sweep.n_tiles)]
        unread = unreadable_files([p for p in paths if p.exists()])
        for tile, path in enumerate(paths):
            if not path.exists():
                state = "missing"
            elif path in unread:
                state = "damaged"
            else:
                state = tile_state(path, sweep, tile, checked=True)
            if state != "valid":
                todo.append(tile)
            if state == "damaged":
                damaged.append(path)
            elif state == "foreign":
                foreign.append(path)
        if foreign:
            raise ValueError(
                f"{self.tiles_dir} holds {len(foreign)} tiles of another configuration "
                f"(the first: {foreign[0].name}), so {config.name} does not describe them: "
                "was it edited, or the directory used by another version of rattlesweep? "
                "Restore the configuration, or use a new directory"
            )
        for path in damaged:
            path.unlink()
        if damaged:
            self.notes.append(
                f"{len(damaged)} tile files in {self.tiles_dir} were damaged "
                f"(the first: {damaged[0].name}); recomputing them"
            )
        if not config.exists():
            write_text_atomic(config, sweep.to_toml())
        self.written = sweep.n_tiles - len(todo)
        return todo

    def write(self, result: TileResult) -> None:
        self._write_file(
            tile_dataset(self.sweep, result), tile_path(self.tiles_dir, result.tile)
        )
        self.written += 1

    def finish(self) -> xr.Dataset:
        """Merge the tiles into ``sweep.nc`` (written atomically) and return it."""
        names = result_names(self.sweep)
        ds = merge_arrays(self.sweep, self._tile_arrays(names), command=self.command)
        self._write_file(ds, self.out / RESULT_NAME)
        return ds

    def _tile_arrays(
        self, names: tuple[str, ...]
    ) -> Iterator[tuple[tuple[int, int], dict[str, np.ndarray]]]:
        for tile in range(self.sweep.n_tiles):
            yield (
                self.sweep.tile_range(tile),
                read_tile(tile_path(self.tiles_dir, tile), names),
            )
