"""Every kind of netCDF file rattlesweep writes passes the IOOS compliance checker's
CF-1.8 suite (the `compliance-checker` package, written by others) with no error, but
one: a file over ``time`` (a single run, a fit) is told that its ``time`` should have
``standard_name = "time"``. That standard name is for times since an epoch (its units
must read "s since ..."); rattlesweep's ``time`` is the time since the release in s,
which CF describes without it, and the checker asks for it of any dimension named
``time``. The checker's own monotonicity check fails (a TypeError inside it) on a
string-valued coordinate such as ``body_axis`` (x, y, z); that check is then left out,
and the others must pass."""

import pytest

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.io import write_netcdf

checker = pytest.importorskip(
    "compliance_checker.runner",
    reason="compliance-checker is not installed (the test extra installs it)",
)

TIME_NAME = "Coordinate variable 'time' should have standard_name='time', found: 'None'"
CRASHES_ON_STRINGS = "check_coordinate_variables_strict_monotonicity"


def cf_errors(path):
    """The high-priority findings of the CF-1.8 suite on ``path``."""
    suite = checker.CheckSuite()
    suite.load_all_available_checkers()
    ds = suite.load_dataset(str(path))
    found = []
    for name, (results, errors) in suite.run_all(ds, ["cf:1.8"], skip_checks=[]).items():
        assert set(errors) <= {CRASHES_ON_STRINGS}, errors
        scored = suite.build_structure(name, results, str(path), 2)
        found += [m for r in scored["high_priorities"] for m in r.msgs]
    return found


def test_single_runs_and_batches_pass_but_for_the_time_axis_name(tmp_path):
    body = rs.Body.preset("kane_levinson")
    run = rs.simulate(body, spin=-3.0, roll_deg=1.0, t_end=0.2, record_every=10)
    batch = rs.run_batch(body, spin=[-3.0, 3.0], mu=[0.3, 0.5], t_end=0.2)
    write_netcdf(run, tmp_path / "run.nc")
    write_netcdf(batch, tmp_path / "batch.nc")
    assert set(cf_errors(tmp_path / "run.nc")) <= {TIME_NAME}
    assert cf_errors(tmp_path / "batch.nc") == []
    with rs.io.xr.open_dataset(tmp_path / "run.nc") as back:  # what the checker wanted
        assert back["n_reversals"].dtype.itemsize == 4  # 32-bit on disk
        assert back["status"].attrs["flag_values"].dtype == back["status"].dtype
        assert "_FillValue" not in back["time"].encoding
        assert "rattlesweep" in back.attrs["history"]
    assert run["n_reversals"].dtype.itemsize == 8  # the result in memory is unchanged


def test_sweeps_stability_files_and_exported_zarr_sweeps_pass(tmp_path):
    sweep = rs.Sweep(
        axes={"spin": {"start": -5, "stop": 5, "num": 3}, "mu": [0.3, 0.5]},
        fixed={"body": "toy", "t_end": 0.2},
    )
    rs.run_sweep(sweep, tmp_path / "sweep", progress=False)
    assert cf_errors(tmp_path / "sweep" / "sweep.nc") == []
    stability = rs.Sweep(
        axes={"spin": {"start": -5, "stop": 5, "num": 3}, "delta_deg": [2.0, 5.0]},
        fixed={"a": 0.05, "b": 0.01, "c": 0.01, "mass": 0.01},
    )
    (tmp_path / "stab.toml").write_text(stability.to_toml())
    out = tmp_path / "stab.nc"
    assert main(["stability", str(tmp_path / "stab.toml"), "--out", str(out)]) == 0
    assert cf_errors(out) == []
    pytest.importorskip("zarr")
    from rattlesweep.sweep._execution.run import export

    stored = rs.Sweep(**{**sweep.to_dict(), "output": "zarr"})
    rs.run_sweep(stored, tmp_path / "run.zarr", progress=False)
    export(tmp_path / "run.zarr", tmp_path / "exported.nc")
    assert cf_errors(tmp_path / "exported.nc") == []
