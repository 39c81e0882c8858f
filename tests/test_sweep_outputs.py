"""Sweep outputs: the zarr store (layout, a store read half-way, resume, equality with the
netCDF output, export) and the safety of an output: the lock against a second sweep,
stale locks, a disk that fills up, an edited or corrupted sweep.toml."""

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import xarray as xr

from rattlesweep.cli import main
from rattlesweep.sweep import Sweep, resume, run_sweep
from rattlesweep.sweep._execution.lock import LOCK_NAME, SweepLocked
from rattlesweep.sweep._execution.lock import SweepLock as SweepLock_
from rattlesweep.sweep._execution.run import RESULT_NAME, export
from rattlesweep.sweep._execution.tiles import NOT_COMPUTED, compute_tile
from sweep_helpers import (
    KILL_TOML,
    as_zarr,
    file_stats,
    small_sweep,
    without_config,
    without_history,
)

zarr = pytest.importorskip("zarr")

from rattlesweep.sweep._outputs.zarr_store import DONE_ARRAY, ZarrStore, tiles_done  # noqa: E402


def _cli(*args, **kwargs) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "rattlesweep.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


# --- zarr ------------------------------------------------------------------------------


def test_zarr_output_equals_netcdf_output_and_exports_to_the_same_file(tmp_path, capsys):
    s = small_sweep()
    nc = run_sweep(s, tmp_path / "nc", progress=False)
    z = as_zarr(s)
    assert z.differences(s) == ["output: 'zarr' -> 'netcdf'"]
    store = tmp_path / "run.zarr"
    lazy = run_sweep(z, store, progress=False)
    # lazy, chunked by tile, and nothing else was written next to the store
    assert lazy.outcome.data.chunksize == z.tile_shape
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nc", "run.zarr"]
    xr.testing.assert_identical(without_config(nc), without_config(lazy.load()))
    with xr.open_zarr(store) as reopened:
        xr.testing.assert_identical(without_config(nc), without_config(reopened.load()))
        assert Sweep.from_toml(reopened.attrs["sweep_config"]) == z

    exported = tmp_path / "exported.nc"
    assert main(["export", str(store), str(exported)]) == 0
    with xr.open_dataset(exported) as e:
        xr.testing.assert_identical(without_config(nc), without_config(e.load()))
    assert main(["info", str(store)]) == 0
    info = capsys.readouterr().out
    assert "spin (4), delta_deg (2), mu (2), repeat (2)" in info and "outcomes:" in info

    # the CLI chooses zarr by --output, or by the configuration's own key
    config = tmp_path / "s.toml"
    config.write_text(s.to_toml())
    assert (
        main(
            [
                "sweep",
                str(config),
                "--out",
                str(tmp_path / "cli.zarr"),
                "--output",
                "zarr",
                "--quiet",
            ]
        )
        == 0
    )
    config.write_text(z.to_toml())
    assert 'output = "zarr"' in z.to_toml()
    assert (
        main(["sweep", str(config), "--out", str(tmp_path / "toml.zarr"), "--quiet"]) == 0
    )
    for name in ("cli.zarr", "toml.zarr"):
        with xr.open_zarr(tmp_path / name) as ds:
            xr.testing.assert_identical(without_config(nc), without_config(ds.load()))


def test_zarr_store_read_half_way_is_consistent_and_resume_computes_only_the_rest(
    tmp_path, capsys
):
    s = as_zarr(small_sweep(tile_size=3))
    reference = run_sweep(small_sweep(tile_size=3), tmp_path / "reference", progress=False)
    path = tmp_path / "half.zarr"
    store = ZarrStore(s, path)
    todo = store.open()
    assert todo == list(range(s.n_tiles)) and s.n_tiles >= 8
    written = todo[::2]
    for tile in written:
        store.write(compute_tile(s, tile))
    # a tile whose write was cut short: every variable but status, and no done flag
    cut = compute_tile(s, todo[1])
    region = s.tile_region(cut.tile)
    shape = tuple(r.stop - r.start for r in region)
    for name, values in cut.data.items():
        if name != "status":
            store.group[name][region] = values.reshape(shape)
    store.close()

    complete = np.zeros(s.shape, dtype=bool)
    for tile in written:
        complete[s.tile_region(tile)] = True
    with xr.open_zarr(path) as half:
        half = half.load()
    assert set(half.data_vars) == set(reference.data_vars)
    np.testing.assert_array_equal(half.status.values != NOT_COMPUTED, complete)
    for name in reference.data_vars:
        np.testing.assert_array_equal(
            half[name].values[complete], reference[name].values[complete], err_msg=name
        )
    untouched = ~complete
    untouched[region] = False
    assert np.all(half.outcome.values[untouched] == NOT_COMPUTED)
    assert np.all(np.isnan(half.final_spin.values[untouched]))
    assert np.all(half.n_reversals.values[untouched] == -1)
    np.testing.assert_array_equal(
        tiles_done(str(path), s.n_tiles), np.isin(np.arange(s.n_tiles), written)
    )

    chunks_before = file_stats(path, "*")
    ds = resume(path)
    assert (
        f"resuming: {len(written)} of {s.n_tiles} tiles already done"
        in capsys.readouterr().err
    )
    after = file_stats(path, "*")
    for tile in written:  # their chunks were not written again
        key = "status/c/" + "/".join(
            str(r.start // b) for r, b in zip(s.tile_region(tile), s.tile_shape)
        )
        assert after[key] == chunks_before[key]
    xr.testing.assert_identical(without_config(reference), without_config(ds.load()))
    assert tiles_done(str(path), s.n_tiles).all()


def test_zarr_store_refuses_another_sweep_and_foreign_stores(tmp_path):
    s = as_zarr(small_sweep())
    run_sweep(s, tmp_path / "a.zarr", progress=False)
    other = as_zarr(small_sweep(seed=8))
    with pytest.raises(ValueError, match=r"holds a different sweep.*seed: 7 -> 8"):
        run_sweep(other, tmp_path / "a.zarr", progress=False)
    plain = tmp_path / "plain.zarr"
    xr.Dataset({"x": ("i", np.arange(3))}).to_zarr(plain, zarr_format=3, consolidated=False)
    with pytest.raises(ValueError, match="without a sweep configuration"):
        run_sweep(s, plain, progress=False)
    store = ZarrStore(s, tmp_path / "fresh.zarr")
    store.open()
    store.close()
    with pytest.raises(ValueError, match=r"unfinished \(8 of 8 tiles not computed\)"):
        export(tmp_path / "fresh.zarr", tmp_path / "x.nc")
    assert not (tmp_path / "x.nc").exists()
    # a zarr output never lays itself out over a directory holding something else
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    with pytest.raises(ValueError, match="exists and is not a zarr store"):
        run_sweep(s, tmp_path / "mine", progress=False)
    assert os.listdir(tmp_path / "mine") == ["notes.txt"]
    assert DONE_ARRAY in zarr.open_group(tmp_path / "fresh.zarr", mode="r")


# --- the lock --------------------------------------------------------------------------

HOLD = textwrap.dedent("""
    import sys, time
    from rattlesweep.sweep._execution.lock import SweepLock
    SweepLock(sys.argv[1]).acquire()
    print("held", flush=True)
    time.sleep(120)
""")


@pytest.mark.parametrize("output", ["netcdf", "zarr"])
def test_a_held_lock_refuses_a_second_sweep_and_a_killed_holder_leaves_it_stale(
    tmp_path, output
):
    s = small_sweep(output=output)
    out = tmp_path / "out"
    lock = out / LOCK_NAME if output == "netcdf" else tmp_path / "out.lock"
    lock.parent.mkdir(exist_ok=True)
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(lock)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(
            SweepLocked,
            match=rf"{out} is in use by another sweep: process "
            rf"{holder.pid} on this host",
        ):
            run_sweep(s, out, progress=False)
        assert sorted(os.listdir(tmp_path)) == (
            ["out"] if output == "netcdf" else ["out.lock"]
        )
        assert output == "zarr" or os.listdir(out) == [LOCK_NAME], (
            "a refused sweep writes nothing"
        )
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    assert lock.exists()  # left behind by the killed process
    run_sweep(s, out, progress=False)  # recognised as stale
    assert not lock.exists()


def test_stale_and_foreign_locks(tmp_path):
    lock = tmp_path / LOCK_NAME
    here = socket.gethostname()
    SweepLock = lambda d: SweepLock_(d / LOCK_NAME)
    # a process id now used by another program (pid 1 did not start at tick 0)
    lock.write_text(json.dumps({"host": here, "pid": 1, "started": "0"}))
    with SweepLock(tmp_path) as held:
        assert json.loads(lock.read_text())["pid"] == os.getpid()
        with pytest.raises(SweepLocked, match="process .* on this host"):
            SweepLock(tmp_path).acquire()
    assert held.held is False and not lock.exists()
    lock.write_text("garbage")  # not a lock this module wrote
    with SweepLock(tmp_path):
        pass
    # a lock taken on another host cannot be checked from here
    lock.write_text(
        json.dumps(
            {
                "host": "elsewhere",
                "pid": 12,
                "since": "2026-01-01T00:00",
                "command": "rattlesweep sweep x.toml",
            }
        )
    )
    with pytest.raises(
        SweepLocked,
        match=rf"process 12 on elsewhere, since 2026-01-01T00:00 "
        rf"\(rattlesweep sweep x.toml\); if that process is gone, remove {lock}",
    ):
        SweepLock(tmp_path).acquire()
    assert lock.exists()


def test_two_sweeps_started_at_once_into_one_directory(tmp_path):
    config = tmp_path / "kill.toml"
    config.write_text(KILL_TOML)
    out = tmp_path / "out"
    procs = [
        _cli("sweep", str(config), "--out", str(out), "--workers", "1", "--quiet")
        for _ in range(2)
    ]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    for p in procs:
        p.stdout.close()
        p.stderr.close()
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2], results
    refused = next(err for code, err in results if code == 2)
    assert "is in use by another sweep: process" in refused
    assert (out / RESULT_NAME).exists() and not (out / LOCK_NAME).exists()


# --- a full disk -----------------------------------------------------------------------

FULL_DISK = textwrap.dedent("""
    set -u
    mount -t tmpfs -o size=$SIZE tmpfs "$MNT" || exit 77
    "$PY" -m rattlesweep.cli sweep "$CONFIG" --out "$MNT/out" --workers 1 --quiet \\
        > "$LOG/first.out" 2> "$LOG/first.err"
    echo $? > "$LOG/first.rc"
    ls -la "$MNT/out" "$MNT/out/tiles" > "$LOG/listing" 2>&1
    "$PY" -m rattlesweep.cli info "$MNT/out" > "$LOG/info.out" 2>&1
    mount -o remount,size=64m "$MNT"
    "$PY" -m rattlesweep.cli resume "$MNT/out" --quiet \\
        > "$LOG/resume.out" 2> "$LOG/resume.err"
    echo $? > "$LOG/resume.rc"
    cp -r "$MNT/out" "$LOG/result"
""")


@pytest.mark.parametrize("output", ["netcdf", "zarr"])
def test_a_full_disk_stops_with_a_clear_error_and_resume_completes(tmp_path, output):
    """The sweep runs on a small tmpfs (mounted in a user and mount namespace of its
    own) that fills up mid-sweep; a resume after it is enlarged completes the sweep."""
    if shutil.which("unshare") is None:
        pytest.skip("needs unshare (util-linux)")
    s = small_sweep(tile_size=3, output=output, fixed={"t_end": 1.0, "damping": 1e-7})
    config = tmp_path / "s.toml"
    config.write_text(s.to_toml())
    reference = run_sweep(s, tmp_path / "reference", progress=False)
    # a tmpfs stores every file in whole pages; room for about half the output
    pages = sum(
        -(-f.stat().st_size // 4096)
        for f in (tmp_path / "reference").rglob("*")
        if f.is_file()
    )
    size = 4096 * max(2, pages // 2)
    mnt, log = tmp_path / "mnt", tmp_path / "log"
    mnt.mkdir()
    log.mkdir()
    env = dict(
        os.environ,
        SIZE=str(size),
        MNT=str(mnt),
        LOG=str(log),
        PY=sys.executable,
        CONFIG=str(config),
    )
    run = subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "bash", "-c", FULL_DISK],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    if run.returncode == 77 or not (log / "first.rc").exists():
        pytest.skip(f"cannot mount a tmpfs in a user namespace here: {run.stderr[-300:]}")
    first_err = (log / "first.err").read_text()
    assert (log / "first.rc").read_text().strip() == "2", first_err
    assert (
        "No space left on device" in first_err
        and "tiles written before are intact" in first_err
        and "rattlesweep resume" in first_err
    ), first_err
    assert "Traceback" not in first_err
    info = (log / "info.out").read_text()
    assert "tiles written:" in info or "tiles written;" in info, (
        info + (log / "listing").read_text()
    )
    assert (log / "resume.rc").read_text().strip() == "0", (log / "resume.err").read_text()
    if output == "netcdf":
        with xr.open_dataset(log / "result" / RESULT_NAME) as ds:
            xr.testing.assert_identical(
                without_history(reference), without_history(ds.load())
            )
        assert not list((log / "result" / "tiles").glob(".*.tmp"))
    else:
        with xr.open_zarr(log / "result") as ds:
            xr.testing.assert_identical(
                without_config(reference.load()), without_config(ds.load())
            )


# --- an edited or corrupted sweep.toml --------------------------------------------------


def test_corrupted_or_edited_sweep_toml_gets_a_clear_error_and_loses_no_tile(
    tmp_path, capsys
):
    s = small_sweep()
    out = tmp_path / "out"
    run_sweep(s, out, progress=False)
    (out / RESULT_NAME).unlink()
    config = out / "sweep.toml"
    original = config.read_text()
    tiles = file_stats(out / "tiles", "*.nc")

    for damage, message in [
        (
            original[: len(original) // 2],
            r"sweep\.toml is not a valid sweep configuration "
            r"\(cannot parse .* as TOML",
        ),
        (
            b"\xff\xfe garbage",
            r"is not a valid sweep configuration \(cannot parse .*not UTF-8",
        ),
        (original.replace("t_end = 3.0", "t_end = -3.0"), r"fixed\.t_end"),
        (original.replace("[axes]", "[axes]\nspni = [1.0]"), r"unknown parameter 'spni'"),
    ]:
        config.write_bytes(damage.encode() if isinstance(damage, str) else damage)
        with pytest.raises(ValueError, match=message):
            resume(out, progress=False)
        assert main(["resume", str(out)]) == 2
        err = capsys.readouterr().err
        assert "restore it" in err and "Traceback" not in err, err
        with pytest.raises(ValueError, match=message):
            run_sweep(s, out, progress=False)
    # a valid but different configuration: the tiles are someone else's, so the resume is
    # refused instead of deleting them
    config.write_text(original.replace("t_end = 3.0", "t_end = 2.0"))
    with pytest.raises(ValueError, match=r"holds 8 tiles of another configuration.*edited"):
        resume(out, progress=False)
    assert file_stats(out / "tiles", "*.nc") == tiles
    # restored, it resumes with every tile kept
    config.write_text(original)
    resume(out, progress=False)
    assert file_stats(out / "tiles", "*.nc") == tiles and (out / RESULT_NAME).exists()
