"""The zarr output of a sweep: one store, laid out before anything is computed and filled
tile by tile.

The store is an xarray dataset over the sweep's dimensions (coordinates, CF attributes,
the configuration and versions as global attributes) whose chunks are the sweep's tiles
(:attr:`~rattlesweep.sweep.Sweep.tile_shape`), so each finished tile is written into
its own chunks and nothing is merged at the end. A point not computed yet reads as NaN
(-1 for integers), with ``status`` and ``outcome`` equal to
:data:`~rattlesweep.sweep._execution.tiles.NOT_COMPUTED`; ``status`` is written after the
point's other variables, so ``xarray.open_zarr`` on a store being written shows every point
either complete or flagged. The group ``rattlesweep`` holds ``tile_done``, one byte per
tile set after the tile's data: a resume reads from it which tiles are complete.

Every chunk carries a CRC-32C checksum (zarr's ``crc32c`` codec, after ``zstd``) and every
chunk of a finished tile is stored, even one holding only fill values, so a tile is
verified (:func:`check_tiles`) by finding each of its chunks and decoding it: a chunk
deleted, truncated or changed is found, and ``resume`` recomputes its tile, while
``export`` and ``rattlesweep verify`` name it.

The location is a local path or any fsspec URL (``s3://bucket/run.zarr``, with
``storage_options`` for credentials). Only local stores are locked against a second
sweep (:mod:`~rattlesweep.sweep._execution.lock`; the lock file ``STORE.lock`` lies beside
the store).

zarr is an optional dependency (``pip install 'rattlesweep[zarr]'``), imported here only.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import warnings
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Iterator, Mapping

import numpy as np
import xarray as xr

from .._execution.lock import SweepLock
from .digest import feed, finish, tile_digest
from .zarr_flags import DIGEST_ARRAY, DONE_ARRAY, damage, keys, read_by_chunk, tile_key
from .zarr_flags import digests as stored_digests
from .merge import grid_coords, result_attrs
from .._config.spec import Sweep
from .store import write_failure
from .._execution.stage import Stage, uniform_stage
from .._execution.tiles import NOT_COMPUTED, TileResult, result_dtypes, variable_attrs

if TYPE_CHECKING:
    from zarr import Group
    from zarr.abc.store import Store

__all__ = [
    "DIGEST_ARRAY",
    "DONE_ARRAY",
    "ZarrStore",
    "check_coords",
    "check_tiles",
    "is_zarr_store",
    "damage_report",
    "every_tile_done",
    "open_result",
    "stored_sweep",
    "tile_digest",
    "tiles_done",
]

"""A digest of each tile's values, written before its done flag: a chunk's checksum
covers its bytes, not where it lies, so a chunk copied over another tile's passes it."""
_DONE_CHUNK = 4096
MOVED = "a chunk copied from another tile's place?"


def _zarr() -> ModuleType:
    try:
        import zarr
    except ImportError:
        raise ValueError(
            "a zarr output needs the zarr package: pip install 'rattlesweep[zarr]'"
        ) from None
    return zarr


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Silence zarr's warning that fixed-length unicode (the body-name coordinates) has no
    zarr format 3 specification yet: xarray reads such stores back, and the warning,
    raised on zarr's own I/O thread at every write and read of the metadata, told a user
    nothing they could act on. The filter list is process-wide, so it also covers that
    thread while this one waits for it."""
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", message=r"The data type \(FixedLengthUTF32", category=FutureWarning
        )
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


def _codecs() -> dict[str, Any]:
    """The chunk encoding of every array: zstd, then a CRC-32C checksum of the bytes."""
    from zarr.codecs import Crc32cCodec, ZstdCodec

    return {"compressors": (ZstdCodec(), Crc32cCodec())}


def _checksummed(array: Any) -> bool:
    """True for an array written with checksums and every chunk stored (what this
    module writes now; stores of rattlesweep 0.x before it have neither)."""
    return any(type(c).__name__ == "Crc32cCodec" for c in array.metadata.codecs)


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    if text and "checksum" in text[0]:
        return "it fails its CRC-32C checksum"
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def check_tiles(
    location: str,
    sweep: Sweep,
    tiles: Any = None,
    storage_options: Mapping[str, Any] | None = None,
) -> dict[int, str]:
    """What is wrong with each of the ``tiles`` (default: all) of the store, by tile:
    a chunk missing, a chunk that fails its checksum or cannot be decoded, points whose
    ``status`` says not computed, or values not those of the tile's digest (a chunk
    moved). Tiles not named are sound. Reads every chunk of the tiles."""
    group: Any = _group(location, storage_options)
    tiles = range(sweep.n_tiles) if tiles is None else [int(t) for t in tiles]
    problems: dict[int, str] = {}
    digests, unchecked = stored_digests(group, sweep.n_tiles) if tiles else (None, set())
    hashes: dict[int, Any] = {}  # each tile's digest, fed variable by variable
    for name, dtype in result_dtypes(sweep).items():
        try:
            array: Any = group[name]
        except KeyError:
            return {t: f"array {name} missing" for t in tiles}
        except Exception as exc:
            raise ValueError(
                f"{location}: the metadata of array {name} cannot be read "
                f"({_first_line(exc)}); the store cannot be checked or "
                "resumed: restore it, or run the sweep into a new store"
            ) from None
        # a store written before checksums left out the chunks holding only fill
        # values; status is never all fill in a computed tile, so its chunks are there
        complete = _checksummed(array) or name == "status"
        stored = keys(group, f"{name}/")
        for tile in tiles:
            if tile in problems:
                continue
            region = sweep.tile_region(tile)
            key = tile_key(array, sweep, tile)
            if key not in stored:
                if complete:
                    problems[tile] = f"chunk {key} missing"
                continue
            try:
                read = array[region]
            except Exception as exc:  # a failed checksum, zstd or a short read
                problems[tile] = f"chunk {key} damaged ({_first_line(exc)})"
                continue
            if name == "status" and (np.asarray(read) == NOT_COMPUTED).any():
                problems[tile] = f"chunk {key} holds points not computed"
            if digests is not None:
                if tile in unchecked or not digests[tile]:
                    problems[tile] = (
                        f"its digest ({DIGEST_ARRAY}) is damaged or missing: its values "
                        "cannot be checked"
                    )
                    continue
                feed(hashes.setdefault(tile, hashlib.blake2b(digest_size=8)), read, dtype)
    for tile, h in hashes.items():
        assert digests is not None  # hashes are fed only where there are digests
        if tile not in problems and finish(h) != int(digests[tile]):
            problems[tile] = f"its values are not those written ({MOVED})"
    return problems


def metadata_damage(
    location: str, sweep: Sweep, storage_options: Mapping[str, Any] | None = None
) -> list[str]:
    """What is wrong with the store's integrity metadata (the done flags and the
    digests, :mod:`.zarr_flags`), in plain statements; empty when sound."""
    return damage(_group(location, storage_options), sweep)


def check_coords(
    location: str, sweep: Sweep, storage_options: Mapping[str, Any] | None = None
) -> list[str]:
    """What is wrong with the store's coordinates (the axes' values, the fixed values):
    each is read in full and compared with what the sweep's configuration gives, so that
    a damaged coordinate chunk, checksummed or not, is found rather than exported."""
    from .merge import grid_coords

    group = _group(location, storage_options)
    problems = []
    for name, (_, want, _) in grid_coords(sweep).items():
        try:
            array: Any = group[name]
            have = np.asarray(array[...])
        except KeyError:
            problems.append(f"coordinate {name} missing")
            continue
        except Exception as exc:  # a failed checksum, zstd or a short read
            problems.append(f"coordinate {name} damaged ({_first_line(exc)})")
            continue
        want = np.asarray(want)
        same = have.shape == want.shape and (
            np.array_equal(have, want)
            if want.dtype.kind in "OUS"
            else np.array_equal(have.astype(float), want.astype(float), equal_nan=True)
        )
        if not same:
            problems.append(f"coordinate {name} differs from the sweep's configuration")
    return problems


def write_coords(
    location: str, sweep: Sweep, storage_options: Mapping[str, Any] | None = None
) -> None:
    """Write the store's coordinates again from the sweep's configuration."""
    from .merge import grid_coords

    group = _group(location, storage_options, "r+")
    for name, (_, values, _) in grid_coords(sweep).items():
        array: Any = group[name]
        array[...] = values


def _consolidate(location: str, options: Mapping[str, Any] | None) -> None:
    # consolidated metadata lets open_zarr read the layout in one request; zarr warns
    # that format 3 does not standardise it yet, which does not matter to xarray
    with _quiet(), warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", message="Consolidated metadata", category=UserWarning
        )
        _zarr().consolidate_metadata(_store(location, options))


def stored_sweep(location: str, storage_options: Mapping[str, Any] | None = None) -> Sweep:
    """The sweep whose results the store at ``location`` holds; ValueError when it is no
    rattlesweep store or its configuration cannot be read."""
    try:
        group = _group(location, storage_options)
    except (FileNotFoundError, KeyError, ValueError) as exc:
        raise ValueError(f"{location} is not a zarr store ({exc})") from None
    except Exception as exc:  # the store's own errors: credentials, network, permissions
        raise ValueError(f"cannot open {location}: {_first_line(exc)}") from None
    text = group.attrs.get("sweep_config")
    if not isinstance(text, str):
        raise ValueError(
            f"{location} is a zarr store without a sweep configuration "
            "(attribute sweep_config): not written by rattlesweep"
        )
    try:
        return Sweep.from_toml(text)
    except ValueError as exc:
        raise ValueError(
            f"{location}: its sweep_config attribute is not a valid sweep "
            f"configuration ({exc})"
        ) from None


def tiles_done(
    location: str, n_tiles: int, storage_options: Mapping[str, Any] | None = None
) -> np.ndarray | None:
    """Which tiles of the store are complete (bool per tile), None when the store's
    layout was never finished."""
    group: Any = _group(location, storage_options)
    try:
        # Any: zarr types a member as an array or a group; this is the array _layout made
        done: Any = group[DONE_ARRAY]
    except KeyError:
        return None
    if done.shape != (n_tiles,):
        return None
    values, unreadable, _ = read_by_chunk(done, keys(group, f"{DONE_ARRAY}/"))
    flags = values.astype(bool)
    for a, b in unreadable:  # a damaged chunk of flags: its tiles are checked instead
        flags[a:b] = True
    return flags


def every_tile_done(
    location: str, storage_options: Mapping[str, Any] | None = None
) -> bool:
    """Whether the store at ``location`` holds every tile of its sweep (each tile's done
    flag set, the flags read cleanly): nothing is left to compute. False when it cannot
    tell."""
    try:
        with _quiet(), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # zarr's, on reading the metadata
            n_tiles = stored_sweep(location, storage_options).n_tiles
            done: Any = _group(location, storage_options)[DONE_ARRAY]
            return done.shape == (n_tiles,) and bool(done[:].all())
    except Exception:  # no store, another one, a damaged flag: not known to be done
        return False


class ZarrStore:
    """The zarr output of ``sweep`` at ``location`` (see the module's description)."""

    def __init__(
        self,
        sweep: Sweep,
        location: str | os.PathLike,
        *,
        storage_options: Mapping[str, Any] | None = None,
        command: str | None = None,
    ) -> None:
        _zarr()
        self.sweep = sweep
        self.command = command
        self.location = str(location)
        self.options = dict(storage_options) if storage_options else None
        self.lock = None
        if _is_local(self.location):
            # beside the store's real path: a symlink to a store being written leads
            # to the same lock
            root = _local_path(self.location).resolve()
            self.lock = SweepLock(root.with_name(root.name + ".lock"))
        # the root group once open; Any, as zarr types its members as arrays or groups and
        # these are the arrays _layout made
        self.group: Any = None
        self.written = 0
        self.arrays: dict[str, Any] = {}
        self.notes: list[str] = []
        self.todo: list[int] = []

    def open(self) -> list[int]:
        """Lay the store out, or check that it holds this sweep; take its lock; return the
        tiles still to compute."""
        if self.lock is not None:
            self.lock.path.parent.mkdir(parents=True, exist_ok=True)
            self.lock.acquire()
        try:
            self.todo = self._prepare()
            return self.todo
        except BaseException:
            self.close()
            raise

    def stages(self) -> Iterator[Stage]:
        """One stage: the tiles :meth:`open` found still to compute."""
        yield uniform_stage(self.sweep, self.todo)

    def _prepare(self) -> list[int]:
        sweep = self.sweep
        done = None
        if self._exists():
            stored = stored_sweep(self.location, self.options)
            if stored != sweep:
                changes = "; ".join(stored.differences(sweep))
                raise ValueError(
                    f"{self.location} holds a different sweep (stored -> new: "
                    f"{changes}); resume it unchanged with `rattlesweep resume "
                    f"{self.location}`, or use a new store"
                )
            done = tiles_done(self.location, sweep.n_tiles, self.options)
            damaged = (
                [] if done is None else metadata_damage(self.location, sweep, self.options)
            )
        if done is None:
            try:
                self._layout()
            except OSError as exc:
                raise write_failure(
                    f"the layout of {self.location}",
                    exc,
                    0,
                    f"rattlesweep resume {self.location}",
                ) from exc
            done = np.zeros(sweep.n_tiles, dtype=bool)
        else:
            done = self._verify(done, rewrite=bool(damaged))
            if damaged:
                self.notes.append(
                    f"{self.location}: {'; '.join(damaged)}; its tiles were checked "
                    "and the flags written again"
                )
            coords = check_coords(self.location, sweep, self.options)
            if coords:
                write_coords(self.location, sweep, self.options)
                self.notes.append(
                    f"{self.location}: {'; '.join(coords)}; written again "
                    "from the configuration"
                )
        self.group = _group(self.location, self.options, "r+")
        # every chunk is stored, even all fill values: a missing chunk is then a loss
        self.arrays = {
            name: self.group[name].with_config({"write_empty_chunks": True})
            for name in result_dtypes(sweep)
        }
        self.written = int(done.sum())
        return [int(t) for t in np.flatnonzero(~done)]

    def _verify(self, done: np.ndarray, rewrite: bool = False) -> np.ndarray:
        """The tiles flagged done whose chunks are all there and sound; the others are
        flagged not done (to be recomputed) and noted. With ``rewrite`` (the flags
        were damaged), every flag is written again."""
        bad = check_tiles(self.location, self.sweep, np.flatnonzero(done), self.options)
        if bad or rewrite:
            group = _group(self.location, self.options, "r+")
            if rewrite and DIGEST_ARRAY in group:
                # a tile's digest is written into its chunk, which must be readable
                array: Any = group[DIGEST_ARRAY]
                _, unreadable, _ = read_by_chunk(array, keys(group, f"{DIGEST_ARRAY}/"))
                for a, b in unreadable:
                    array[a:b] = 0
            flags: Any = group[DONE_ARRAY]
            for tile in bad:
                done[tile] = False
            flags[:] = np.where(done, 1, 0).astype("uint8")
        if bad:
            first = min(bad)
            self.notes.append(
                f"{len(bad)} tiles of {self.location} are damaged or missing "
                f"(tile {first}: {bad[first]}); recomputing them"
            )
        return done

    def _exists(self) -> bool:
        """True for a zarr store at the location; False where there is nothing, and a
        ValueError where something else is there, or a store whose root metadata cannot
        be read (laying out the store would delete it)."""
        if _is_local(self.location):
            root = _local_path(self.location)
            if not is_zarr_store(root):
                if root.exists() and (not root.is_dir() or any(root.iterdir())):
                    raise ValueError(
                        f"{root} exists and is not a zarr store; a zarr "
                        "output needs a new path (or a store it wrote)"
                    )
                return False
        try:
            _group(self.location, self.options)
        except FileNotFoundError:
            if _is_local(self.location) or not self._holds_objects():
                return False
            raise ValueError(
                f"{self.location} holds objects but no zarr store; a zarr "
                "output needs a new location (or a store it wrote)"
            ) from None
        except Exception as exc:
            raise ValueError(
                f"{self.location} holds a zarr store whose root metadata "
                f"cannot be read ({_first_line(exc)}): not overwriting it. "
                "Restore it, or use a new location"
            ) from None
        return True

    def _holds_objects(self) -> bool:
        """True when anything is stored under the (remote) location."""
        from zarr.core.sync import sync

        store = _store(self.location, self.options)

        async def first() -> bool:
            async for _ in store.list():
                return True
            return False

        return bool(sync(first()))

    def _layout(self) -> None:
        import dask.array

        sweep = self.sweep
        chunks = sweep.tile_shape
        data, encoding = {}, {}
        for name, dtype in result_dtypes(sweep).items():
            data[name] = (
                sweep.dims,
                dask.array.empty(sweep.shape, dtype=dtype, chunks=chunks),
                variable_attrs(sweep, name),
            )
            encoding[name] = {
                "chunks": chunks,
                "fill_value": _fill(dtype, name),
                **_codecs(),
            }
        template = xr.Dataset(
            data, coords=grid_coords(sweep), attrs=result_attrs(sweep, self.command)
        )
        with _quiet():
            template.to_zarr(
                _store(self.location, self.options),
                mode="w",
                compute=False,
                encoding=encoding,
                consolidated=False,
                zarr_format=3,
            )
        group = _group(self.location, self.options, "r+")
        for name, kind in ((DONE_ARRAY, "uint8"), (DIGEST_ARRAY, "uint64")):
            group.create_array(
                name,
                shape=(sweep.n_tiles,),
                dtype=kind,
                chunks=(min(sweep.n_tiles, _DONE_CHUNK),),
                fill_value=0,
                **_codecs(),
            )
        _consolidate(self.location, self.options)

    def write(self, result: TileResult) -> None:
        """Write a tile into its region: every variable but ``status``, then ``status``,
        then the tile's done flag, so a crash between them leaves the tile to redo."""
        region = self.sweep.tile_region(result.tile)
        block = tuple(r.stop - r.start for r in region)
        try:
            for name in (*(n for n in result.data if n != "status"), "status"):
                self.arrays[name][region] = result.data[name].reshape(block)
            if DIGEST_ARRAY in self.group:  # not in a store written before digests
                digest = tile_digest(self.sweep, result.data)
                self.group[DIGEST_ARRAY][result.tile] = digest
            self.group[DONE_ARRAY][result.tile] = 1
        except OSError as exc:
            raise write_failure(
                f"tile {result.tile} to {self.location}",
                exc,
                self.written,
                f"rattlesweep resume {self.location}",
            ) from exc
        self.written += 1

    def finish(self) -> xr.Dataset:
        """The finished store as a lazy (dask-backed) dataset."""
        _consolidate(self.location, self.options)
        return open_result(self.location, self.options)

    def close(self) -> None:
        if self.lock is not None:
            self.lock.release()


def open_result(
    location: str, storage_options: Mapping[str, Any] | None = None
) -> xr.Dataset:
    """A sweep's zarr store as a lazy dataset (``xarray.open_zarr``)."""
    with _quiet():
        return xr.open_zarr(_store(location, storage_options))


def damage_report(bad: Mapping[int, str], n_tiles: int, most: int = 5) -> str:
    """``bad`` (tile -> problem) in a sentence naming the first ``most`` tiles."""
    shown = "; ".join(f"tile {t}: {bad[t]}" for t in sorted(bad)[:most])
    more = f"; and {len(bad) - most} more" if len(bad) > most else ""
    return f"{len(bad)} of {n_tiles} tiles are missing or damaged ({shown}{more})"
