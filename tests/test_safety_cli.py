"""The sweep commands' arguments and messages: refused before anything is written, with a
message naming the argument."""

import pytest

from rattlesweep.cli import main
from sweep_helpers import small_sweep


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(small_sweep(tile_size=8).to_toml())
    return path


def test_negative_refine_is_refused_not_dropped(tmp_path, config, capsys):
    assert main(["sweep", str(config), "--out", str(tmp_path / "o"), "--refine", "-1",
                 "--quiet"]) == 2
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
    assert f"tiles written: {n - 2} of {n} (complete and readable), 1 damaged" in \
        capsys.readouterr().out
