"""Sweeps on a dask.distributed cluster: workers that never touch the output (plain and
refined sweeps), a worker killed mid-sweep, a client killed mid-sweep and resumed."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rattlesweep.sweep import Sweep, resume, run_sweep
from rattlesweep.sweep._execution.run import RESULT_NAME
from sweep_helpers import (
    KILL_TOML,
    as_zarr,
    assert_same_file,
    file_stats,
    small_sweep,
    without_config,
)

distributed = pytest.importorskip("distributed")

AUDIT = str(Path(__file__).with_name("worker_audit.py"))


def _cluster(tmp_path, **kwargs):
    return distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, **kwargs
    )


def _under(path: str, root: Path) -> bool:
    return os.path.commonpath(
        [os.path.realpath(path), os.path.realpath(root)]
    ) == os.path.realpath(root)


def test_workers_never_touch_the_output(tmp_path):
    """Two worker processes, each in a working directory of its own, with an audit hook
    recording every path they open, create, rename, remove or list; the outputs (a
    netCDF directory and a zarr store) in a third directory, written by this process
    only. Both equal the sweep on local threads, and so does one sent through the
    scheduler's address (as the CLI's --scheduler does)."""
    import worker_audit

    s = small_sweep()
    threads = run_sweep(s, tmp_path / "threads", progress=False)
    refined = small_sweep(refine={"levels": 1})
    run_sweep(refined, tmp_path / "threads-refined", progress=False)
    out = tmp_path / "out"
    out.mkdir()
    with (
        _cluster(
            tmp_path, local_directory=str(tmp_path / "workers"), preload=[AUDIT]
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        cwds = client.run(worker_audit.working_directory)
        assert len(set(cwds.values())) == 2
        assert not any(_under(c, out) for c in cwds.values())
        nc = run_sweep(s, out / "nc", client=client, progress=False)
        zr = run_sweep(as_zarr(s), out / "run.zarr", client=client, progress=False)
        by_address = run_sweep(
            s, out / "address", scheduler=cluster.scheduler_address, progress=False
        )
        run_sweep(refined, out / "refined", client=client, progress=False)
        # the hook sees what a worker writes: a file written by a task is recorded
        canary = tmp_path / "canary.txt"
        client.submit(Path.write_text, canary, "x", pure=False).result()
        touched = client.run(worker_audit.touched)
    recorded = [p for paths in touched.values() for p in paths]
    assert str(canary) in recorded
    assert [p for p in recorded if _under(p, out)] == []
    # under the test's directory they touched their own directories only
    assert [
        p
        for p in recorded
        if _under(p, tmp_path) and not _under(p, tmp_path / "workers") and p != str(canary)
    ] == []
    for ds in (nc, by_address, zr.load()):
        xr.testing.assert_identical(without_config(threads), without_config(ds))
    assert_same_file(tmp_path / "threads" / RESULT_NAME, out / "nc" / RESULT_NAME)
    assert_same_file(
        tmp_path / "threads-refined" / RESULT_NAME, out / "refined" / RESULT_NAME
    )


def test_a_worker_killed_mid_sweep_loses_nothing(tmp_path):
    s = Sweep.from_toml(
        KILL_TOML.replace("t_end = 30.0", "t_end = 10.0").replace(
            "tile_size = 256", "tile_size = 128"
        )
    )
    reference = run_sweep(s, tmp_path / "threads", progress=False)
    out = tmp_path / "cluster"
    killed = {}
    with _cluster(tmp_path) as cluster, distributed.Client(cluster) as client:
        pids = client.run(os.getpid)

        def kill_a_busy_worker():
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not killed:
                done = len(list((out / "tiles").glob("tile-*.nc")))
                busy = [w for w, keys in client.processing().items() if keys]
                if done >= 2 and busy:
                    killed.update(pid=pids[busy[0]], done=done)
                    os.kill(pids[busy[0]], signal.SIGKILL)
                time.sleep(0.01)

        killer = threading.Thread(target=kill_a_busy_worker)
        killer.start()
        result = run_sweep(s, out, client=client, progress=False)
        killer.join()
        assert killed and 2 <= killed["done"] < s.n_tiles, "the kill must land mid-sweep"
        with pytest.raises(ProcessLookupError):
            os.kill(killed["pid"], 0)
    xr.testing.assert_identical(without_config(reference), without_config(result))


def test_a_client_killed_mid_sweep_resumes_without_recomputing(tmp_path):
    """The client (the CLI, sending tiles to a cluster by its address and writing a zarr
    store) is killed mid-sweep; a resume on the same cluster completes the store without
    writing again the tiles that were done."""
    from rattlesweep.sweep._outputs.zarr_store import tiles_done

    pytest.importorskip("zarr")
    config = tmp_path / "kill.toml"
    config.write_text(
        KILL_TOML.replace("t_end = 30.0", "t_end = 10.0").replace(
            "tile_size = 256", "tile_size = 128"
        )
    )
    s = as_zarr(Sweep.from_toml(config))
    store = tmp_path / "run.zarr"
    with _cluster(tmp_path) as cluster, distributed.Client(cluster) as client:
        client.run(lambda: None)
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rattlesweep.cli",
                "sweep",
                str(config),
                "--out",
                str(store),
                "--output",
                "zarr",
                "--scheduler",
                cluster.scheduler_address,
                "--quiet",
            ]
        )
        done = None
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                done = tiles_done(str(store), s.n_tiles)
            except Exception:  # not laid out yet
                done = None
            if done is not None and done.sum() >= 2:
                break
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        done = tiles_done(str(store), s.n_tiles)
        assert 2 <= done.sum() < s.n_tiles, "the kill must land mid-sweep"
        before = file_stats(store, "*")
        result = resume(store, client=client, progress=False).load()
    after = file_stats(store, "*")
    for tile in np.flatnonzero(done):
        key = "status/c/" + "/".join(
            str(r.start // b) for r, b in zip(s.tile_region(tile), s.tile_shape)
        )
        assert after[key] == before[key], "a finished tile was written again"
    reference = run_sweep(Sweep.from_toml(config), tmp_path / "threads", progress=False)
    xr.testing.assert_identical(without_config(reference), without_config(result))
