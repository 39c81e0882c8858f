"""Writing results: netCDF files written atomically."""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import os
import re
import signal
import tempfile
import threading
from pathlib import Path
from typing import Iterator

import xarray as xr

__all__ = [
    "DIGEST_SUFFIX",
    "DamagedFile",
    "NETCDF_LOCK",
    "check_digest",
    "digest_path",
    "recorded_digest_matches",
    "stale_temporaries",
    "write_netcdf",
]

NETCDF_LOCK = threading.RLock()
"""Serialises netCDF/HDF5 calls made by rattlesweep: the HDF5 library is not thread-safe
(concurrent writes crash it), and sweep tiles finish on several threads at once."""


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike, *, digest: bool = False) -> Path:
    """Write ``ds`` to ``path`` (netCDF4, zlib-compressed, every numeric array with HDF5's
    fletcher32 checksums) atomically.

    The file is written to a temporary name in the same directory and renamed into place,
    so a crash never leaves a truncated file under ``path``. On the main thread a Ctrl-C
    waits until the file is in place (:func:`_interrupts_held`). With ``digest``, the
    BLAKE2b digest of the complete file is written beside it first (:func:`digest_path`),
    so that a damaged file is recognised before the netCDF library opens it
    (:func:`check_digest`). Returns the path.
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
    fd, tmp = _temporary(path)
    os.close(fd)
    try:
        with _interrupts_held(), NETCDF_LOCK:
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            if digest:
                # before the rename: the file renamed into place has its digest beside
                # it already (killed in between, an older file there reads as damaged)
                _write_atomic(
                    digest_path(path), f"{_file_digest(Path(tmp))}  {path.name}\n"
                )
            os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


DIGEST_SUFFIX = ".b2sum"
"""The suffix of the file that holds a file's digest (``sweep.nc.b2sum``), in the format
of ``b2sum`` (BLAKE2b, 512 bits): ``b2sum -c sweep.nc.b2sum`` checks it too."""


class DamagedFile(ValueError):
    """A file whose bytes differ from the digest recorded when it was written."""


def digest_path(path: str | os.PathLike) -> Path:
    """The file that holds the digest of ``path``."""
    path = Path(path)
    return path.with_name(path.name + DIGEST_SUFFIX)


def recorded_digest_matches(path: str | os.PathLike) -> bool | None:
    """Whether the file ``path`` has the digest recorded beside it when it was written:
    None when none is recorded; False when it differs, or the record cannot be read.

    Reads the file and its record only, with no netCDF library: a file whose HDF5
    metadata is damaged can crash that library (a segmentation fault, or an abort on
    a double free) where Python cannot catch it."""
    record = digest_path(path)
    try:
        text = record.read_text(encoding="ascii")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError):
        return False
    recorded = (text.split() or [""])[0].lower()
    try:
        return _file_digest(Path(path)) == recorded
    except OSError:
        return False


def check_digest(path: str | os.PathLike) -> None:
    """Raise :class:`DamagedFile` when ``path`` differs from its recorded digest
    (:func:`recorded_digest_matches`); a file with none recorded passes."""
    if recorded_digest_matches(path) is False:
        raise DamagedFile(
            f"{Path(path).name} is damaged (its bytes differ from the digest recorded in "
            f"{digest_path(path).name} when it was written)"
        )


def _file_digest(path: Path) -> str:
    h = hashlib.blake2b()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file of :func:`stale_temporaries`'s
    form, renamed into place."""
    fd, tmp = _temporary(path)
    try:
        with os.fdopen(fd, "w", encoding="ascii") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


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


_UMASK_LOCK = threading.Lock()


def _temporary(path: Path) -> tuple[int, str]:
    """A new temporary file for ``path`` (of :func:`stale_temporaries`'s form) in its
    directory, with the permissions of a file created there: descriptor and name."""
    fd, tmp = tempfile.mkstemp(
        prefix=_temporary_prefix(path.name), suffix=".tmp", dir=path.parent
    )
    with _UMASK_LOCK:  # os.umask reads by setting: two threads at once could keep 0
        umask = os.umask(0)
        os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600
    return fd, tmp


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
