"""Every numeric array of a sweep's netCDF files carries HDF5's fletcher32 checksums, so a
byte changed on disk fails the read (named by verify, info and plot) instead of reading
as another value; the values written are the same."""

import json
import shutil
import subprocess
import sys

import netCDF4
import numpy as np
import xarray as xr

from rattlesweep.cli import main
from rattlesweep.sweep import run_sweep
from rattlesweep.sweep._execution.run import RESULT_NAME
from rattlesweep.sweep._outputs.verify import verify
from sweep_helpers import REFINED_TOML, small_sweep


def _checksummed(path):
    with netCDF4.Dataset(path) as nc:
        return {k: v.filters()["fletcher32"] for k, v in nc.variables.items() if v.ndim}


def test_sweep_nc_and_tiles_are_checksummed_and_a_changed_byte_is_named(tmp_path, capsys):
    out = tmp_path / "run"
    ds = run_sweep(small_sweep(tile_size=3), out, progress=False)
    merged = out / RESULT_NAME
    assert all(_checksummed(merged).values()) and len(_checksummed(merged)) > 16
    assert all(_checksummed(next((out / "tiles").glob("tile-*.nc"))).values())
    with xr.open_dataset(merged) as back:  # the data as computed
        xr.testing.assert_equal(back.load(), ds)

    # one bit of the launch_spin axis's stored values (kept uncompressed, so found):
    # it read as another spin, silently, where no sweep.toml is beside the file
    raw = merged.read_bytes()
    at = raw.find(ds.launch_spin.values.tobytes())
    assert at > 0
    damaged = bytearray(raw)
    damaged[at + 9] ^= 0x01
    alone = tmp_path / "copy.nc"
    alone.write_bytes(bytes(damaged))
    assert main(["info", str(alone)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"rattlesweep info: cannot read {alone}: copy.nc is damaged (")
    assert "checksum" in err and "Traceback" not in err

    plot = subprocess.run(
        [sys.executable, "-m", "rattlesweep.cli", "plot", str(alone)],
        capture_output=True,
        text=True,
    )
    assert plot.returncode == 2 and "Traceback" not in plot.stderr, plot.stderr
    assert f"cannot read {alone}: copy.nc is damaged (" in plot.stderr

    shutil.copy(alone, merged)
    found = verify(out)
    assert not found.ok
    # in its directory, the file differs from the digest recorded when it was written
    assert any("sweep.nc is damaged (its bytes differ" in p for p in found.problems)
    assert main(["info", str(out)]) == 2
    err = capsys.readouterr().err
    assert "warning:" in err and f"rattlesweep resume {out}" in err
    assert "Traceback" not in err
    assert not np.isnan(ds.launch_spin.values).any()


def _flip(path, at, n=8):
    data = bytearray(path.read_bytes())
    data[at : at + n] = bytes(b ^ 0xFF for b in data[at : at + n])
    path.write_bytes(bytes(data))


# the commands in one process of their own (the libraries load once): a crash of the
# netCDF library (a segmentation fault, an abort) ends that process, not the tests'
_COMMANDS = """
import contextlib, io, json, sys
from rattlesweep.cli import main
done = []
for argv in json.loads(sys.argv[1]):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(argv)
    done.append((status, out.getvalue(), err.getvalue()))
print(json.dumps(done))
"""


def _commands(*argvs):
    """Status, stdout and stderr of each ``rattlesweep`` command line in ``argvs``."""
    ran = subprocess.run(
        [sys.executable, "-c", _COMMANDS, json.dumps([list(map(str, a)) for a in argvs])],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert ran.returncode == 0, (ran.returncode, ran.stderr[-2000:])
    return json.loads(ran.stdout)


def test_damaged_hdf5_metadata_is_named_from_the_digest_before_the_library_opens_it(
    tmp_path,
):
    # bytes 2400-2407 of sweep.nc lie in its HDF5 metadata: netCDF-C crashed on opening
    # it (verify, plot: abort on a double free; info: segmentation fault), where Python
    # can catch nothing. The digest recorded beside each file is checked first
    out = tmp_path / "run"
    run_sweep(small_sweep(tile_size=3), out, progress=False)
    merged = out / RESULT_NAME
    assert (out / "sweep.nc.b2sum").read_text().endswith("  sweep.nc\n")
    assert (out / "tiles" / "tile-000003.nc.b2sum").is_file()
    _flip(merged, 2400)
    resume = f"`rattlesweep resume {out}` recomputes what is missing or damaged"
    (verified, *reading) = _commands(["verify", out], ["info", out], ["plot", merged])
    assert verified[0] == 1, verified
    assert "sweep.nc is damaged (its bytes differ from the digest" in verified[1]
    assert resume in verified[1]
    for status, _, err in reading:  # info, plot
        assert status == 2, (status, err)
        last = err.strip().splitlines()[-1]
        assert f"cannot read {merged}: sweep.nc is damaged" in last, last
        assert last.endswith(resume) and "Traceback" not in err

    # a tile's metadata: at these bytes netCDF-C read the tile without a complaint
    tile = out / "tiles" / "tile-000003.nc"
    _flip(tile, 2400)
    found = verify(out)
    assert list(found.damaged) == [3]
    assert found.damaged[3].startswith("tile-000003.nc is damaged (its bytes differ")
    assert main(["resume", str(out), "--quiet"]) == 0  # the tile and sweep.nc rewritten
    assert verify(out).ok


def test_damaged_files_without_digests_are_read_by_a_child_first(tmp_path):
    # a file copied away from its digest, and a directory of an older version (no
    # digests): netCDF-C crashed on both (abort on a double free) or gave a traceback.
    # Such a file is read in full by a child process first, and named when that fails

    out = tmp_path / "run"
    run_sweep(small_sweep(tile_size=3), out, progress=False)
    for digest in out.rglob("*.b2sum"):
        digest.unlink()
    alone = tmp_path / "alone.nc"
    shutil.copy(out / RESULT_NAME, alone)
    _flip(alone, 2400)
    _flip(out / RESULT_NAME, 2400)
    _flip(out / "tiles" / "tile-000002.nc", 100)
    (info, plot, verified, info_dir, plot_dir) = _commands(
        ["info", alone],
        ["plot", alone, "--out", tmp_path / "a.png"],
        ["verify", out],
        ["info", out],
        ["plot", out / RESULT_NAME, "--out", tmp_path / "b.png"],
    )
    for status, _, err in (info, plot, info_dir, plot_dir):
        last = err.strip().splitlines()[-1]
        assert status == 2 and "Traceback" not in err, (status, err)
        assert " is damaged (" in last and "cannot read " in last, last
    assert f"cannot read {alone}: alone.nc is damaged (reading it crashes" in info[2]
    assert verified[0] == 1
    assert "damaged: tile 2: tile-000002.nc is damaged (" in verified[1]
    assert "sweep.nc is damaged (reading it crashes the netCDF library" in verified[1]

    # one child reads many files; one that crashes it is named, a new one goes on
    from rattlesweep.io import unreadable_files

    good = tmp_path / "good.nc"
    shutil.copy(out / "tiles" / "tile-000003.nc", good)
    found = unreadable_files([alone, good, out / RESULT_NAME, out / "tiles/tile-000004.nc"])
    assert set(found) == {alone, out / RESULT_NAME}
    assert all("reading it crashes the netCDF library" in w for w in found.values())


REFINED = REFINED_TOML.replace("tile_size = 64", "tile_size = 8")


def test_verify_reads_every_level_tile_of_a_refined_sweep(tmp_path):
    # verify checked only sweep.nc of a refined sweep: "0 of 0 tiles verified", status 0
    from rattlesweep.sweep import Sweep

    out = tmp_path / "rd"
    run_sweep(Sweep.from_toml(REFINED), out, progress=False)
    levels = out / "levels"
    n = len(list(levels.glob("level-*/tile-*.nc")))
    assert verify(out).ok and verify(out).n_tiles == n > 12
    assert len(list(levels.glob("level-2/tile-*.nc"))) > 1
    (levels / "level-1" / "tile-000001.nc").unlink()
    _flip(levels / "level-2" / "tile-000000.nc", 2400)
    found = verify(out)
    assert found.finished and found.missing == ("1 of level 1",)
    assert list(found.damaged) == ["0 of level 2"]
    assert "tile-000000.nc is damaged (its bytes differ" in found.damaged["0 of level 2"]
    report = found.report()
    assert f"{n - 2} of {n} tiles verified" in report and "tile 1 of level 1" in report
    (info,) = _commands(["info", out])
    assert info[2].startswith(f"rattlesweep info: warning: {out} is damaged ({n - 2} of")
    assert "tile 1 of level 1" in info[2] and "and 1 more (`rattlesweep verify" in info[2]
