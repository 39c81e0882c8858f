"""Verifying a sweep's output without changing it: every tile of a netCDF directory or a
zarr store read back and checked, and the merged ``sweep.nc`` read in full."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

__all__ = ["Verification", "verify"]


@dataclass(frozen=True)
class Verification:
    """What :func:`verify` found: the output's ``location``, its number of tiles, the
    tiles without a file or done flag (``missing``), the tiles found damaged (tile ->
    what is wrong) and other problems (the merged file). ``finished`` says that the
    sweep had finished (its merged file was written), so a tile in ``missing`` was lost
    rather than not computed yet."""

    location: str
    n_tiles: int
    missing: tuple[int, ...]
    damaged: Mapping[int, str]
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
        for tile in sorted(self.damaged)[:10]:
            lines.append(f"  damaged: tile {tile}: {self.damaged[tile]}")
        if len(self.damaged) > 10:
            lines.append(f"  damaged: {_tiles(len(self.damaged) - 10)} more")
        lines.extend(f"  {p}" for p in self.problems)
        if not self.ok:
            lines.append(
                f"  `rattlesweep resume {self.location}` recomputes what is "
                "missing or damaged"
            )
        return "\n".join(lines)


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

    from .zarr_store import check_coords, check_tiles, tiles_done

    done = tiles_done(location, sweep.n_tiles, options)
    if done is None:
        done = np.zeros(sweep.n_tiles, dtype=bool)
    bad = check_tiles(location, sweep, np.flatnonzero(done), options)
    missing = tuple(int(t) for t in np.flatnonzero(~done))
    return Verification(
        location, sweep.n_tiles, missing, bad, tuple(check_coords(location, sweep, options))
    )


def _verify_directory(out: Path, sweep: Any) -> Verification:
    from .directory import RESULT_NAME, TILES_DIR, tile_path, tile_state

    if sweep.refine is not None:
        # a refined sweep's tiles are per level; its merged file, on the finest grid, is
        # what is checked
        return Verification(
            str(out),
            0,
            (),
            {},
            _check_merged(out / RESULT_NAME, sweep, required=True, grid=sweep.finest()),
        )
    missing, damaged = [], {}
    for tile in range(sweep.n_tiles):
        path = tile_path(out / TILES_DIR, tile)
        if not path.exists():
            missing.append(tile)
            continue
        state = tile_state(path, sweep, tile)
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


def _check_merged(
    path: Path, sweep: Any, required: bool, grid: Any = None
) -> tuple[str, ...]:
    """Problems of the merged file ``path`` of ``sweep``, whose coordinates are those
    of the sweep ``grid`` (default: ``sweep``); none when it is absent and not
    ``required``."""
    import netCDF4

    from ...io import NETCDF_LOCK, DamagedFile, check_digest
    from .merge import grid_coords

    if not path.exists():
        return (f"{path.name} is missing: resume writes it",) if required else ()
    try:
        check_digest(path)  # before the netCDF library opens it: damaged metadata can
    except DamagedFile as exc:  # crash it
        return (f"{exc}; resume writes it again",)
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
