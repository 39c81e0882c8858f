"""What the two outputs of a sweep share: the interface the runner writes through, and the
error a failed write becomes.

An output (:class:`~rattlesweep.sweep._outputs.directory.TileDirectory` for netCDF,
:class:`~rattlesweep.sweep._outputs.zarr_store.ZarrStore`, and
:class:`~rattlesweep.sweep._outputs.refined.RefinedDirectory` for a refined sweep) is
opened for one sweep, says which tiles are still to compute and in which stages
(:class:`~rattlesweep.sweep._execution.stage.Stage`), takes each finished tile's results
from the runner (only the process that runs the sweep writes), and finishes into the
result dataset.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import TYPE_CHECKING, Iterator, Protocol, TypeVar

import xarray as xr

if TYPE_CHECKING:
    from .._execution.stage import Stage

__all__ = ["SweepInterrupted", "SweepWriteError", "TileStore", "write_failure"]


class SweepWriteError(OSError):
    """Writing a sweep's output failed (disk full, no permission, a lost connection...).
    What was written before is intact, and a resume continues from there."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a sweep while its tiles ran; the message says how many tiles are
    kept in the output and how to finish it (the command line's one line about it)."""

    def __init__(self, kept: int, total: int, location: str, what: str = "") -> None:
        super().__init__(
            f"{kept} of {total} tiles{what} kept in {location}; "
            f"`rattlesweep resume {location}` finishes it"
        )
        self.kept, self.total, self.location = kept, total, location


Result = TypeVar("Result", contravariant=True)
"""What a tile task returns and the output writes: a
:class:`~rattlesweep.sweep._execution.tiles.TileResult`, or a
:class:`~rattlesweep.sweep._execution.tiles.LevelTileResult` in a refined sweep."""


class TileStore(Protocol[Result]):
    location: str

    def open(self) -> list[int]:
        """Lock and prepare the output; return the tiles still to compute (of a refined
        sweep: none, its levels' tiles are planned as the levels run)."""

    def stages(self) -> Iterator[Stage]:
        """After :meth:`open`, the stages of tasks still to run, in order: one of a
        uniform sweep, a level's of a refined sweep, planned once the stages before it
        are written."""

    def write(self, result: Result) -> None:
        """Write one finished tile, so that a crash leaves it whole or absent."""

    def finish(self) -> xr.Dataset:
        """The result of the finished sweep."""

    def close(self) -> None:
        """Release the lock."""


_NEARLY_FULL = 2**20
"""Free bytes below which a failed write is put down to a full disk."""


def _diagnose(directory: Path) -> tuple[int | None, str]:
    """The likely cause of a write that failed without saying why (HDF5 reports only
    "HDF error"): a full disk or a directory this process may not write."""
    try:
        stat = os.statvfs(directory)
    except OSError:
        return None, ""
    free = stat.f_bavail * stat.f_frsize
    if free < _NEARLY_FULL:
        return errno.ENOSPC, f"{os.strerror(errno.ENOSPC)}: {free} bytes free there"
    if not os.access(directory, os.W_OK):
        return errno.EACCES, os.strerror(errno.EACCES)
    return None, ""


def write_failure(
    what: str | Path, exc: BaseException, written: int, resume: str
) -> SweepWriteError:
    """The error for a failed write of ``what`` (a local file, or a description), naming
    the cause and what to do."""
    code = getattr(exc, "errno", None)
    cause = (exc.strerror or str(exc)) if isinstance(exc, OSError) else str(exc)
    # HDF5 reports a full disk as "HDF error", and through the netCDF library as a
    # permission error: the disk is looked at before the permissions are blamed
    if code in (None, errno.EACCES, errno.EPERM) and isinstance(what, Path):
        found, diagnosis = _diagnose(what.parent)
        if code is None or found == errno.ENOSPC:
            code = found
            cause = f"{cause} ({diagnosis})" if diagnosis else cause
    hints: dict[int | None, str] = {
        errno.ENOSPC: "free some space",
        errno.EDQUOT: "free some space",
        errno.EFBIG: "allow larger files",
        errno.EACCES: "fix the permissions",
        errno.EPERM: "fix the permissions",
        errno.EROFS: "make it writable",
    }
    hint = hints.get(code, "fix the cause")
    return SweepWriteError(
        code or errno.EIO,
        f"cannot write {what}: {cause or type(exc).__name__}. The {written} tiles written "
        f"before are intact; {hint}, then `{resume}` completes the sweep",
    )
