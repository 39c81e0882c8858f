"""The integrity metadata of a sweep's zarr store, read so that its own damage is seen:
``tile_done`` (one byte per tile, set after the tile's data) and ``tile_digest`` (each
tile's digest, by which a chunk moved from another tile is found).

Each is read chunk by chunk: a chunk that cannot be read (a failed checksum, a short
file) or that is missing where finished tiles need it is damage, reported by what it
covers, never taken as "no digest" or "not done". A tile whose digest is damaged cannot
be checked, so it counts as damaged (and a resume computes it again); a damaged done
flag is taken as set, so that the tile's chunks are checked, and written again.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "DIGEST_ARRAY",
    "DONE_ARRAY",
    "damage",
    "digests",
    "flag_damage",
    "keys",
    "read_by_chunk",
    "tile_key",
]

DONE_ARRAY = "rattlesweep/tile_done"
DIGEST_ARRAY = "rattlesweep/tile_digest"


def read_by_chunk(
    array: Any, stored: set[str]
) -> tuple[np.ndarray, list[tuple[int, int]], list[tuple[int, int]]]:
    """(values, the tile ranges [start, stop) of chunks that cannot be read, those of
    chunks not stored) of a one-dimensional metadata array; ``stored``: the store's
    keys under the array. A chunk not stored reads as zeros, which is right only while
    none of its tiles has finished."""
    n = int(array.shape[0])
    size = int(array.chunks[0])
    values = np.zeros(n, dtype=array.dtype)
    unreadable, missing = [], []
    for k, start in enumerate(range(0, n, size)):
        stop = min(n, start + size)
        if f"{array.path}/{array.metadata.encode_chunk_key((k,))}" not in stored:
            missing.append((start, stop))
            continue
        try:
            values[start:stop] = array[start:stop]
        except Exception:  # a failed checksum, zstd or a short read
            unreadable.append((start, stop))
    return values, unreadable, missing


def flag_damage(
    name: str,
    unreadable: list[tuple[int, int]],
    missing: list[tuple[int, int]],
    finished: np.ndarray,
) -> list[str]:
    """Plain statements of the damage of metadata array ``name``: every chunk that
    cannot be read, and every chunk not stored that covers a tile ``finished`` says has
    its data (a chunk of tiles none of which finished was never written)."""
    out = [
        f"{name} is damaged for tiles {a} to {b - 1} (a chunk cannot be read)"
        for a, b in unreadable
    ]
    out += [
        f"{name} is missing for tiles {a} to {b - 1} (its chunk is gone)"
        for a, b in missing
        if finished[a:b].any()
    ]
    return out


def tile_key(array: Any, sweep: Any, tile: int) -> str:
    """The store key of ``tile``'s chunk of ``array`` (a result variable: its chunks
    are the sweep's tiles)."""
    region = sweep.tile_region(tile)
    coords = tuple(r.start // c for r, c in zip(region, sweep.tile_shape))
    return f"{array.path}/{array.metadata.encode_chunk_key(coords)}"


def keys(group: Any, prefix: str) -> set[str]:
    """The keys stored under ``prefix`` in the group's store."""
    from zarr.core.sync import sync

    async def listing() -> list[str]:
        return [k async for k in group.store.list_prefix(prefix)]

    return set(sync(listing()))


def digests(group: Any, n_tiles: int) -> tuple[np.ndarray | None, set[int]]:
    """(each tile's digest, the tiles whose digest cannot be trusted: its chunk
    unreadable or gone); (None, set()) for a store written before digests."""
    try:
        array: Any = group[DIGEST_ARRAY]
    except KeyError:
        return None, set()
    except Exception:  # its metadata damaged: no tile can be checked
        return np.zeros(n_tiles, dtype="uint64"), set(range(n_tiles))
    values, unreadable, missing = read_by_chunk(array, keys(group, f"{DIGEST_ARRAY}/"))
    return values, {t for a, b in unreadable + missing for t in range(a, b)}


def damage(group: Any, sweep: Any) -> list[str]:
    """What is wrong with the integrity metadata of the store ``group`` of ``sweep``,
    in plain statements; empty when sound."""
    try:
        flags: Any = group[DONE_ARRAY]
    except KeyError:
        return []  # a layout never finished: nothing is done
    stored = keys(group, "status/")
    status: Any = group["status"]
    finished = np.zeros(sweep.n_tiles, dtype=bool)
    for tile in range(sweep.n_tiles):
        finished[tile] = tile_key(status, sweep, tile) in stored
    done, unreadable, missing = read_by_chunk(flags, keys(group, f"{DONE_ARRAY}/"))
    out = flag_damage(DONE_ARRAY, unreadable, missing, finished)
    if DIGEST_ARRAY in group:
        _, bad, gone = read_by_chunk(group[DIGEST_ARRAY], keys(group, f"{DIGEST_ARRAY}/"))
        out += flag_damage(DIGEST_ARRAY, bad, gone, done.astype(bool) | finished)
    return out
