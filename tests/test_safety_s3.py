"""A zarr sweep into an object store, for real: a local S3-compatible server (moto's
server mode) on 127.0.0.1, reached through s3fs, as a user's bucket would be. A sweep is
killed mid-way, verified, resumed, exported, and a damaged object is found and
recomputed."""

import os
import signal
import subprocess
import sys
import time

import pytest
import xarray as xr

from rattlesweep.cli import main

from rattlesweep.sweep import Sweep, run_sweep
from rattlesweep.sweep._execution.run import export
from rattlesweep.sweep._outputs.verify import verify
from sweep_helpers import without_config

pytest.importorskip("zarr")
pytest.importorskip("s3fs", reason="the S3 tests need s3fs (the test extra)")
moto_server = pytest.importorskip(
    "moto.server", reason="the S3 tests need moto[server] (the test extra)"
)
boto3 = pytest.importorskip("boto3")

BUCKET = "rattlesweep-test"
S3_TOML = """\
name = "object store"
output = "zarr"
tile_size = 16
[axes]
spin = { start = -20, stop = 20, num = 16 }
delta_deg = { start = -6, stop = 6, num = 8 }
[fixed]
t_end = 1.0
mu = 0.3
roll_deg = 0.5
"""
"""8 tiles of 16 launches, each a fraction of a second on one core."""


@pytest.fixture(scope="module")
def s3():
    """The server's address, with a bucket; the credentials it takes are any."""
    server = moto_server.ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    url = f"http://{host}:{port}"
    boto3.client(
        "s3",
        endpoint_url=url,
        aws_access_key_id="testing",
        aws_secret_access_key="testing",
        region_name="us-east-1",
    ).create_bucket(Bucket=BUCKET)
    yield url
    server.stop()


def _options(url):
    return {
        "key": "testing",
        "secret": "testing",
        "endpoint_url": url,
        "client_kwargs": {"region_name": "us-east-1"},
    }


def _env(url):
    """What a user's shell would set: credentials and the endpoint, for the CLI (fsspec
    reads FSSPEC_S3_* as s3fs arguments)."""
    return {
        **os.environ,
        "FSSPEC_S3_KEY": "testing",
        "FSSPEC_S3_SECRET": "testing",
        "FSSPEC_S3_ENDPOINT_URL": url,
        "AWS_DEFAULT_REGION": "us-east-1",
    }


def _fs(url):
    import s3fs

    return s3fs.S3FileSystem(**_options(url))


def test_zarr_sweep_into_s3_killed_verified_resumed_exported_and_damage_found(
    s3, tmp_path, monkeypatch, capsys
):
    config = tmp_path / "s3.toml"
    config.write_text(S3_TOML)
    sweep = Sweep.from_toml(config)
    store = f"s3://{BUCKET}/run.zarr"
    fs = _fs(s3)
    opts = _options(s3)

    # the CLI, as a user runs it, killed (SIGKILL: no cleanup) after a few tiles
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "sweep",
            str(config),
            "--out",
            store,
            "--workers",
            "1",
            "--quiet",
        ],
        env=_env(s3),
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if len(fs.find(f"{BUCKET}/run.zarr/status/c", refresh=True)) >= 2:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL, err

    found = verify(store, opts)
    assert not found.damaged and 0 < len(found.missing) < sweep.n_tiles, found.report()
    # an unfinished store is not exported
    with pytest.raises(ValueError, match="unfinished"):
        export(store, tmp_path / "early.nc", opts)

    # resume, through the CLI with the endpoint from the environment
    resumed = subprocess.run(
        [sys.executable, "-m", "rattlesweep.cli", "resume", store, "--quiet"],
        env=_env(s3),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert resumed.returncode == 0, resumed.stderr
    assert verify(store, opts).ok
    # the other commands in this process, configured as fsspec reads FSSPEC_S3_*
    import fsspec.config

    monkeypatch.setitem(
        fsspec.config.conf,
        "s3",
        {"key": "testing", "secret": "testing", "endpoint_url": s3},
    )
    assert main(["verify", store]) == 0
    assert f"{sweep.n_tiles} of {sweep.n_tiles} tiles verified" in capsys.readouterr().out

    # the exported file equals a local netCDF sweep of the same configuration
    export(store, tmp_path / "s3.nc", opts)
    local = run_sweep(
        Sweep(**{**sweep.to_dict(), "output": "netcdf"}), tmp_path / "local", progress=False
    )
    with xr.open_dataset(tmp_path / "s3.nc") as got:
        xr.testing.assert_identical(without_config(got.load()), without_config(local))

    # an object changed in the bucket (a partial or corrupted upload) is found, named,
    # refused by export and recomputed by resume
    key = sorted(fs.find(f"{BUCKET}/run.zarr/final_spin/c"))[3]
    data = bytearray(fs.cat(key))
    data[len(data) // 2] ^= 0x10
    fs.pipe(key, bytes(data))
    found = verify(store, opts)
    assert list(found.damaged) == [3] and "checksum" in found.damaged[3]
    assert main(["verify", store]) == 1
    assert "damaged: tile 3: chunk final_spin/" in capsys.readouterr().out
    assert main(["export", store, str(tmp_path / "bad.nc")]) == 2
    assert (
        "1 of 8 tiles are missing or damaged (tile 3: chunk final_spin/"
        in capsys.readouterr().err
    )
    assert not (tmp_path / "bad.nc").exists()
    run_sweep(sweep, store, storage_options=opts, progress=False)
    assert verify(store, opts).ok
    export(store, tmp_path / "again.nc", opts)
    with (
        xr.open_dataset(tmp_path / "s3.nc") as a,
        xr.open_dataset(tmp_path / "again.nc") as b,
    ):
        xr.testing.assert_identical(without_config(a.load()), without_config(b.load()))
