"""The line a Ctrl-C ends a command with says what is true of its output: nothing
written, the tiles kept (and how to finish), or the result complete."""

import pytest

from rattlesweep.cli import main
from rattlesweep.sweep._execution import run as run_module
from rattlesweep.sweep._outputs import directory, zarr_export
from rattlesweep.sweep._outputs.verify import verify
from sweep_helpers import as_zarr, small_sweep


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


def _then_interrupt(function):
    def wrapped(*args, **kwargs):
        function(*args, **kwargs)
        raise KeyboardInterrupt

    return wrapped


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(small_sweep(tile_size=8).to_toml())
    return path


def test_ctrl_c_before_the_output_exists_says_nothing_was_written(
    config, tmp_path, monkeypatch, capsys
):
    # it said "the tiles written so far are kept: `rattlesweep resume sg` finishes it"
    # where sg did not exist
    out = tmp_path / "sg"
    monkeypatch.setattr(run_module, "check_size", _interrupt)
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert err == f"rattlesweep: interrupted; nothing was written to {out}\n"
    assert not out.exists()


def test_ctrl_c_after_the_merge_says_the_result_is_complete(
    config, tmp_path, monkeypatch, capsys
):
    # a Ctrl-C during the merge is held until sweep.nc is in place: the sweep is done,
    # and the line said "the tiles written so far are kept … resume finishes it"
    out = tmp_path / "done"
    finish = directory.TileDirectory.finish
    monkeypatch.setattr(directory.TileDirectory, "finish", _then_interrupt(finish))
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert (
        err
        == f"rattlesweep: interrupted; the result is complete: {out}/sweep.nc is written\n"
    )
    assert verify(out).ok
    # resume re-merges a finished sweep: the same
    assert main(["resume", str(out), "--quiet"]) == 130
    assert "the result is complete" in capsys.readouterr().err

    # interrupted while reading what to resume: the output is as it was
    stored = run_module.stored_sweep
    monkeypatch.setattr(run_module, "stored_sweep", _interrupt)
    assert main(["resume", str(out), "--quiet"]) == 130
    assert capsys.readouterr().err == f"rattlesweep: interrupted; {out} is unchanged\n"
    monkeypatch.setattr(run_module, "stored_sweep", stored)

    # interrupted during the tiles, with no merged file: the tiles are kept
    (out / "sweep.nc").unlink()
    (out / "tiles" / "tile-000001.nc").unlink()
    monkeypatch.setattr(run_module, "run_tiles", _interrupt)
    assert main(["resume", str(out), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert "kept in" in err and f"`rattlesweep resume {out}` finishes it" in err


def test_ctrl_c_after_the_last_tile_of_a_zarr_sweep_says_the_result_is_complete(
    tmp_path, monkeypatch, capsys
):
    # a store has nothing left to do after its last tile: it said "8 of 8 tiles kept …
    # `rattlesweep resume` finishes it"
    config = tmp_path / "z.toml"
    config.write_text(as_zarr(small_sweep(tile_size=8)).to_toml())
    store = tmp_path / "s.zarr"
    run_tiles = run_module.run_tiles
    # before its first tile: the store is laid out, and resume finishes it
    monkeypatch.setattr(run_module, "run_tiles", _interrupt)
    assert main(["sweep", str(config), "--out", str(store), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert "tiles kept in" in err and f"`rattlesweep resume {store}` finishes it" in err
    monkeypatch.setattr(run_module, "run_tiles", _then_interrupt(run_tiles))
    assert main(["resume", str(store), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert err == (
        f"rattlesweep: interrupted; the result is complete: every tile of {store} is "
        "written\n"
    )
    assert verify(store).ok


def test_ctrl_c_of_an_export_says_whether_the_file_is_written(
    tmp_path, monkeypatch, capsys
):
    store = tmp_path / "s.zarr"
    run_module.run_sweep(as_zarr(small_sweep(tile_size=8)), store, progress=False)
    out = tmp_path / "s.nc"
    export = zarr_export.export_netcdf
    monkeypatch.setattr(zarr_export, "export_netcdf", _interrupt)
    assert main(["export", str(store), str(out)]) == 130
    assert capsys.readouterr().err.endswith(f"nothing was written to {out}\n")
    monkeypatch.setattr(zarr_export, "export_netcdf", _then_interrupt(export))
    assert main(["export", str(store), str(out)]) == 130
    assert capsys.readouterr().err.endswith(f"the export is complete: {out} is written\n")
    assert out.is_file()
