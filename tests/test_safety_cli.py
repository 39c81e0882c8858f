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
