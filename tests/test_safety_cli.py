"""The sweep commands' arguments and messages: refused before anything is written, with a
message naming the argument."""

import subprocess
import sys

import pytest

from rattlesweep.cli import main
from sweep_helpers import small_sweep


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(small_sweep(tile_size=8).to_toml())
    return path


def test_negative_refine_is_refused_not_dropped(tmp_path, config, capsys):
    assert (
        main(
            [
                "sweep",
                str(config),
                "--out",
                str(tmp_path / "o"),
                "--refine",
                "-1",
                "--quiet",
            ]
        )
        == 2
    )
    assert "--refine must be an integer >= 0" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_empty_out_is_refused(tmp_path, config, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(config), "--out", "", "--quiet"]) == 2
    assert "out must name a directory or a store, got ''" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_toml_with_a_byte_order_mark_is_read(tmp_path, config):
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + config.read_bytes())
    from rattlesweep.sweep import Sweep

    assert Sweep.from_toml(bom) == Sweep.from_toml(config)


def test_plot_of_a_file_that_is_not_netcdf_says_so(tmp_path, capsys):
    bad = tmp_path / "notes.nc"
    bad.write_text("not a result")
    assert main(["plot", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"cannot read {bad}: expected a rattlesweep result file (netCDF" in err
    assert "engine" not in err and "Traceback" not in err


def test_plot_of_a_sweep_directory_draws_its_result(tmp_path, config, capsys):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["plot", str(out)]) == 0  # what `info DIR` reads, plot draws
    png = out / "sweep_outcome.png"
    shown, wrote = capsys.readouterr().out.strip().splitlines()
    # the dimensions not drawn are shown at their first values, and it says so
    assert shown.startswith(f"{out}: outcome at mu = 0.3, repeat = 0 (the first values")
    assert wrote == f"wrote {png}"
    assert png.read_bytes().startswith(b"\x89PNG")
    assert main(["plot", str(out), "--facet", "mu", "--select", "repeat=1"]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {png}"
    (out / "sweep.nc").unlink()  # and a tile not written yet: an unfinished sweep
    (out / "tiles" / "tile-000001.nc").unlink()
    assert main(["plot", str(out)]) == 2
    assert (
        f"cannot plot {out}: the sweep is unfinished (no sweep.nc yet); "
        f"`rattlesweep resume {out}` completes it" in capsys.readouterr().err
    )
    assert main(["plot", str(tmp_path)]) == 2
    assert (
        f"cannot plot {tmp_path}: a directory without sweep.nc or sweep.toml"
        in capsys.readouterr().err
    )


def test_plot_options_that_cannot_be_drawn_are_named_before_anything_is_written(
    tmp_path, config, capsys
):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    refused = [
        # the configuration's name for the axis, not the result's
        (["--x", "spin"], "--x spin: results name it launch_spin"),
        (["--select", "mu=abc"], "select: mu takes a number, got 'abc'"),
        (["--select", "repeat=x"], "select: repeat takes a number, got 'x'"),
        (["--select", "mu=nan"], "select: mu = nan is not within its axis, 0.3 .. inf"),
        (["--select", "launch_spin=100"], "select: 'launch_spin' is drawn (as x)"),
        (["--facet", "mu", "--select", "mu=0.3"], "select: 'mu' is drawn (as facet)"),
        (["--select", "mu=0.3", "--select", "mu=inf"], "--select mu is given twice"),
        (["--versus", str(out)], "the stability result has no e_folding_time"),
        (["--versus", str(out), "--select", "mu=0.3"], "--select does not apply to it"),
        ([str(out), "--out", str(tmp_path / "a.png")], "--out names one PNG, for one"),
    ]
    for options, message in refused:
        assert main(["plot", str(out), *options]) == 2, options
        captured = capsys.readouterr()
        assert message in captured.err and "Traceback" not in captured.err
        assert captured.out == ""  # no note about what would have been drawn
    # a value between two of an axis is drawn at the nearer, and said so
    assert main(["plot", str(out), "--select", "mu=0.5", "--select", "repeat=0"]) == 0
    assert f"{out}: mu = 0.5 is not on its axis: drawn at the nearest value, 0.3" in (
        capsys.readouterr().out
    )
    for png in out.glob("*.png"):
        png.unlink()
    assert not list(tmp_path.glob("*.png")) and not list(out.glob("*.png"))
    # a one-axis sweep: a map needs two (its dimensions were read as letters)
    one = tmp_path / "one.toml"
    one.write_text("[axes]\nspin = [1.0, 2.0]\n[fixed]\nt_end = 0.2\n")
    assert main(["sweep", str(one), "--out", str(tmp_path / "one"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["plot", str(tmp_path / "one")]) == 2
    assert "a map needs two dimensions, found ['launch_spin']" in capsys.readouterr().err
    # a PNG path without its suffix is written with it, and named so
    assert main(["plot", str(out), "--out", str(tmp_path / "map")]) == 0
    assert capsys.readouterr().out.endswith(f"wrote {tmp_path / 'map.png'}\n")
    assert (tmp_path / "map.png").is_file()


def test_info_counts_only_complete_tiles(tmp_path, config, capsys):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    (out / "sweep.nc").unlink()
    tiles = sorted((out / "tiles").glob("tile-*.nc"))
    tiles[0].write_bytes(tiles[0].read_bytes()[:100])  # what a kill mid-write of old left
    tiles[1].unlink()
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    n = len(tiles)
    assert (
        f"tiles written: {n - 2} of {n} (complete and readable), 1 damaged"
        in capsys.readouterr().out
    )


# --- info and plot say when an output is damaged ----------------------------------------


def _corrupt(path, at=40_000, n=3_000):
    data = bytearray(path.read_bytes())
    data[at : at + n] = b"\xff" * n
    path.write_bytes(bytes(data))


def test_info_and_plot_of_a_directory_with_a_corrupt_sweep_nc_say_it_is_damaged(
    tmp_path, config, capsys
):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    _corrupt(out / "sweep.nc")
    capsys.readouterr()
    assert main(["info", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"rattlesweep info: warning: {out} is damaged (4 of 4 tiles verified" in err
    assert "sweep.nc is damaged (its bytes differ from the digest" in err
    # one line of warning, one that ends the command: it was a block of three and one
    warning, last = err.strip().splitlines()
    assert last.startswith(f"rattlesweep info: cannot read {out / 'sweep.nc'}: ")
    assert f"`rattlesweep resume {out}` recomputes what is missing or damaged" in err
    assert "expected a rattlesweep result file" not in err  # it is one, damaged
    assert main(["plot", str(out / "sweep.nc")]) == 2
    err = capsys.readouterr().err
    assert f"rattlesweep plot: warning: {out} is damaged" in err
    assert (
        "sweep.nc is damaged (its bytes differ from the digest" in err
        and "rattlesweep resume" in err
    )


def test_info_of_a_finished_directory_names_a_deleted_tile_as_missing(
    tmp_path, config, capsys
):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    (out / "tiles" / "tile-000001.nc").unlink()
    capsys.readouterr()
    assert main(["info", str(out)]) == 0  # sweep.nc itself is sound
    captured = capsys.readouterr()
    assert "outcomes:" in captured.out
    assert "missing (deleted after the sweep finished): 1 tile (tile 1)" in captured.err
    assert f"`rattlesweep resume {out}` recomputes" in captured.err


def test_info_of_a_sound_output_warns_of_nothing(tmp_path, config, capsys):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["info", str(out), str(out / "sweep.nc")]) == 0
    assert capsys.readouterr().err == ""


def test_info_of_a_zarr_store_with_a_chunk_deleted_says_which_tile(
    tmp_path, config, capsys
):
    pytest.importorskip("zarr")
    store = tmp_path / "z.zarr"
    assert (
        main(["sweep", str(config), "--out", str(store), "--output", "zarr", "--quiet"])
        == 0
    )
    chunks = sorted(store.glob("outcome/c/*/*/*/*"))
    chunks[2].unlink()
    capsys.readouterr()
    assert main(["info", str(store)]) == 0
    captured = capsys.readouterr()
    assert "not computed" in captured.out  # what the store reads as, now explained:
    assert (
        f"rattlesweep info: warning: {store} is damaged (3 of 4 tiles verified"
        in captured.err
    )
    assert "damaged: tile 2: chunk outcome/c/2" in captured.err
    assert f"`rattlesweep resume {store}` recomputes" in captured.err


def test_verify_says_1_tile_and_not_computed_yet_for_an_unfinished_directory(
    tmp_path, config, capsys
):
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    (out / "sweep.nc").unlink()  # as before the merge
    (out / "tiles" / "tile-000003.nc").unlink()
    capsys.readouterr()
    assert main(["verify", str(out)]) == 1
    text = capsys.readouterr().out
    assert "3 of 4 tiles verified" in text
    assert "not computed yet: 1 tile (tile 3)" in text


# --- a netCDF sweep writes only into a directory of its own ------------------------------


def test_a_directory_holding_other_files_is_refused_and_left_untouched(
    tmp_path, config, capsys
):
    mine = tmp_path / "mine"
    (mine / "data").mkdir(parents=True)
    (mine / "notes.txt").write_text("keep")
    (mine / "results.csv").write_text("1,2")
    before = sorted(p.relative_to(mine) for p in mine.rglob("*"))
    assert main(["sweep", str(config), "--out", str(mine), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"output {mine} holds 3 other files (the first: data/) and no sweep.toml" in err
    assert "Give a new or empty directory" in err
    assert sorted(p.relative_to(mine) for p in mine.rglob("*")) == before  # no lock either
    (mine / "data").rmdir()
    (mine / "results.csv").unlink()
    assert main(["sweep", str(config), "--out", str(mine), "--quiet", "--refine", "1"]) == 2
    assert "holds 1 other file (notes.txt) and no sweep.toml" in capsys.readouterr().err


def test_an_empty_directory_or_one_a_killed_start_left_is_used(tmp_path, config):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["sweep", str(config), "--out", str(empty), "--quiet"]) == 0
    started = tmp_path / "started"  # killed before sweep.toml was written
    (started / "tiles").mkdir(parents=True)
    (started / ".sweep.toml.tmp").write_text("")
    assert main(["sweep", str(config), "--out", str(started), "--quiet"]) == 0
    # a sweep's own directory may hold other files (a map drawn beside its result)
    (started / "map.png").write_bytes(b"png")
    assert main(["sweep", str(config), "--out", str(started), "--quiet"]) == 0


# --- messages that say what is wrong -----------------------------------------------------


@pytest.mark.parametrize("refine", [None, "1"])
def test_a_file_where_the_tiles_directory_goes_is_named(tmp_path, config, capsys, refine):
    out = tmp_path / "o"
    out.mkdir()
    in_the_way = out / ("levels" if refine else "tiles")
    in_the_way.write_text("a file")
    extra = ["--refine", refine] if refine else []
    assert main(["sweep", str(config), "--out", str(out), "--quiet", *extra]) == 2
    err = capsys.readouterr().err
    assert f"{in_the_way} is in the way: a sweep keeps its tile files in a directory" in err
    assert "Errno" not in err
    assert in_the_way.read_text() == "a file"


def test_a_long_run_warning_is_one_line_of_the_command(tmp_path):
    config = tmp_path / "long.toml"
    config.write_text(small_sweep(fixed={"t_end": 1.0, "damping": 1e3}).to_toml())
    in_the_way = tmp_path / "a-file"
    in_the_way.write_text("")  # the sweep is refused after its announcement
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "sweep",
            str(config),
            "--out",
            str(in_the_way),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    warning, error = done.stderr.splitlines()
    assert warning.startswith("rattlesweep: warning: this sweep takes up to ")
    assert "core-minutes" in warning
    assert error.startswith(f"rattlesweep: error: output {in_the_way} exists")


def test_a_netcdf_output_never_replaces_another_kind_of_file(tmp_path, config, capsys):
    """``stability CONFIG --out CONFIG`` wrote netCDF over the configuration; ``export``
    into a directory failed with the name of its temporary file."""
    kept = config.read_bytes()
    for argv in (
        ["stability", str(config), "--out", str(config)],
        ["simulate", "--t-end", "0.05", "--out", str(config)],
    ):
        assert main(argv) == 2
        assert (
            f"output {config} exists and is not a netCDF file: not overwriting it"
            in capsys.readouterr().err
        )
        assert config.read_bytes() == kept
    # a sweep's own files, which carry their digest
    sweep_dir = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(sweep_dir), "--quiet"]) == 0
    merged = (sweep_dir / "sweep.nc").read_bytes()
    assert main(["stability", str(config), "--out", str(sweep_dir / "sweep.nc")]) == 2
    assert f"output {sweep_dir / 'sweep.nc'} is a sweep's file (its digest" in (
        capsys.readouterr().err
    )
    assert (sweep_dir / "sweep.nc").read_bytes() == merged
    assert main(["export", str(sweep_dir), str(tmp_path / "x.nc")]) == 2
    assert "is a netCDF sweep's directory, not a zarr store: its result is" in (
        capsys.readouterr().err
    )
    store = tmp_path / "s.zarr"
    assert (
        main(["sweep", str(config), "--out", str(store), "--output", "zarr", "--quiet"])
        == 0
    )
    assert main(["export", str(store), str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"output {tmp_path} is a directory; give the netCDF file's path" in err
    assert ".tmp" not in err
    # a netCDF file, or an empty one, is replaced as before; folders are made for both
    # kinds of output
    nc = tmp_path / "new" / "e.nc"
    for _ in range(2):
        assert main(["export", str(store), str(nc)]) == 0
    empty = tmp_path / "empty.nc"
    empty.touch()
    png = tmp_path / "pictures" / "spin.png"
    assert (
        main(["simulate", "--t-end", "0.05", "--out", str(empty), "--png", str(png)]) == 0
    )
    assert png.is_file() and empty.stat().st_size > 0


def test_verify_and_resume_take_a_merged_file_for_its_directory(tmp_path, config, capsys):
    """``verify DIR/sweep.nc`` said 'DIR/sweep.nc/sweep.toml not found', where info and
    plot take that path; and a path that holds no sweep stopped verify's other paths."""
    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    missing = tmp_path / "nothing"
    assert main(["verify", str(missing), str(out / "sweep.nc"), str(config)]) == 2
    captured = capsys.readouterr()
    assert captured.out == f"{out}: 4 of 4 tiles verified\n"
    assert f"rattlesweep verify: {missing} does not exist" in captured.err
    assert f"rattlesweep verify: {config} is a file: expected a sweep directory" in (
        captured.err
    )
    assert main(["resume", str(out / "sweep.nc"), "--quiet"]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {out / 'sweep.nc'}: ")


def test_info_and_verify_of_an_output_being_written_name_its_writer(
    tmp_path, config, capsys
):
    """They advised `rattlesweep resume DIR` for a sweep still running, which the lock
    would refuse."""
    import os

    from rattlesweep.sweep._execution.lock import LOCK_NAME, SweepLock

    out = tmp_path / "o"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    (out / "sweep.nc").unlink()
    (out / "tiles" / "tile-000001.nc").unlink()
    capsys.readouterr()
    writing = f"a sweep is writing it now: process {os.getpid()} on this host"
    with SweepLock(out.resolve() / LOCK_NAME):  # as a sweep running in this process
        assert main(["info", str(out)]) == 0
        assert f"3 of 4 (complete and readable); {writing}" in capsys.readouterr().out
        assert main(["verify", str(out)]) == 1
        report = capsys.readouterr().out
        assert writing in report and "rattlesweep resume" not in report
    assert main(["info", str(out)]) == 0
    assert f"`rattlesweep resume {out}` completes it" in capsys.readouterr().out


def test_info_gives_the_fixed_values_with_their_units(tmp_path, capsys):
    # t_end given in ms was listed as t_end=2000.0, read as seconds
    path = tmp_path / "ms.toml"
    path.write_text(
        '[axes]\nspin = [1.0, 2.0]\n[fixed]\nt_end = { value = 200, units = "ms" }\n'
        "mu = 0.3\nroll_deg = 0.5\n"
    )
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "o")]) == 0
    fixed = next(line for line in capsys.readouterr().out.splitlines() if "fixed:" in line)
    assert "t_end=200.0 ms" in fixed and "roll_deg=0.5 degree" in fixed
    assert "mu=0.3," in fixed + ","  # dimensionless: no unit


def test_plot_of_an_unfinished_zarr_store_says_so(tmp_path, config, capsys, monkeypatch):
    # it drew the points not computed yet without a word
    from rattlesweep.sweep._execution import run as run_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    store = tmp_path / "s.zarr"
    monkeypatch.setattr(run_module, "run_tiles", interrupted)  # laid out, no tile
    argv = ["sweep", str(config), "--out", str(store), "--output", "zarr", "--quiet"]
    assert main(argv) == 130
    monkeypatch.undo()
    capsys.readouterr()
    assert main(["plot", str(store), "--out", str(tmp_path / "m.png")]) == 0
    assert (
        f"{store} is unfinished (0 of 4 tiles written; `rattlesweep resume {store}` "
        "completes it): its points not computed yet are drawn as such"
    ) in capsys.readouterr().out


def test_info_of_a_store_whose_configuration_is_unreadable_does_not_advise_resume(
    tmp_path, config, capsys
):
    """resume reads the same configuration and refuses it: info says what can be done."""
    import json

    pytest.importorskip("zarr")
    store = tmp_path / "z.zarr"
    main(["sweep", str(config), "--out", str(store), "--output", "zarr", "--quiet"])
    meta = store / "zarr.json"
    doc = json.loads(meta.read_text())
    doc["attributes"]["sweep_config"] = "garbage = 1"
    meta.write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["info", str(store)]) == 2
    err = capsys.readouterr().err
    assert "it cannot be verified; restore it from a copy, or run the sweep again" in err
    assert "resume" not in err.splitlines()[-1]
    assert main(["resume", str(store)]) == 2  # what info no longer advises
