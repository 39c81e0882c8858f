"""The integrity metadata of a zarr store is itself verified (issue 43, defect 4): a
damaged `tile_digest` chunk no longer switches the moved-chunk check off, and a damaged
or deleted `tile_done` chunk is reported, by `verify`, `export` and `resume`."""

import shutil

import pytest
import xarray as xr

from rattlesweep.cli import main
from rattlesweep.sweep import run_sweep
from rattlesweep.sweep._execution.run import export
from rattlesweep.sweep._outputs.verify import verify
from sweep_helpers import as_zarr, small_sweep, without_history

zarr = pytest.importorskip("zarr")


def _flip(path, at=5):
    data = bytearray(path.read_bytes())
    data[at] ^= 0x01
    path.write_bytes(bytes(data))


@pytest.fixture
def store(tmp_path):
    s = as_zarr(small_sweep(tile_size=3))
    location = tmp_path / "run.zarr"
    run_sweep(s, location, progress=False)
    export(location, tmp_path / "reference.nc")
    return s, location


def test_a_damaged_digest_chunk_with_a_moved_chunk_is_damage_not_a_pass(
    store, tmp_path, capsys
):
    s, location = store
    chunks = sorted(location.glob("final_spin/c/*/*/*/*"))
    shutil.copy(chunks[1], chunks[2])  # a chunk moved: only the digest can tell
    _flip(next(location.glob("rattlesweep/tile_digest/c/*")))
    found = verify(location)
    assert not found.ok and len(found.damaged) == s.n_tiles  # none can be checked
    assert "its digest (rattlesweep/tile_digest) is damaged or missing" in found.damaged[2]
    assert any(
        "rattlesweep/tile_digest is damaged for tiles 0 to" in p for p in found.problems
    )
    assert main(["verify", str(location)]) == 1
    assert main(["export", str(location), str(tmp_path / "x.nc")]) == 2
    assert not (tmp_path / "x.nc").exists()
    capsys.readouterr()
    assert main(["resume", str(location), "--quiet"]) == 0  # every tile computed again
    assert verify(location).ok
    export(location, tmp_path / "again.nc")
    with xr.open_dataset(tmp_path / "reference.nc") as a:
        with xr.open_dataset(tmp_path / "again.nc") as b:
            xr.testing.assert_identical(
                without_history(a.load()), without_history(b.load())
            )


@pytest.mark.parametrize("how", ["flipped", "deleted"])
def test_a_damaged_done_flags_chunk_is_reported_and_written_again(store, tmp_path, how):
    s, location = store
    flags = next(location.glob("rattlesweep/tile_done/c/*"))
    if how == "flipped":
        _flip(flags, at=3)
    else:
        flags.unlink()
    found = verify(location)
    assert not found.ok
    word = "damaged" if how == "flipped" else "missing"
    assert any(
        f"rattlesweep/tile_done is {word} for tiles 0 to" in p for p in found.problems
    )
    assert main(["export", str(location), str(tmp_path / "x.nc")]) == 2
    run_sweep(s, location, progress=False)  # resume: tiles checked, flags written again
    assert verify(location).ok
