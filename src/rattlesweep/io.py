"""Writing results: netCDF files written atomically."""

from __future__ import annotations

import contextlib
import fnmatch
import os
import re
import signal
import tempfile
import threading
from pathlib import Path
from typing import Iterator

import xarray as xr

__all__ = ["NETCDF_LOCK", "stale_temporaries", "write_netcdf"]

NETCDF_LOCK = threading.RLock()
"""Serialises netCDF/HDF5 calls made by rattlesweep: the HDF5 library is not thread-safe
(concurrent writes crash it), and sweep tiles finish on several threads at once."""


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` (netCDF4, zlib-compressed, every numeric array with HDF5's
    fletcher32 checksums) atomically.

    The file is written to a temporary name in the same directory and renamed into place,
    so a crash never leaves a truncated file under ``path``. On the main thread a Ctrl-C
    waits until the file is in place (:func:`_interrupts_held`). Returns the path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # fletcher32: HDF5 checksums every chunk, so a byte changed on disk fails the read
    # instead of reading as another value (a scalar is not chunked: it has none)
    encoding = {
        str(name): {"fletcher32": True}
        | ({"zlib": True, "complevel": 4} if name in ds.data_vars else {})
        for name, var in ds.variables.items()
        if var.dtype.kind in "fiub" and var.ndim
    }
    fd, tmp = tempfile.mkstemp(
        prefix=_temporary_prefix(path.name), suffix=".tmp", dir=path.parent
    )
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file normal permissions
    try:
        with _interrupts_held(), NETCDF_LOCK:
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


@contextlib.contextmanager
def _interrupts_held() -> Iterator[None]:
    """Hold back SIGINT (Ctrl-C) on the main thread while a file is written, and act on
    it as the handler before would have once the file is in place. An interrupt raised
    inside the netCDF library can leave one of xarray's locks held, and closing the file
    then waits for it for ever; the file itself is written atomically, so nothing is
    gained by stopping halfway. Other threads receive no KeyboardInterrupt anyway."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        if callable(previous):
            previous(signal.SIGINT, None)
        elif previous == signal.SIG_DFL:
            os.kill(os.getpid(), signal.SIGINT)


# the temporary file of ``NAME``: ``.NAME.<pid>.<tempfile's 8 random characters>.tmp``
_TEMPORARY = re.compile(r"\.(?P<name>.+)\.[0-9]+\.[a-z0-9_]{8}\.tmp")


def _temporary_prefix(name: str) -> str:
    return f".{name}.{os.getpid()}."


def stale_temporaries(directory: str | os.PathLike[str], name_glob: str) -> list[Path]:
    """The temporary files :func:`write_netcdf` left in ``directory`` (killed before the
    rename) for files whose names match ``name_glob``. Only names of exactly the form
    it creates are listed, so a user's file that merely looks alike is never one."""
    found = []
    for path in Path(directory).glob(f".{name_glob}.*.tmp"):
        match = _TEMPORARY.fullmatch(path.name)
        if match and fnmatch.fnmatchcase(match["name"], name_glob) and path.is_file():
            found.append(path)
    return found
