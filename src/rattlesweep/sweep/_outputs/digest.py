"""The digest of a tile's values that a zarr store keeps beside its done flag: a chunk's
checksum covers its bytes, not where it lies, so a chunk copied over another tile's
passes the checksum but not the digest."""

from __future__ import annotations

import hashlib
from typing import Any, Mapping

import numpy as np

from .._config.spec import Sweep
from .._execution.tiles import result_dtypes

__all__ = ["feed", "finish", "tile_digest"]


def tile_digest(sweep: Sweep, values: Mapping[str, Any]) -> int:
    """A 64-bit digest (never 0, the fill value) of a tile's values by variable name."""
    h = hashlib.blake2b(digest_size=8)
    for name, dtype in result_dtypes(sweep).items():
        feed(h, values[name], dtype)
    return finish(h)


def feed(h: Any, values: Any, dtype: np.dtype) -> None:
    """Add values, as little-endian ``dtype``, to the running hash h."""
    h.update(np.ascontiguousarray(values, dtype=dtype.newbyteorder("<")).data)


def finish(h: Any) -> int:
    """The digest of the running hash h: 64 bits, never 0 (the fill value)."""
    return int.from_bytes(h.digest(), "little") or 1
