"""resume removes the temporary files of a killed write, and only those: a file of the
user's that merely looks like one is kept."""

import os
from pathlib import Path

import pytest
import xarray as xr

from rattlesweep.sweep import run_sweep
from sweep_helpers import small_sweep


@pytest.mark.parametrize("refine", [False, True])
def test_resume_keeps_user_files_that_look_like_its_temporaries(tmp_path, refine):
    out = tmp_path / "run"
    s = (
        small_sweep(tile_size=3, refine={"levels": 1})
        if refine
        else small_sweep(tile_size=3)
    )
    run_sweep(s, out, progress=False)
    tiles = out / ("levels/level-0" if refine else "tiles")
    mine = [
        out / ".sweep.nc.mine.tmp",
        out / ".sweep.nc.12.abcdefghi.tmp",  # 9 random characters: not tempfile's
        out / ".sweep.nc.abcdefgh.tmp",  # no pid
        tiles / ".tile-000001.nc.x.tmp",
        tiles / ".tile-000001.nc.x.abcdefgh.tmp",  # the pid is not a number
        tiles / ".notes.txt.12.abcdefgh.tmp",  # not a tile's
    ]
    for path in mine:
        path.write_bytes(b"mine")
    orphan = tiles / ".tile-000001.nc.77.a_b1c2d3.tmp"  # what a killed tile write leaves
    orphan.write_bytes(b"partial")
    run_sweep(s, out, progress=False)
    assert not orphan.exists()
    assert all(path.read_bytes() == b"mine" for path in mine)


def test_write_netcdf_temporaries_have_the_format_resume_removes(tmp_path, monkeypatch):
    import rattlesweep.io as rio

    seen = []
    real = xr.Dataset.to_netcdf

    def spy(self, path, *args, **kwargs):
        seen.append(Path(path))
        return real(self, path, *args, **kwargs)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", spy)
    rio.write_netcdf(xr.Dataset({"x": ("i", [1.0])}), tmp_path / "tile-000003.nc")
    (tmp,) = seen
    assert tmp.name.startswith(f".tile-000003.nc.{os.getpid()}.")
    tmp.write_bytes(b"partial")
    assert rio.stale_temporaries(tmp_path, "tile-*.nc") == [tmp]


def test_a_digest_temporary_goes_with_its_file(tmp_path):
    """A kill between a digest's temporary and its rename leaves one; it is listed with
    the temporaries of the file it belongs to, and a look-alike is not."""
    import rattlesweep.io as rio

    fd, name = rio._temporary(rio.digest_path(tmp_path / "tile-000003.nc"))
    os.close(fd)
    digest_tmp = Path(name)
    assert digest_tmp.name.startswith(".tile-000003.nc.b2sum.")
    (tmp_path / ".tile-000003.nc.b2sum.x.tmp").write_text("")  # not of the form
    assert rio.stale_temporaries(tmp_path, "tile-*.nc") == [digest_tmp]
