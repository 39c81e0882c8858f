"""An output never lies: every tile of a netCDF directory or a zarr store is verified by
``resume``, ``export`` and ``rattlesweep verify``; damaged or missing tiles are recomputed
on resume and named where nothing may be written."""

import pytest
import xarray as xr

from rattlesweep.cli import main
from rattlesweep.sweep import run_sweep
from rattlesweep.sweep._execution.run import RESULT_NAME, export
from rattlesweep.sweep._outputs.verify import verify
from sweep_helpers import as_zarr, file_stats, small_sweep, without_history

zarr = pytest.importorskip("zarr")


def _flip(path, at=5):
    data = bytearray(path.read_bytes())
    data[at] ^= 0x01
    path.write_bytes(bytes(data))


def test_zarr_chunks_deleted_or_changed_are_found_named_and_recomputed(tmp_path, capsys):
    s = as_zarr(small_sweep(tile_size=3))
    store = tmp_path / "run.zarr"
    run_sweep(s, store, progress=False)
    reference = tmp_path / "reference.nc"
    export(store, reference)
    assert verify(store).ok
    assert main(["verify", str(store)]) == 0
    assert f"{s.n_tiles} of {s.n_tiles} tiles verified" in capsys.readouterr().out

    chunks = sorted(store.glob("outcome/c/*/*/*/*"))
    assert len(chunks) == s.n_tiles  # every tile's chunk stored, fill values or not
    chunks[1].unlink()
    _flip(sorted(store.glob("final_spin/c/*/*/*/*"))[2])
    found = verify(store)
    assert not found.ok and set(found.damaged) == {1, 2}
    assert "missing" in found.damaged[1] and "checksum" in found.damaged[2]

    # read-only commands name the tiles and write nothing; no decompression traceback
    assert main(["verify", str(store)]) == 1
    out = capsys.readouterr().out
    assert "tile 1: chunk outcome/" in out and "tile 2: chunk final_spin/" in out
    assert main(["export", str(store), str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert "2 of 16 tiles are missing or damaged" in err and "Traceback" not in err
    assert not (tmp_path / "x.nc").exists()

    # resume recomputes exactly those two tiles
    before = file_stats(store, "*/c/*/*/*/*")
    assert main(["resume", str(store), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "2 tiles of" in err and "recomputing them" in err
    after = file_stats(store, "*/c/*/*/*/*")
    changed = {k for k in after if after[k] != before.get(k)}
    assert changed and all(k.rsplit("/c/", 1)[1] in ("0/0/1/0", "0/1/0/0") for k in changed)
    assert verify(store).ok
    export(store, tmp_path / "again.nc")
    with xr.open_dataset(reference) as a, xr.open_dataset(tmp_path / "again.nc") as b:
        xr.testing.assert_identical(without_history(a.load()), without_history(b.load()))


def test_zarr_damaged_done_flags_check_every_tile(tmp_path):
    s = as_zarr(small_sweep(tile_size=3))
    store = tmp_path / "run.zarr"
    run_sweep(s, store, progress=False)
    _flip(next(store.glob("rattlesweep/tile_done/c/*")), at=3)
    sorted(store.glob("status/c/*/*/*/*"))[4].unlink()
    run_sweep(s, store, progress=False)
    assert verify(store).ok


def test_netcdf_directory_verified_tile_by_tile_and_merged_file(tmp_path, capsys):
    s = small_sweep(tile_size=3)
    out = tmp_path / "run"
    run_sweep(s, out, progress=False)
    assert verify(out).ok
    tile = out / "tiles" / "tile-000003.nc"
    tile.write_bytes(tile.read_bytes()[:200])
    (out / "tiles" / "tile-000004.nc").unlink()
    _flip(out / RESULT_NAME, at=len((out / RESULT_NAME).read_bytes()) // 2)
    found = verify(out)
    assert set(found.damaged) == {3} and found.missing == (4,)
    assert main(["verify", str(out)]) == 1
    assert "damaged: tile 3: tile-000003.nc" in capsys.readouterr().out
    assert main(["resume", str(out), "--quiet"]) == 0
    assert verify(out).ok


# --- a sweep never destroys what it cannot show it wrote -------------------------------


def _tree(root):
    return {
        str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()
    }


def test_zarr_store_with_damaged_root_metadata_is_refused_not_wiped(tmp_path):
    store = tmp_path / "a.zarr"
    run_sweep(as_zarr(small_sweep(tile_size=3)), store, progress=False)
    (store / "zarr.json").write_text("{broken")
    before = _tree(store)
    with pytest.raises(
        ValueError,
        match=r"a\.zarr holds a zarr store whose root metadata "
        r"cannot be read.*not overwriting it",
    ):
        run_sweep(as_zarr(small_sweep(tile_size=4)), store, progress=False)
    assert _tree(store) == before


def test_netcdf_directory_without_config_keeps_results_it_cannot_claim(tmp_path):
    out = tmp_path / "run"
    s = small_sweep(tile_size=3)
    run_sweep(s, out, progress=False)
    (out / "sweep.toml").unlink()
    (out / RESULT_NAME).rename(tmp_path / RESULT_NAME)
    tiles = _tree(out / "tiles")
    # tiles left without their configuration: not this sweep's to delete or overwrite
    with pytest.raises(ValueError, match=r"tiles holds 32 files .* no sweep\.toml"):
        run_sweep(small_sweep(tile_size=4), out, progress=False)
    assert _tree(out / "tiles") == tiles
    for path in (out / "tiles").iterdir():
        path.unlink()
    (tmp_path / RESULT_NAME).rename(out / RESULT_NAME)
    merged = (out / RESULT_NAME).read_bytes()
    with pytest.raises(
        ValueError,
        match=r"holds sweep\.nc but no sweep\.toml.*not "
        r"overwriting it",
    ):
        run_sweep(small_sweep(tile_size=4), out, progress=False)
    assert (out / RESULT_NAME).read_bytes() == merged
    assert not (out / "sweep.toml").exists()
    # the same configuration's result is this sweep's: it runs and rewrites it
    run_sweep(s, out, progress=False)
    assert (out / "sweep.toml").exists()


def test_netcdf_sweep_refuses_a_zarr_store_and_a_file(tmp_path, capsys):
    store = tmp_path / "a.zarr"
    run_sweep(as_zarr(small_sweep(tile_size=3)), store, progress=False)
    before = _tree(store)
    with pytest.raises(ValueError, match=r"a\.zarr is a zarr store: a netCDF sweep"):
        run_sweep(small_sweep(tile_size=3), store, progress=False)
    assert _tree(store) == before
    config = tmp_path / "s.toml"
    config.write_text(small_sweep(tile_size=3).to_toml())
    (tmp_path / "file").write_text("x")
    assert main(["sweep", str(config), "--out", str(tmp_path / "file"), "--quiet"]) == 2
    assert "file exists and is not a directory" in capsys.readouterr().err


def test_orphan_merge_tmp_is_removed_on_resume(tmp_path):
    out = tmp_path / "run"
    s = small_sweep(tile_size=3)
    run_sweep(s, out, progress=False)
    orphan = out / ".sweep.nc.4242.x1y2_3ab.tmp"  # what a kill during the merge leaves
    orphan.write_bytes(b"partial")
    run_sweep(s, out, progress=False)
    assert not orphan.exists()


@pytest.mark.parametrize("output", ["netcdf", "zarr"])
def test_a_symlink_to_an_output_in_use_meets_its_lock(tmp_path, output):
    from rattlesweep.sweep._execution.lock import SweepLocked
    from rattlesweep.sweep._execution.run import open_output

    s = small_sweep(output=output, tile_size=3)
    real = tmp_path / ("real.zarr" if output == "zarr" else "real")
    link = tmp_path / ("link.zarr" if output == "zarr" else "link")
    holder = open_output(s, real)
    holder.open()
    link.symlink_to(real, target_is_directory=True)
    try:
        with pytest.raises(SweepLocked, match=r"real(\.zarr)? is in use by another sweep"):
            run_sweep(s, link, progress=False)
    finally:
        holder.close()
    run_sweep(s, link, progress=False)
    assert verify(real).ok


def test_zarr_coordinates_damaged_are_found_refused_and_rewritten(tmp_path, capsys):
    """An axis's coordinate chunk with a flipped byte (values that still decode, wrong)
    and a damaged scalar coordinate: verify names them, export refuses, and resume
    writes them again from the configuration (a hostile trial exported 4.588 for 4.5)."""
    s = as_zarr(small_sweep(tile_size=3))
    store = tmp_path / "run.zarr"
    run_sweep(s, store, progress=False)
    export(store, tmp_path / "reference.nc")
    (axis,) = [d for d in s.dims if d != "repeat"][:1]
    (chunk,) = sorted((store / axis / "c").glob("*"))
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2] ^= 0x5A
    chunk.write_bytes(bytes(data))
    found = verify(store)
    assert not found.ok and any(f"coordinate {axis}" in p for p in found.problems)
    assert main(["verify", str(store)]) == 1
    assert main(["export", str(store), str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert f"coordinate {axis}" in err and "Traceback" not in err
    assert not (tmp_path / "x.nc").exists()
    assert main(["resume", str(store), "--quiet"]) == 0
    assert verify(store).ok
    export(store, tmp_path / "again.nc")
    with (
        xr.open_dataset(tmp_path / "reference.nc") as a,
        xr.open_dataset(tmp_path / "again.nc") as b,
    ):
        xr.testing.assert_identical(without_history(a), without_history(b))


def test_a_wrong_coordinate_in_a_merged_sweep_nc_is_found_and_resume_rewrites_it(tmp_path):
    """A value of an axis changed inside sweep.nc (a flipped byte read as -4.000343 for
    -4.0 passed verify in a hostile trial): verify names the coordinate, resume writes the
    file again."""
    import netCDF4

    s = small_sweep()
    out = tmp_path / "run"
    reference = run_sweep(s, out, progress=False).load()
    with netCDF4.Dataset(out / RESULT_NAME, "a") as nc:
        nc.variables["delta_deg"][0] = -4.000343
    found = verify(out)  # the file differs from the digest written with it
    assert not found.ok and any("sweep.nc is damaged" in p for p in found.problems)
    (out / "sweep.nc.b2sum").unlink()  # as a file with no digest: the values checked
    found = verify(out)
    assert not found.ok and any("coordinate delta_deg" in p for p in found.problems)
    assert main(["resume", str(out), "--quiet"]) == 0
    assert verify(out).ok
    with xr.open_dataset(out / RESULT_NAME) as again:
        xr.testing.assert_identical(without_history(reference), without_history(again))


def test_a_finished_refined_directory_verifies_against_its_finest_grid(tmp_path, capsys):
    s = small_sweep(refine={"levels": 1})
    out = tmp_path / "refined"
    run_sweep(s, out, progress=False)
    assert verify(out).ok  # its sweep.nc lies on the finest grid, not the declared one
    assert main(["info", str(out)]) == 0
    assert capsys.readouterr().err == ""


def test_info_and_plot_of_a_zarr_chunk_failing_its_checksum_end_in_one_clear_line(
    tmp_path,
):
    """They warned, then died with zarr's 'Stored and computed checksum do not match'
    (plot with asyncio's 'Task was destroyed but it is pending!' after it)."""
    import subprocess
    import sys

    store = tmp_path / "run.zarr"
    run_sweep(as_zarr(small_sweep(tile_size=3)), store, progress=False)
    chunk = sorted(store.glob("outcome/c/*/*/*/*"))[2]
    _flip(chunk)
    for command in (["info", str(store)], ["plot", str(store)]):
        done = subprocess.run(
            [sys.executable, "-m", "rattlesweep.cli", *command],
            capture_output=True,
            text=True,
            cwd=tmp_path,
        )
        assert done.returncode == 2, done.stderr
        last = done.stderr.strip().splitlines()[-1]
        assert last.endswith(
            f"cannot read {store}: tile 2 is damaged: chunk outcome/c/0/1/0/0 damaged "
            f"(it fails its CRC-32C checksum); `rattlesweep resume {store}` recomputes "
            "what is missing or damaged"
        ), done.stderr
        for noise in ("Stored and computed", "Traceback", "Task was destroyed", "loop"):
            assert noise not in done.stderr, done.stderr


def test_a_zarr_chunk_copied_over_another_tiles_is_found_and_recomputed(tmp_path):
    """A chunk's CRC-32C covers its bytes, not its place: final_spin's chunk of tile 1
    copied over tile 2's passed every check. Each tile's digest now finds it."""
    import shutil

    s = as_zarr(small_sweep(tile_size=3))
    store = tmp_path / "run.zarr"
    run_sweep(s, store, progress=False)
    reference = tmp_path / "reference.nc"
    export(store, reference)
    chunks = sorted(store.glob("final_spin/c/*/*/*/*"))
    assert chunks[1].read_bytes() != chunks[2].read_bytes()
    shutil.copy(chunks[1], chunks[2])
    found = verify(store)
    assert set(found.damaged) == {2}
    assert found.damaged[2].startswith("its values are not those written")
    assert main(["export", str(store), str(tmp_path / "x.nc")]) == 2
    assert not (tmp_path / "x.nc").exists()
    run_sweep(s, store, progress=False)  # resume: tile 2 recomputed
    assert verify(store).ok
    export(store, tmp_path / "again.nc")
    with xr.open_dataset(reference) as a, xr.open_dataset(tmp_path / "again.nc") as b:
        xr.testing.assert_identical(without_history(a.load()), without_history(b.load()))


def test_a_digest_path_in_the_way_is_named_before_anything_is_removed(tmp_path, capsys):
    # a directory where a tile's digest goes: resume removed the good tile, recomputed
    # it, then failed naming the tile ("[Errno 21] cannot write .../tile-000003.nc")
    out = tmp_path / "dm"
    run_sweep(small_sweep(tile_size=8), out, progress=False)
    tile = out / "tiles" / "tile-000003.nc"
    before = file_stats(out, "*.nc")
    (out / "tiles" / "tile-000003.nc.b2sum").unlink()
    (out / "tiles" / "tile-000003.nc.b2sum").mkdir()
    assert main(["resume", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{tile}.b2sum is in the way" in err and "is a directory" in err, err
    assert file_stats(out, "*.nc") == before


def test_a_full_disk_the_library_calls_a_permission_error_is_named_a_full_disk(
    tmp_path, monkeypatch
):
    """The netCDF library reports a write on a full disk as "Permission denied": the
    message looks at the disk before blaming the permissions (the disk's free space as
    statvfs reports it, made nearly nothing here)."""
    import errno

    from rattlesweep.sweep._outputs import store

    denied = PermissionError(errno.EACCES, "Permission denied")
    target = tmp_path / "tile-000001.nc"
    error = store.write_failure(target, denied, 3, "rattlesweep resume out")
    assert error.errno == errno.EACCES and "fix the permissions" in str(error)

    class Full:
        f_bavail, f_frsize = 10, 4096

    monkeypatch.setattr(store.os, "statvfs", lambda directory: Full())
    error = store.write_failure(target, denied, 3, "rattlesweep resume out")
    assert error.errno == errno.ENOSPC
    assert "40960 bytes free there" in str(error) and "free some space" in str(error)
    assert "The 3 tiles written before are intact" in str(error)


def test_a_dangling_symlink_at_the_output_or_its_tiles_is_named(tmp_path, capsys):
    config = tmp_path / "s.toml"
    config.write_text(small_sweep().to_toml())
    out = tmp_path / "out"
    out.symlink_to(tmp_path / "nowhere")
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert (
        f"{out} is a symbolic link to {tmp_path / 'nowhere'}, which does not exist" in err
    )
    assert "Errno 17" not in err
    other = tmp_path / "other"
    other.mkdir()
    (other / "tiles").symlink_to(tmp_path / "nothing")
    assert main(["sweep", str(config), "--out", str(other), "--quiet"]) == 2
    assert "tiles is a symbolic link to" in capsys.readouterr().err
