"""Sweeps: specification and validation, tiled execution, resumable output, maps, CLI."""

import math
import os
import signal
import subprocess
import sys
import textwrap
import time

import netCDF4
import numpy as np
import pytest
import xarray as xr

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.sweep import OUTCOME_NAMES, Sweep, classify, resume, run_sweep
from rattlesweep.sweep._config.grid import uniform01
from rattlesweep.sweep._execution.run import RESULT_NAME
from sweep_helpers import (
    KILL_TOML,
    assert_same_file,
    file_stats,
    small_sweep,
    start_sweep,
    without_history,
)

TOY = rs.Body.preset("toy")


# --- specification ---------------------------------------------------------------------


def test_toml_maps_one_to_one_onto_sweep():
    s = small_sweep()
    again = Sweep.from_toml(s.to_toml())
    assert again == s
    assert again.to_toml() == s.to_toml()
    assert again.config_hash() == s.config_hash()
    text = textwrap.dedent("""
        name = "t"
        [axes]
        spin = { start = -12.0, stop = 12.0, num = 4 }
        delta_deg = [-4.0, 3.0]
        mu = [0.3, inf]
        [fixed]
        t_end = 3.0
        damping = 1e-7
        [random]
        roll_deg = { uniform = [0.3, 0.8] }
    """)
    from_text = Sweep.from_toml(text)
    assert from_text.axes == s.axes and from_text.random == s.random
    assert from_text.differences(s) == [
        "name: 't' -> 'sweep'",
        f"tile_size: {from_text.tile_size} -> 5",
        "repeats: 1 -> 2",
        "seed: 0 -> 7",
    ]
    # a 32-point grid gets the smallest automatic tile
    assert from_text.tile_size == 256 and from_text.n_tiles == 1


def test_automatic_tile_size():
    big = Sweep(
        axes={
            "spin": {"start": -30, "stop": 30, "num": 224},
            "delta_deg": {"start": -8, "stop": 8, "num": 224},
            "mu": [0.3, math.inf],
        },
        fixed={"t_end": 2.0},
    )
    steps = math.ceil(2.0 / TOY.default_dt())
    assert big.tile_size % 32 == 0
    assert big.n_tiles >= 16  # enough tasks to balance the workers
    assert big.tile_size * steps <= 2e7 + 32 * steps  # about 2 s of kernel time per tile
    long = Sweep(axes=big.axes, fixed={"t_end": 60.0})
    assert (
        long.tile_size * math.ceil(60.0 / TOY.default_dt())
        <= 2e7 + 32 * 60.0 / TOY.default_dt()
    )
    assert long.n_tiles > big.n_tiles


def test_units_and_degree_names_convert_to_the_same_si_values():
    by_name = Sweep(axes={"delta_deg": [2.0, 4.0]}, fixed={"t_end": 1.0})
    by_units = Sweep(
        axes={"delta": {"values": [2.0, 4.0], "units": "deg"}}, fixed={"t_end": 1.0}
    )
    rad = Sweep(
        axes={"delta": [math.radians(2.0), math.radians(4.0)]}, fixed={"t_end": 1.0}
    )
    for s in (by_name, by_units):
        np.testing.assert_allclose(s.grid_axes[0].si, rad.grid_axes[0].si, rtol=1e-15)
        assert s.grid_axes[0].units == "degree"
    rpm = Sweep(axes={"spin": {"values": [60.0], "units": "rpm"}}, fixed={"t_end": 1.0})
    assert rpm.grid_axes[0].si[0] == pytest.approx(2 * math.pi)
    ms = Sweep(axes={"spin": [1.0]}, fixed={"t_end": {"value": 500, "units": "ms"}})
    assert ms.fixed_si()["t_end"] == pytest.approx(0.5)


def test_ranges_are_inclusive_linear_or_log():
    s = Sweep(
        axes={
            "spin": {"start": -2.0, "stop": 2.0, "num": 5},
            "damping": {"start": 1e-6, "stop": 1e-4, "num": 3, "scale": "log"},
        },
        fixed={"t_end": 1.0},
    )
    np.testing.assert_allclose(s.grid_axes[0].values, [-2, -1, 0, 1, 2])
    np.testing.assert_allclose(s.grid_axes[1].values, [1e-6, 1e-5, 1e-4])
    assert s.shape == (5, 3) and s.size == 15 and s.dims == ("launch_spin", "damping")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            dict(axes={"spni": [1.0]}),
            r"axes\.spni: unknown parameter 'spni' \(did you mean 'spin'",
        ),
        (dict(axes={"spin": []}), r"axes\.spin: axis is empty"),
        (  # it said 'a random parameter is a table {uniform = [low, high]}'
            dict(axes={"spin": [1.0]}, random={"body": {"uniform": [0, 1]}}, repeats=2),
            r"random\.body: the body cannot be random; give it in \[fixed\], or as an",
        ),
        (  # it said 'refine.axes must name at least one range axis'
            dict(axes={"spin": [1.0, 2.0]}, refine=2),
            r"refine: a refined sweep needs a range axis .* this sweep's axes are lists",
        ),
        (
            dict(axes={"spin": {"start": 5, "stop": -5, "num": 3}}),
            r"axes\.spin: range is inverted",
        ),
        (
            dict(axes={"spin": {"start": 1, "stop": 2}}),
            r"axes\.spin: a range needs start, stop, num",
        ),
        (
            dict(axes={"spin": {"start": 1, "stop": 2, "num": 0}}),
            r"axes\.spin: num must be",
        ),
        (
            dict(axes={"mass": [0.01, -0.02]}),
            r"axes\.mass: mass must be finite and > 0; got -0\.02",
        ),
        (dict(axes={"spin": [1.0, 1.0]}), r"axes\.spin: axis has duplicate values"),
        (dict(axes={"spin": [1.0, float("nan")]}), r"axes\.spin: values must not be NaN"),
        (dict(axes={"b": [[1, 2], 0.0096]}), r"axes\.b: values must be numbers"),
        (
            dict(axes={"mu": {"start": 1.0, "stop": 0.0, "num": 1, "scale": "log"}}),
            r"axes\.mu: a log range needs start > 0 and stop > 0",
        ),
        (
            dict(axes={"spin": {"values": [1.0], "units": "furlong"}}),
            r"units 'furlong' are not "
            r"allowed for 'spin'",
        ),
        (
            dict(axes={"mu": [0.2, 0.5]}, fixed={"t_end": 1.0, "mu_static": 0.3}),
            r"mu_static must be >= mu.*sweep corner mu=0\.5",
        ),
        (dict(axes={"roll_deg": [0.0, 95.0]}), r"tilt.*rim.*sweep corner roll_deg=95"),
        (dict(axes={"c": [0.011, 0.05]}), r"(radius|curvature).*sweep corner c=0\.05"),
        (dict(axes={"delta_deg": [1.0], "delta": [0.1]}), r"'delta' is already given"),
        (
            dict(axes={"delta_deg": [1.0]}, fixed={"t_end": 1.0, "body": "golden"}),
            r"either a body or the semi-ellipsoid",
        ),
        (
            dict(axes={"spin": [1.0]}, repeats=3),
            r"repeats = 3 needs at least one \[random\]",
        ),
        (
            dict(axes={"spin": [1.0]}, random={"roll": {"uniform": [0.2, 0.1]}}),
            r"random\.roll: uniform range is inverted",
        ),
        (
            dict(axes={"spin": [1.0]}, fixed={"t_end": 1.0, "body": "nope"}),
            r"fixed\.body: preset name 'nope' is unknown",
        ),
        (dict(axes={"spin": [1.0]}, method="rk45"), "method must be one of"),
        (dict(axes={"spin": [1.0]}, tile_size=0), "tile_size must be an integer >= 1"),
        (dict(axes={}), "at least one axis"),
    ],
)
def test_configuration_errors_name_the_key(kwargs, message):
    args = dict(fixed={"t_end": 1.0})
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        Sweep(**args)


def test_bad_toml_is_refused_before_any_compute(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[axes]\nspin = [1.0, 2.0\n")
    with pytest.raises(ValueError, match=r"cannot parse .*bad\.toml as TOML"):
        Sweep.from_toml(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[axes]\nspin = [1.0]\n[fixed]\nt_end = 1.0\n[extra]\nx = 1\n")
    with pytest.raises(ValueError, match=r"unknown configuration keys \['extra'\]"):
        Sweep.from_toml(unknown)
    out = tmp_path / "out"
    assert main(["sweep", str(bad), "--out", str(out)]) == 2
    assert "cannot parse" in capsys.readouterr().err
    assert not out.exists()


# --- execution -------------------------------------------------------------------------


def test_sweep_equals_run_batch_on_the_same_points(tmp_path):
    s = small_sweep()
    ds = run_sweep(s, tmp_path, progress=False, workers=2)
    assert ds.sizes == {"launch_spin": 4, "delta_deg": 2, "mu": 2, "repeat": 2}
    # rebuild every point's inputs independently from the result's own coordinates
    grid = ds[["roll_deg"]].to_dataframe().reset_index()
    bodies = np.array(
        [
            rs.Body.semi_ellipsoid(TOY.a, TOY.b, TOY.c, TOY.mass, math.radians(d))
            for d in grid.delta_deg
        ],
        dtype=object,
    )
    ref = rs.run_batch(
        bodies,
        spin=grid.launch_spin.values,
        mu=grid.mu.values,
        roll=np.radians(grid.roll_deg.values),
        t_end=3.0,
        damping=1e-7,
    )
    for name in (
        "first_reversal_time",
        "n_reversals",
        "final_spin",
        "mean_final_spin",
        "max_tilt",
        "energy_lost",
        "slip_fraction",
        "status",
        "steps",
    ):
        np.testing.assert_array_equal(
            ds[name].values.ravel(), ref[name].values, err_msg=name
        )
    np.testing.assert_array_equal(ds.dt.values.ravel(), ref.dt.values)
    # the draws are in range, differ between repeats, and the grid is not trivial
    assert np.all((ds.roll_deg >= 0.3) & (ds.roll_deg < 0.8))
    assert np.all(ds.roll_deg.isel(repeat=0) != ds.roll_deg.isel(repeat=1))
    assert {int(o) for o in np.unique(ds.outcome)} >= {0, 1}


def test_results_do_not_depend_on_tiling(tmp_path):
    a = run_sweep(small_sweep(tile_size=3), tmp_path / "a", progress=False)
    b = run_sweep(small_sweep(tile_size=64), tmp_path / "b", progress=False, workers=1)
    data = lambda ds: ds.drop_attrs().drop_vars([])
    xr.testing.assert_identical(data(a), data(b))


def test_random_draws_are_reproducible_and_uniform():
    idx = np.arange(200_000)
    u = uniform01(3, "roll", idx)
    np.testing.assert_array_equal(u, uniform01(3, "roll", idx))
    assert not np.array_equal(u, uniform01(4, "roll", idx))
    assert not np.array_equal(u, uniform01(3, "pitch", idx))
    assert u.min() >= 0.0 and u.max() < 1.0
    # uniform: mean 1/2 and variance 1/12 within 5 standard errors
    assert abs(u.mean() - 0.5) < 5 * math.sqrt(1 / 12 / len(u))
    assert abs(u.var() - 1 / 12) < 5 * math.sqrt(1 / 180 / len(u))
    counts = np.histogram(u, bins=20, range=(0, 1))[0]
    chi2 = ((counts - len(u) / 20) ** 2 / (len(u) / 20)).sum()
    assert chi2 < 50  # 19 dof: p < 1e-4 beyond 50


def test_outcome_classes():
    status = np.array([0, 0, 0, 0, 0, 1, 2, 3])
    n_rev = np.array([0, 1, 3, 0, 0, 1, 0, 0])
    final = np.array([5.0, -5.0, 5.0, 0.1, 0.0, 1.0, 1.0, np.nan])
    spin0 = np.array([5.0, 5.0, 5.0, 5.0, 0.0, 5.0, 5.0, 5.0])
    got = classify(status, n_rev, final, spin0, 0.05)
    names = [OUTCOME_NAMES[k] for k in got]
    assert names == [
        "no_reversal",
        "reversed",
        "several_reversals",
        "stopped",
        "no_reversal",
        "capsized",
        "lifted_off",
        "numerical_failure",
    ]


def test_written_file_carries_cf_metadata_and_configuration(tmp_path):
    s = small_sweep()
    run_sweep(s, tmp_path, progress=False, command="rattlesweep sweep test.toml")
    path = tmp_path / RESULT_NAME
    with netCDF4.Dataset(path) as nc:
        assert nc.data_model == "NETCDF4"
        assert nc.variables["first_reversal_time"].filters()["zlib"]
        assert nc.variables["outcome"].dimensions == (
            "launch_spin",
            "delta_deg",
            "mu",
            "repeat",
        )
        assert nc.variables["launch_spin"].units == "rad s-1"
        assert nc.variables["delta_deg"].units == "degree"
        assert nc.getncattr("Conventions").startswith("CF-")
        assert "rattlesweep sweep test.toml" in nc.getncattr("history")
        for key in (
            "rattlesweep_version",
            "numba_version",
            "numpy_version",
            "xarray_version",
            "dask_version",
            "netCDF4_version",
            "python_version",
        ):
            assert nc.getncattr(key)
    with xr.open_dataset(path) as ds:
        assert Sweep.from_toml(ds.attrs["sweep_config"]) == s
        # the flags end with not_computed (-1), which only a store being written shows
        assert ds.outcome.attrs["flag_meanings"].split() == [*OUTCOME_NAMES, "not_computed"]
        assert list(ds.outcome.attrs["flag_values"]) == [*range(len(OUTCOME_NAMES)), -1]
        assert ds.status.attrs["flag_meanings"].split()[0] == "ok"
        assert ds.status.attrs["flag_meanings"].split()[-1] == "not_computed"
        assert int(ds.outcome.min()) >= 0 and int(ds.status.min()) >= 0
        for name in ds.data_vars:
            assert ds[name].attrs.get("long_name"), name
            if name not in ("outcome", "status"):
                assert ds[name].attrs.get("units"), name
        assert float(ds.t_end) == 3.0 and ds.t_end.attrs["units"] == "s"


# --- resume ----------------------------------------------------------------------------


def test_sigkill_then_resume_gives_the_uninterrupted_file(tmp_path):
    config = tmp_path / "kill.toml"
    config.write_text(KILL_TOML)
    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "sweep",
            str(config),
            "--out",
            str(killed),
            "--workers",
            "1",
            "--quiet",
        ]
    )
    tiles = killed / "tiles"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list(tiles.glob("tile-*.nc"))) >= 2:
            break
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    before = file_stats(tiles, "*.nc")
    n_tiles = Sweep.from_toml(config).n_tiles
    assert 2 <= len(before) < n_tiles, "the kill must land mid-sweep"
    assert not (killed / RESULT_NAME).exists()

    resume(killed, progress=False)
    after = file_stats(tiles, "*.nc")
    assert len(after) == n_tiles
    assert {k: after[k] for k in before} == before, "finished tiles must not be recomputed"
    assert not list(tiles.glob(".*.tmp"))

    fresh = tmp_path / "fresh"
    run_sweep(Sweep.from_toml(config), fresh, progress=False)
    assert_same_file(killed / RESULT_NAME, fresh / RESULT_NAME)


def test_corrupt_tile_is_recomputed_and_changed_config_refused(tmp_path):
    s = small_sweep()
    run_sweep(s, tmp_path, progress=False)
    reference = xr.open_dataset(tmp_path / RESULT_NAME).load()
    tiles = tmp_path / "tiles"
    victim = sorted(tiles.glob("tile-*.nc"))[2]
    size = victim.stat().st_size
    with open(victim, "r+b") as f:
        f.truncate(size // 2)
    (tiles / ".tile-000001.nc.123.abc_1234.tmp").write_bytes(b"partial")
    before = file_stats(tiles, "*.nc")
    run_sweep(s, tmp_path, progress=False)
    after = file_stats(tiles, "*.nc")
    changed = {k for k in after if after[k] != before.get(k)}
    assert changed == {victim.name}
    assert victim.stat().st_size > size // 2
    assert not list(tiles.glob(".*.tmp"))
    xr.testing.assert_identical(
        without_history(reference),
        without_history(xr.open_dataset(tmp_path / RESULT_NAME).load()),
    )

    other = small_sweep(
        axes={
            "spin": {"start": -12.0, "stop": 12.0, "num": 5},
            "delta_deg": [-4.0, 3.0],
            "mu": [0.3, math.inf],
        }
    )
    with pytest.raises(ValueError, match=r"different sweep.*axes\.spin\.num: 4 -> 5"):
        run_sweep(other, tmp_path, progress=False)


def test_ctrl_c_stops_cleanly_and_resume_finishes(tmp_path):
    config = tmp_path / "kill.toml"
    config.write_text(KILL_TOML)
    out = tmp_path / "out"
    proc = start_sweep(config, out, 1)
    tiles = out / "tiles"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(tiles.glob("tile-*.nc")):
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "rattlesweep resume" in err
    done = len(list(tiles.glob("tile-*.nc")))
    assert 1 <= done < Sweep.from_toml(config).n_tiles
    assert not list(tiles.glob(".*.tmp"))
    assert main(["resume", str(out), "--quiet"]) == 0
    assert (out / RESULT_NAME).exists()


def test_run_sweep_argument_errors(tmp_path):
    s = small_sweep()
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        run_sweep(s, tmp_path, workers=0)
    with pytest.raises(ValueError, match="either client or scheduler"):
        run_sweep(s, tmp_path, client=object(), scheduler="tcp://x:1")
    with pytest.raises(ValueError, match="nothing does not exist"):
        resume(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="empty holds no sweep"):
        resume(tmp_path / "empty")
    with pytest.raises(ValueError, match=r"fixed\.t_end: the end time \(s\) is required"):
        run_sweep(Sweep(axes={"spin": [1.0]}), tmp_path / "no_t_end")
    assert not (tmp_path / "no_t_end").exists()


# --- maps and CLI ----------------------------------------------------------------------


def test_reversal_map_categorical_continuous_and_facets(tmp_path):
    from rattlesweep.plot import reversal_map

    ds = run_sweep(small_sweep(), tmp_path, progress=False)
    fig = reversal_map(ds, "launch_spin", "delta_deg", facet="mu", select={"repeat": 0})
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 2
    assert axes[0].get_xlabel() == "initial spin about the vertical [rad/s]"
    assert axes[0].get_ylabel().endswith("[°]")
    assert axes[1].get_title() == "μ = ∞ (rolling)"
    legend = {t.get_text() for t in fig.legends[0].get_texts()}
    present = {OUTCOME_NAMES[k].replace("_", " ") for k in np.unique(ds.outcome)}
    assert legend == present
    fig = reversal_map(
        ds, "launch_spin", "delta_deg", "max_tilt", select={"mu": 0.3}, reduce="mean"
    )
    colorbar = [ax for ax in fig.axes if ax.get_ylabel().startswith("largest tilt")]
    assert colorbar and colorbar[0].get_ylabel().endswith("[rad]")
    with pytest.raises(ValueError, match=r"also varies along \['mu', 'repeat'\]"):
        reversal_map(ds, "launch_spin", "delta_deg")
    with pytest.raises(ValueError, match="not a dimension"):
        reversal_map(ds, "launch_spin", "nope")


def test_cli_demo_info_plot(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert (out / RESULT_NAME).exists() and (
        out / "reversal_map.png"
    ).stat().st_size > 10_000
    assert "reversed" in printed
    assert main(["info", str(out / RESULT_NAME)]) == 0
    info = capsys.readouterr().out
    assert "spin (321), delta_deg (257), mu (2)" in info and "outcomes:" in info
    assert "simulated:" in info
    # the directory the sweep wrote is summarised the same way
    assert main(["info", str(out)]) == 0
    assert capsys.readouterr().out == info
    # a reader that goes away (``rattlesweep info DIR | head -1``) is no error
    reader = subprocess.Popen(
        [sys.executable, "-m", "rattlesweep.cli", "info", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    reader.stdout.close()
    err = reader.stderr.read().decode()
    assert reader.wait(timeout=120) == 0 and err == "", err
    # an unfinished sweep directory reports its progress
    (out / RESULT_NAME).unlink()
    assert main(["info", str(out)]) == 0
    assert "levels started: 4 of 4" in capsys.readouterr().out
    # anything unreadable is named, with what was expected, and the exit status says so
    junk = tmp_path / "junk.nc"
    junk.write_text("not netCDF")
    assert main(["info", str(junk), str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"cannot read {junk}: expected a rattlesweep result file" in err
    assert f"{tmp_path} is a directory without sweep.nc or sweep.toml" in err
    # the demo resumed draws its map, as the demo does
    (out / "reversal_map.png").unlink()
    assert main(["resume", str(out), "--quiet"]) == 0
    assert f"wrote {out / 'reversal_map.png'}" in capsys.readouterr().out
    assert (out / "reversal_map.png").stat().st_size > 10_000
    (out / RESULT_NAME).unlink()
    assert main(["demo", "--out", str(out), "--quiet"]) == 0  # resumes: merges again
    capsys.readouterr()
    png = tmp_path / "t.png"
    assert (
        main(
            [
                "plot",
                str(out / RESULT_NAME),
                "--var",
                "first_reversal_time",
                "--facet",
                "mu",
                "--out",
                str(png),
            ]
        )
        == 0
    )
    assert png.stat().st_size > 10_000
    assert main(["plot", str(out / RESULT_NAME), "--x", "nope"]) == 2
    capsys.readouterr()
    assert main(["demo", "--print-config"]) == 0
    demo = Sweep.from_toml(capsys.readouterr().out)
    assert demo.size == 41 * 33 * 2 and demo.finest().size == 321 * 257 * 2
    assert demo.stop == "first_reversal"


def test_a_map_title_names_the_sweeps_body(tmp_path):
    from rattlesweep.plot import reversal_map

    sweep = Sweep(
        axes={"spin": [-5.0, 5.0], "roll_deg": [0.5, 1.0]},
        fixed={"body": "kane_levinson", "t_end": 0.1},
    )
    ds = run_sweep(sweep, tmp_path / "kl", progress=False)
    title = reversal_map(ds, "launch_spin", "roll_deg")._suptitle.get_text()
    assert title.startswith("kane_levinson body, t_end = 0.1 s")
    assert "roll_deg" not in title
