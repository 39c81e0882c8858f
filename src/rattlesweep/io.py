"""Writing results: netCDF files written atomically."""

from __future__ import annotations

import os
import tempfile
import threading
from pathlib import Path

import xarray as xr

__all__ = ["NETCDF_LOCK", "write_netcdf"]

NETCDF_LOCK = threading.RLock()
"""Serialises netCDF/HDF5 calls made by rattlesweep: the HDF5 library is not thread-safe
(concurrent writes crash it), and sweep tiles finish on several threads at once."""


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` (netCDF4, zlib-compressed) atomically.

    The file is written to a temporary name in the same directory and renamed into place,
    so a crash never leaves a truncated file under ``path``. Returns the path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding = {
        name: {"zlib": True, "complevel": 4}
        for name in ds.data_vars
        if ds[name].dtype.kind in "fiub"
    }
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file normal permissions
    try:
        with NETCDF_LOCK:
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
