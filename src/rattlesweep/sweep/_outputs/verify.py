"""Verifying a sweep's output without changing it: every tile of a netCDF directory or a
zarr store read back and checked, and the merged ``sweep.nc`` read in full."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

__all__ = ["Verification", "finish_advice", "verify", "writer"]


@dataclass(frozen=True)
class Verification:
    """What :func:`verify` found: the output's ``location``, its number of tiles, the
    tiles without a file or done flag (``missing``), the tiles found damaged (tile ->
    what is wrong, in the order of the tiles) and other problems (the merged file).
    ``finished`` says that the sweep had finished (its merged file was written), so a
    tile in ``missing`` was lost rather than not computed yet. A tile is its number, or
    for a refined sweep "N of level K"."""

    location: str
    n_tiles: int
    missing: tuple[int | str, ...]
    damaged: Mapping[int | str, str]
    problems: tuple[str, ...] = ()
    finished: bool = False

    @property
    def ok(self) -> bool:
        """True when every tile is there and sound and nothing else is wrong."""
        return not (self.missing or self.damaged or self.problems)

    def report(self) -> str:
        """A few lines for the user."""
        sound = self.n_tiles - len(self.missing) - len(self.damaged)
        lines = [f"{self.location}: {sound} of {_tiles(self.n_tiles)} verified"]
        if self.missing:
            what = (
                "missing (deleted after the sweep finished)"
                if self.finished
                else "not computed yet"
            )
            first = "" if len(self.missing) == 1 else "the first: "
            lines.append(
                f"  {what}: {_tiles(len(self.missing))} ({first}tile {self.missing[0]})"
            )
        for tile in list(self.damaged)[:10]:
            lines.append(f"  damaged: tile {tile}: {self.damaged[tile]}")
        if len(self.damaged) > 10:
            lines.append(f"  damaged: {_tiles(len(self.damaged) - 10)} more")
        lines.extend(f"  {p}" for p in self.problems)
        if not self.ok:
            resume = f"`rattlesweep resume {self.location}` recomputes what is "
            lines.append("  " + finish_advice(self.location, resume + "missing or damaged"))
        return "\n".join(lines)


def writer(out: str | os.PathLike) -> str | None:
    """Who is writing the local sweep output ``out`` now (the process that holds its
    lock, as :meth:`~rattlesweep.sweep._execution.lock.SweepLock.in_use` says); None
    when no sweep is, or ``out`` is a URL (an object store has no lock)."""
    from .._execution.lock import LOCK_NAME, SweepLock
    from .zarr_store import is_zarr_store

    location = str(out)
    if "://" in location and not location.startswith("file://"):
        return None
    root = Path(location.removeprefix("file://")).resolve()
    lock = root.with_name(root.name + ".lock") if is_zarr_store(out) else root / LOCK_NAME
    return SweepLock(lock).in_use()


def finish_advice(out: str | os.PathLike, resume: str | None = None) -> str:
    """How an unfinished output gets finished: by the sweep writing it now, else as
    ``resume`` says (by default: ``rattlesweep resume OUT`` completes it)."""
    writing = writer(out)
    if writing:
        return f"a sweep is writing it now: {writing}"
    return resume or f"`rattlesweep resume {out}` completes it"


def _tiles(n: int) -> str:
    return f"{n} tile{'' if n == 1 else 's'}"


def verify(
    out: str | os.PathLike, storage_options: Mapping[str, Any] | None = None
) -> Verification:
    """Read back every tile of the sweep output ``out`` (a sweep directory or a zarr
    store, local or a URL) and say what is missing or damaged. Writes nothing; a
    ValueError when ``out`` holds no sweep."""
    from .._execution.run import stored_sweep
    from .zarr_store import is_zarr_store

    sweep = stored_sweep(out, storage_options)
    if is_zarr_store(out):
        return _verify_zarr(str(out), sweep, storage_options)
    return _verify_directory(Path(out), sweep)


def _verify_zarr(
    location: str, sweep: Any, options: Mapping[str, Any] | None
) -> Verification:
    import numpy as np

    from .zarr_store import check_coords, check_tiles, metadata_damage, tiles_done

    done = tiles_done(location, sweep.n_tiles, options)
    if done is None:
        done = np.zeros(sweep.n_tiles, dtype=bool)
    bad = check_tiles(location, sweep, np.flatnonzero(done), options)
    missing = tuple(int(t) for t in np.flatnonzero(~done))
    return Verification(
        location,
        sweep.n_tiles,
        missing,
        dict(sorted(bad.items())),
        tuple(
            check_coords(location, sweep, options)
            + metadata_damage(location, sweep, options)
        ),
    )


def _verify_directory(out: Path, sweep: Any) -> Verification:
    from ...io import unreadable_files
    from .directory import RESULT_NAME, TILES_DIR, tile_path, tile_state

    if sweep.refine is not None:
        return _verify_refined(out, sweep)
    missing: list[int | str] = []
    damaged: dict[int | str, str] = {}
    paths = [tile_path(out / TILES_DIR, tile) for tile in range(sweep.n_tiles)]
    # all files without digests read by one child process, not one each
    unread = unreadable_files([p for p in (*paths, out / RESULT_NAME) if p.exists()])
    for tile, path in enumerate(paths):
        if not path.exists():
            missing.append(tile)
            continue
        if path in unread:
            damaged[tile] = unread[path]
            continue
        state = tile_state(path, sweep, tile, checked=True)
        if state != "valid":
            damaged[tile] = f"{path.name} is " + (
                "a tile of another configuration"
                if state == "foreign"
                else "unreadable or incomplete"
            )
    complete = not missing and not damaged
    return Verification(
        str(out),
        sweep.n_tiles,
        tuple(missing),
        damaged,
        _check_merged(out / RESULT_NAME, sweep, required=complete),
        finished=(out / RESULT_NAME).exists(),
    )


def _verify_refined(out: Path, sweep: Any) -> Verification:
    """Every level's tiles of a refined sweep's directory, planned as a resume plans
    them: a level's points follow from the tiles of the levels before it, so the levels
    after one with a tile missing or damaged cannot be planned; their files are only
    checked for damage."""
    from ...io import unreadable_files
    from .._refinement.stages import level_tiles, sweep_levels
    from .directory import RESULT_NAME
    from .refined import LEVELS_DIR, RefinedDirectory, level_tile_path

    directory = RefinedDirectory(sweep, out)  # not opened: no lock taken, nothing written
    levels = sweep_levels(directory)
    missing: list[int | str] = []
    damaged: dict[int | str, str] = {}
    n_tiles, planned = 0, set()
    for level in range(levels.levels + 1):
        if missing or damaged:
            break
        items = level_tiles(directory, levels, level)
        paths = [level_tile_path(out / LEVELS_DIR, level, t.tile) for t in items]
        planned.update(paths)
        unread = unreadable_files([p for p in paths if p.exists()])
        n_tiles += len(items)
        for item, path in zip(items, paths):
            label = f"{item.tile} of level {level}"
            if not path.exists():
                missing.append(label)
                continue
            state = unread.get(path) or directory._read(path, item)
            if isinstance(state, str):
                damaged[label] = (
                    state
                    if state not in ("damaged", "foreign")
                    else (
                        f"{path.name} is "
                        + (
                            "a tile of another configuration"
                            if state == "foreign"
                            else "unreadable, incomplete or of other points"
                        )
                    )
                )
            else:
                directory._apply(state)
    # the files of levels that cannot be planned: damage found all the same
    others = sorted(
        p for p in (out / LEVELS_DIR).glob("level-*/tile-*.nc") if p not in planned
    )
    n_tiles += len(others)
    for path, why in unreadable_files(others).items():
        damaged[f"{int(path.stem[5:])} of {path.parent.name.replace('-', ' ')}"] = why
    result = out / RESULT_NAME
    return Verification(
        str(out),
        n_tiles,
        tuple(missing),
        damaged,
        _check_merged(
            result, sweep, required=not (missing or damaged), grid=sweep.finest()
        ),
        finished=result.exists(),
    )


def _check_merged(
    path: Path, sweep: Any, required: bool, grid: Any = None
) -> tuple[str, ...]:
    """Problems of the merged file ``path`` of ``sweep``, whose coordinates are those
    of the sweep ``grid`` (default: ``sweep``); none when it is absent and not
    ``required``."""
    import netCDF4

    from ...io import NETCDF_LOCK, unreadable_files
    from .merge import grid_coords

    if not path.exists():
        return (f"{path.name} is missing: resume writes it",) if required else ()
    # before the netCDF library opens it here: damaged metadata can crash it
    damage = unreadable_files([path]).get(path)
    if damage is not None:
        return (f"{damage}; resume writes it again",)
    try:
        with NETCDF_LOCK, netCDF4.Dataset(path) as nc:
            if nc.getncattr("sweep_config_hash") != sweep.config_hash():
                return (f"{path.name} holds another configuration's results",)
            for var in nc.variables.values():
                var[:]
            wrong = [
                name
                for name, (_, want, _) in grid_coords(grid or sweep).items()
                if name in nc.variables and not _same(nc.variables[name][...], want)
            ]
    except Exception as exc:  # any failure to read it in full
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return (f"{path.name} cannot be read in full ({first}); resume writes it again",)
    if wrong:
        return (
            f"{path.name}: coordinate {', '.join(wrong)} differs from the sweep's "
            "configuration; resume writes it again",
        )
    return ()


def _same(have: Any, want: Any) -> bool:
    import numpy as np

    have, want = np.asarray(have), np.asarray(want)
    if want.dtype.kind in "OUS":
        return have.shape == want.shape and np.array_equal(
            have.astype(str), want.astype(str)
        )
    return have.shape == want.shape and np.array_equal(
        have.astype(float), want.astype(float), equal_nan=True
    )
