"""Writing results: netCDF files written atomically."""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import xarray as xr

__all__ = [
    "DIGEST_SUFFIX",
    "DamagedFile",
    "NETCDF_LOCK",
    "check_netcdf_target",
    "check_readable",
    "digest_path",
    "unreadable_files",
    "recorded_digest_matches",
    "stale_temporaries",
    "write_netcdf",
    "write_text_atomic",
]

NETCDF_LOCK = threading.RLock()
"""Serialises netCDF/HDF5 calls made by rattlesweep: the HDF5 library is not thread-safe
(concurrent writes crash it), and sweep tiles finish on several threads at once."""


_NETCDF_MAGIC = (b"CDF\x01", b"CDF\x02", b"CDF\x05", b"\x89HDF\r\n\x1a\n")


def check_netcdf_target(path: str | os.PathLike, *, digest: bool = False) -> None:
    """Raise ValueError when ``path`` cannot take a netCDF file without losing something
    else: a directory, an existing file that is not netCDF (a configuration given as the
    output by mistake), or, unless the new file gets a ``digest`` too, a file with its
    digest beside it (a sweep's tile or merged result). Another netCDF file, or an empty
    one, is replaced."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"output {path} is a directory; give the netCDF file's path")
    if not digest and digest_path(path).is_file():
        raise ValueError(
            f"output {path} is a sweep's file (its digest {digest_path(path).name} is "
            "beside it): not overwriting it; give another path"
        )
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise ValueError(f"output {path} cannot be read to check it: {exc}") from None
    if head and not head.startswith(_NETCDF_MAGIC):
        raise ValueError(
            f"output {path} exists and is not a netCDF file: not overwriting it; give "
            "another path, or remove it first"
        )


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike, *, digest: bool = False) -> Path:
    """Write ``ds`` to ``path`` (netCDF4, zlib-compressed, every numeric array with HDF5's
    fletcher32 checksums) atomically.

    The file is written to a temporary name in the same directory and renamed into place,
    so a crash never leaves a truncated file under ``path``. On the main thread a Ctrl-C
    waits until the file is in place (:func:`_interrupts_held`). With ``digest``, the
    BLAKE2b digest of the complete file is written beside it first (:func:`digest_path`),
    so that a damaged file is recognised before the netCDF library opens it
    (:func:`check_readable`). A directory or another kind of file at ``path`` is refused
    (:func:`check_netcdf_target`). Returns the path.
    """
    path = Path(path)
    check_netcdf_target(path, digest=digest)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds, cf = _cf_ready(ds)
    # fletcher32: HDF5 checksums every chunk, so a byte changed on disk fails the read
    # instead of reading as another value (a scalar is not chunked: it has none)
    encoding = {
        str(name): {"fletcher32": True}
        | ({"zlib": True, "complevel": 4} if name in ds.data_vars else {})
        for name, var in ds.variables.items()
        if var.dtype.kind in "fiub" and var.ndim
    }
    for name, extra in cf.items():
        encoding[name] = {**encoding.get(name, {}), **extra}
    fd, tmp = _temporary(path)
    os.close(fd)
    try:
        with _interrupts_held(), NETCDF_LOCK:
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            if digest:
                # before the rename: the file renamed into place has its digest beside
                # it already (killed in between, an older file there reads as damaged)
                write_text_atomic(
                    digest_path(path), f"{_file_digest(Path(tmp))}  {path.name}\n"
                )
            os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


_INT32 = np.iinfo(np.int32)


def _cf_ready(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, dict[str, Any]]]:
    """``ds`` as the CF conventions it declares (CF-1.8) have it on disk, and the
    encoding that goes with it: 64-bit integers stored as 32-bit ones (CF-1.8 has no
    64-bit types; a value out of their range keeps 64 bits), no ``_FillValue`` on a
    coordinate, ``flag_values`` of their variable's type, and a ``history`` line. The
    dataset in memory is not changed. (``time`` is the time since the release in s, not
    a reference time: it has no ``standard_name = "time"``, which CF reserves for times
    "since" an epoch.)"""
    out = ds.copy(deep=False)
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        extra: dict[str, Any] = {}
        if var.dtype.kind in "iu" and var.dtype.itemsize == 8:
            values = np.asarray(var.values)
            if values.size == 0 or (
                values.min() >= _INT32.min and values.max() <= _INT32.max
            ):
                extra["dtype"] = "int32"
        if name in out.coords:
            extra["_FillValue"] = None
        if "flag_values" in var.attrs:
            kind = np.dtype(extra.get("dtype", var.dtype))
            var.attrs = {
                **var.attrs,
                "flag_values": np.asarray(var.attrs["flag_values"], kind),
            }
        if extra:
            encoding[str(name)] = extra
    if "history" not in out.attrs:
        stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        out.attrs["history"] = f"{stamp} written by rattlesweep {_version()}"
    return out, encoding


def _version() -> str:
    from ._version import __version__

    return __version__


DIGEST_SUFFIX = ".b2sum"
"""The suffix of the file that holds a file's digest (``sweep.nc.b2sum``), in the format
of ``b2sum`` (BLAKE2b, 512 bits): ``b2sum -c sweep.nc.b2sum`` checks it too."""


class DamagedFile(ValueError):
    """A file that must not be opened by the netCDF library: its bytes differ from the
    digest recorded when it was written, or, with none recorded, reading it crashed or
    failed in a child process (:func:`check_readable`)."""


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


def check_readable(path: str | os.PathLike) -> None:
    """Raise :class:`DamagedFile` when the netCDF file ``path`` cannot be opened safely:
    it differs from its recorded digest, or, with none recorded, reading it in full
    fails or crashes the netCDF library in a child process (:func:`unreadable_files`).
    A file that is no netCDF file, or no regular file, passes: opening it fails
    cleanly."""
    reason = unreadable_files([Path(path)]).get(Path(path))
    if reason is not None:
        raise DamagedFile(reason)


def unreadable_files(paths: list[Path]) -> dict[Path, str]:
    """The files among ``paths`` that must not be opened by the netCDF library in this
    process, each with the message that says why.

    A file with a recorded digest is checked against it. The others are read in full
    (header, every attribute, every variable) by one child process, which names each
    file as it finishes: damaged HDF5 metadata can crash the netCDF library (a
    segmentation fault, an abort on a double free) where Python cannot catch it, so
    a child that dies names the file in flight, and a new child reads the rest. A
    file is read again only when it changed since (same process)."""
    found: dict[Path, str] = {}
    probe = []
    for path in paths:
        matches = recorded_digest_matches(path)
        if matches is False:
            found[path] = (
                f"{path.name} is damaged (its bytes differ from the digest recorded in "
                f"{digest_path(path).name} when it was written)"
            )
        elif matches is None and path.is_file():
            key = _probe_key(path)
            if key not in _PROBED:
                probe.append(path)
            elif (known := _PROBED[key]) is not None:
                found[path] = known
    while probe:  # a child per crash, each going on after the file that crashed one
        done = _probe(probe)
        for path, reason in done.items():
            with contextlib.suppress(OSError):
                _PROBED[_probe_key(path)] = reason
            if reason is not None:
                found[path] = reason
        probe = probe[len(done) :]
    return found


_PROBED: dict[tuple[int, int, int, int], str | None] = {}
"""Files read in full by a child process: (device, inode, size, modification time) ->
why it cannot be read, None when it can."""


def _probe_key(path: Path) -> tuple[int, int, int, int]:
    st = path.stat()
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


# what the child runs: SIGINT ignored (the parent's Ctrl-C ends it), each file read in
# full through netCDF4 (what xarray's loading reads: attributes, variables' data), a line
# per file ("ok", "other": no netCDF file, "bad" and the error's first line)
_PROBE = """
import signal, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)
import netCDF4
print("ready", flush=True)

def read(group):
    for a in group.ncattrs():
        group.getncattr(a)
    for v in group.variables.values():
        for a in v.ncattrs():
            v.getncattr(a)
        v[...]
    for g in group.groups.values():
        read(g)

def first_line(exc):
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]

for i, path in enumerate(sys.stdin.read().split("\\0")[:-1]):
    try:
        nc = netCDF4.Dataset(path)
    except OSError as exc:
        kind = "other" if "Unknown file format" in str(exc) else "bad"
        print(kind, i, first_line(exc), sep="\\t", flush=True)
        continue
    except Exception as exc:
        print("bad", i, first_line(exc), sep="\\t", flush=True)
        continue
    try:
        with nc:
            read(nc)
    except Exception as exc:
        print("bad", i, first_line(exc), sep="\\t", flush=True)
    else:
        print("ok", i, sep="\\t", flush=True)
"""


_PROBE_WAIT_S = 30.0
"""How long a child process may take over a file beyond reading it at
:data:`_PROBE_RATE` before the file counts as damaged: damaged HDF5 metadata can also
send the netCDF library into an endless loop."""

_PROBE_RATE = 20e6
"""Bytes per second a child process reads at the least (compressed netCDF)."""


def _probe(paths: list[Path]) -> dict[Path, str | None]:
    """Read ``paths`` in order in one child process until one crashes or stalls it: the
    files it finished and the one in flight -> why it cannot be read (None: it can)."""
    env = {**os.environ, "LIBC_FATAL_STDERR_": "1"}  # glibc's abort note: not the tty
    with tempfile.TemporaryFile() as err:
        child = subprocess.Popen(
            [sys.executable, "-c", _PROBE],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=err,
            env=env,
        )
        try:
            lines, stalled = _probe_lines(child, paths)
        finally:
            if child.poll() is None:
                child.kill()
            child.wait()
        err.seek(0)
        last = err.read().decode(errors="replace").strip().splitlines()
    if not lines or lines[0] != "ready":
        raise OSError(
            f"cannot check {paths[0]}: the netCDF reader did not start "
            f"({last[-1] if last else child.returncode})"
        )
    found: dict[Path, str | None] = {}
    for line in lines[1:]:
        kind, index, *error = line.split("\t")
        path = paths[int(index)]
        found[path] = (
            f"{path.name} is damaged ({(error or ['?'])[0]}: a chunk fails its "
            "checksum or cannot be read)"
            if kind == "bad"
            else None
        )
    if len(found) < len(paths):
        path = paths[len(found)]
        if stalled:
            how = f"reading it had not ended after {stalled:.0f} s"
        elif child.returncode < 0:
            how = (
                f"reading it crashes the netCDF library: {_signal_name(-child.returncode)}"
            )
        else:
            how = f"reading it fails: {last[-1] if last else child.returncode}"
        found[path] = f"{path.name} is damaged ({how})"
    return found


def _probe_lines(child: subprocess.Popen, paths: list[Path]) -> tuple[list[str], float]:
    """The lines the child wrote until it ended, or until the file in flight took longer
    than its time (then also that time; else 0)."""
    import selectors

    assert child.stdin is not None and child.stdout is not None
    names = "".join(f"{os.fspath(p)}\0" for p in paths).encode()
    feeder = threading.Thread(target=_feed, args=(child.stdin, names), daemon=True)
    feeder.start()
    lines: list[str] = []
    buffer = b""
    with selectors.DefaultSelector() as selector:
        selector.register(child.stdout, selectors.EVENT_READ)
        while True:
            in_flight = paths[min(max(len(lines) - 1, 0), len(paths) - 1)]
            try:
                size = in_flight.stat().st_size
            except OSError:
                size = 0
            wait = _PROBE_WAIT_S + size / _PROBE_RATE
            if not selector.select(wait):
                return lines, wait
            block = os.read(child.stdout.fileno(), 1 << 16)
            if not block:
                return lines, 0.0
            buffer += block
            *done, buffer = buffer.split(b"\n")
            lines.extend(line.decode(errors="replace") for line in done)


def _feed(stream: Any, data: bytes) -> None:
    with contextlib.suppress(OSError):  # the child ended before reading all
        stream.write(data)
        stream.close()


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _file_digest(path: Path) -> str:
    h = hashlib.blake2b()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (UTF-8) through a temporary file of
    :func:`stale_temporaries`'s form, renamed into place."""
    fd, tmp = _temporary(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
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
    rename) for files whose names match ``name_glob``, and for their digests
    (:func:`digest_path`). Only names of exactly the form it creates are listed, so a
    user's file that merely looks alike is never one."""
    found = []
    for pattern in (name_glob, name_glob + DIGEST_SUFFIX):
        for path in Path(directory).glob(f".{pattern}.*.tmp"):
            match = _TEMPORARY.fullmatch(path.name)
            if match and fnmatch.fnmatchcase(match["name"], pattern) and path.is_file():
                found.append(path)
    return found
