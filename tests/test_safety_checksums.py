"""Every numeric array of a sweep's netCDF files carries HDF5's fletcher32 checksums, so a
byte changed on disk fails the read (named by verify, info and plot) instead of reading
as another value; the values written are the same."""

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
from sweep_helpers import small_sweep


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
    assert err.startswith(f"rattlesweep info: cannot read {alone}: it is damaged (")
    assert "checksum" in err and "Traceback" not in err

    plot = subprocess.run(
        [sys.executable, "-m", "rattlesweep.cli", "plot", str(alone)],
        capture_output=True,
        text=True,
    )
    assert plot.returncode == 2 and "Traceback" not in plot.stderr, plot.stderr
    assert f"cannot read {alone}: it is damaged (" in plot.stderr

    shutil.copy(alone, merged)
    found = verify(out)
    assert not found.ok
    assert any("sweep.nc cannot be read in full" in p for p in found.problems)
    assert main(["info", str(out)]) == 2
    err = capsys.readouterr().err
    assert "warning:" in err and f"rattlesweep resume {out}" in err
    assert "Traceback" not in err
    assert not np.isnan(ds.launch_spin.values).any()
