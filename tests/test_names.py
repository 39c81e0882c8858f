"""Names in results: one name, units and long name for each input in every result, no
name an xarray method hides, flags read as names, tidy tables, batches unstacked."""

import math


import numpy as np
import pandas as pd
import pytest
import xarray as xr

import rattlesweep as rs
from rattlesweep.sweep import Sweep, run_sweep

TOY = rs.Body.preset("toy")
INPUTS = (
    "launch_spin",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "mu",
    "mu_spin",
    "mu_roll",
    "damping",
    "g",
    "t_end",
)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    launch = dict(mu=0.3, mu_spin=1e-5, mu_roll=1e-6, damping=1e-8, g=9.8, t_end=0.05)
    run = rs.simulate(TOY, spin=2.0, roll_deg=0.5, pitch_deg=0.25, yaw_deg=10.0, **launch)
    batch = rs.run_batch(
        TOY, spin=[2.0, -2.0], roll_deg=0.5, pitch_deg=0.25, yaw_deg=10.0, **launch
    )
    sweep = Sweep(
        axes={"spin": [2.0, -2.0], "roll": [0.01, 0.02]},
        fixed={"pitch_deg": 0.25, "yaw": {"value": 10.0, "units": "deg"}, **launch},
        random={"delta_deg": {"uniform": [1.0, 2.0]}},
        repeats=2,
    )
    swept = run_sweep(sweep, tmp_path_factory.mktemp("names"), progress=False)
    return run, batch, swept


def test_each_input_has_one_name_units_and_long_name_in_every_result(results):
    run, batch, swept = results
    for name in INPUTS:
        units, long_name = batch[name].attrs["units"], batch[name].attrs["long_name"]
        assert run.attrs[f"{name}_units"] == units, name
        assert run.attrs[f"{name}_long_name"] == long_name, name
        assert swept[name].attrs["units"] == units, name
        assert swept[name].attrs["long_name"] == long_name, name
    for name in ("roll_deg", "pitch_deg", "yaw_deg"):
        assert batch[name].attrs["units"] == "degree"
    # a sweep axis given in radians, and a fixed angle given with units, both in degrees
    np.testing.assert_allclose(swept.roll_deg.values, np.degrees([0.01, 0.02]), rtol=1e-15)
    assert float(swept.yaw_deg) == 10.0 and float(swept.pitch_deg) == 0.25
    assert swept.delta_deg.attrs["units"] == "degree"
    assert np.all((swept.delta_deg >= 1.0) & (swept.delta_deg < 2.0))
    assert swept.launch_spin.dims == ("launch_spin",)
    assert run.attrs["launch_spin"] == 2.0 and run.attrs["roll_deg"] == 0.5


def test_no_result_name_is_hidden_by_an_xarray_attribute(results):
    run, batch, swept = results
    stab = rs.stability.stability_dataset(
        Sweep(axes={"spin": [1.0, 2.0]}, fixed={"t_end": 1.0})
    )
    for ds in (run, batch, swept, stab, rs.unstack(batch)):
        for name in ds.variables:
            assert not hasattr(xr.Dataset, str(name)), name
            assert getattr(ds, str(name)).name == name


def test_decode_gives_flags_as_names(results):
    run, batch, swept = results
    dec = rs.decode(swept)
    assert set(np.unique(dec.status.values)) == {"ok"}
    meanings = swept.outcome.attrs["flag_meanings"].split()
    codes = dict(zip(swept.outcome.attrs["flag_values"], meanings))
    np.testing.assert_array_equal(
        dec.outcome.values, np.vectorize(codes.get)(swept.outcome.values)
    )
    assert dec.outcome.attrs["long_name"] == swept.outcome.attrs["long_name"]
    assert "flag_values" not in dec.outcome.attrs
    assert swept.outcome.dtype == np.int8  # the input is left as it was
    # every code, an unknown one too, on a DataArray alone
    da = xr.DataArray(
        np.array([0, 1, 2, 3, 7], dtype=np.int8), dims="x", attrs=batch.status.attrs
    )
    assert list(rs.decode(da).values) == [
        "ok",
        "capsized",
        "lifted_off",
        "non_finite",
        "unknown",
    ]
    assert rs.decode(xr.DataArray([1.0, 2.0])).equals(xr.DataArray([1.0, 2.0]))


def test_a_table_has_a_row_per_sample_and_a_column_per_component(results, tmp_path):
    run, batch, swept = results
    table = rs.to_table(run)
    assert len(table) == run.sizes["time"]  # to_dataframe() multiplies the vector dims
    assert len(run.to_dataframe()) == run.sizes["time"] * 4 * 3 * 3 * 2
    np.testing.assert_array_equal(table.omega_y, run.omega.sel(body_axis="y").values)
    np.testing.assert_array_equal(
        table.quaternion_w, run.quaternion.sel(quaternion_component="w").values
    )
    np.testing.assert_array_equal(table.time, run.time.values)
    assert (table.status == "ok").all() and table.status.dtype == "category"
    assert table.attrs["units"]["omega_y"] == "rad s-1"
    # a batch: one row per trajectory, each input a column
    bt = rs.to_table(batch)
    assert len(bt) == 2 and list(bt.launch_spin) == [2.0, -2.0]
    assert list(bt.com_z) == [TOY.com[2]] * 2 and (bt.roll_deg == 0.5).all()
    # a sweep: one row per point, its dimensions as columns
    path = tmp_path / "sweep.csv"
    rs.to_csv(swept, path)
    back = pd.read_csv(path)
    assert len(back) == swept.outcome.size
    assert {"launch_spin", "roll_deg", "repeat", "outcome", "delta_deg", "t_end"} <= set(
        back
    )
    row = back.iloc[5]
    point = swept.sel(
        launch_spin=row["launch_spin"], roll_deg=row["roll_deg"], repeat=int(row["repeat"])
    )  # row.repeat: Series.repeat
    assert row.first_reversal_time == pytest.approx(
        float(point.first_reversal_time), nan_ok=True
    )
    assert row.outcome == str(rs.decode(point.outcome).values)


def test_unstack_gives_the_broadcast_shape_in_one_call():
    spins, mus = np.array([1.0, 2.0, 3.0]), np.array([0.3, math.inf])
    batch = rs.run_batch(
        TOY,
        spin=spins[:, None],
        mu=mus,
        roll_deg=[[0.5], [1.0], [1.5]],
        t_end=0.02,
        record_every=5,
    )
    grid = rs.unstack(batch)
    assert grid.final_spin.dims == ("launch_spin", "mu")
    assert grid.spin.dims == ("launch_spin", "mu", "time")  # recorded series too
    np.testing.assert_array_equal(grid.launch_spin.values, spins)
    np.testing.assert_array_equal(grid.mu.values, mus)
    # an input varying along the first axis only, but not the chosen index, stays a
    # coordinate
    assert grid.roll_deg.dims == ("launch_spin", "mu")
    np.testing.assert_array_equal(grid.roll_deg.values[:, 1], [0.5, 1.0, 1.5])
    for i, s in enumerate(spins):
        for j, m in enumerate(mus):
            k = i * len(mus) + j
            assert int(grid.trajectory[i, j]) == k
            np.testing.assert_array_equal(grid.spin.values[i, j], batch.spin.values[k])
    np.testing.assert_array_equal(grid.com.values.reshape(-1, 3), batch.com.values)
    # axes no single input labels get batch_axis_<i>; names can be given
    same = rs.run_batch(TOY, spin=np.ones((2, 2)), t_end=0.01)
    assert rs.unstack(same).final_spin.dims == ("batch_axis_0", "batch_axis_1")
    assert rs.unstack(same, ["a_", "b_"]).final_spin.dims == ("a_", "b_")
    with pytest.raises(ValueError, match="dims must name each of the 2 axes"):
        rs.unstack(same, ["x"])
    with pytest.raises(ValueError, match="batch_shape"):
        rs.unstack(batch.drop_attrs())


def test_the_reading_results_page_runs_as_written():
    import pathlib
    import re

    page = pathlib.Path(__file__).parents[1] / "docs" / "guide" / "results.md"
    if not page.is_file():
        pytest.skip("the docs are not next to the tests")
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
    assert len(blocks) == 4
    scope: dict = {}
    exec(compile("\n".join(blocks), str(page), "exec"), scope)
    assert scope["grid"].first_reversal_time.dims == ("launch_spin", "mu")
    assert list(scope["named"].status.values) == ["ok"] * 4
