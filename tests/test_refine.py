"""Adaptive refinement: the level algorithm on synthetic maps, refined sweeps end to end
(results, resume, CLI), and (slow) the acceptance figures on the demo problem."""

import math
import os

import numpy as np
import pytest
import xarray as xr

from rattlesweep.cli import main
from rattlesweep.sweep import Sweep, run_sweep
from rattlesweep.sweep._outputs.compare import compare_with_full
from rattlesweep.sweep._refinement.plan import Levels, plan_level
from rattlesweep.sweep._outputs.refined import COMPUTED_ATTRS
from sweep_helpers import REFINED_TOML, assert_same_file, file_stats


# --- the level algorithm on synthetic maps ----------------------------------------------


class Synthetic:
    """A map known at every point of a finest grid (x, y, a batch dimension of 2), and
    the refinement's state over it: ``simulate`` copies the truth at given points."""

    def __init__(self, outcome, time, levels, shape=(129, 97, 2)):
        self.levels = Levels(shape, (0, 1), levels)
        x, y, m = np.meshgrid(
            np.linspace(-1, 1, shape[0]),
            np.linspace(-1, 1, shape[1]),
            np.arange(shape[2]),
            indexing="ij",
        )
        self.truth = {
            "outcome": outcome(x, y, m).astype(np.int8),
            "first_reversal_time": time(x, y, m),
        }
        self.truth["t_final"] = np.where(
            np.isnan(self.truth["first_reversal_time"]),
            5.0,
            self.truth["first_reversal_time"],
        )
        self.truth["steps"] = np.round(100 * self.truth["t_final"]).astype(np.int64)
        self.values = {
            k: np.full(shape, -1 if v.dtype.kind == "i" else np.nan, v.dtype)
            for k, v in self.truth.items()
        }
        self.computed = np.zeros(shape, dtype=bool)
        self.planned = []

    def simulate(self, index):
        for k, v in self.values.items():
            v.ravel()[index] = self.truth[k].ravel()[index]
        self.computed.ravel()[index] = True

    def run(self, jump=None):
        self.simulate(self.levels.level0())
        for level in range(1, self.levels.levels + 1):
            index = plan_level(self.values, self.computed, self.levels, level, jump)
            self.planned.append(index)
            self.simulate(index)
        return self

    @property
    def wrong(self):
        return self.values["outcome"] != self.truth["outcome"]


def disc(x, y, m):
    return (x - 0.2 * m) ** 2 + y**2 < 0.4


def linear_time(x, y, m):
    return np.where(disc(x, y, m), 2.0 + 0.7 * x - 0.3 * y, np.nan)


def test_refinement_resolves_a_boundary_and_fills_agreeing_cells_from_their_corners():
    run = Synthetic(disc, linear_time, levels=3).run()
    assert not run.wrong.any()
    assert 0.05 < run.computed.mean() < 0.35
    # only points near the boundary were simulated at the finest level
    last = np.unravel_index(run.planned[-1], run.levels.shape)
    x = np.linspace(-1, 1, 129)[last[0]] - 0.2 * last[2]
    y = np.linspace(-1, 1, 97)[last[1]]
    assert np.all(np.abs(np.hypot(x, y) - math.sqrt(0.4)) < 0.2)
    # interpolation between agreeing corners reproduces a linear field exactly
    inside = disc(
        *np.meshgrid(
            np.linspace(-1, 1, 129), np.linspace(-1, 1, 97), np.arange(2), indexing="ij"
        )
    )
    filled = inside & ~run.computed
    assert filled.sum() > 1000
    np.testing.assert_allclose(
        run.values["first_reversal_time"][filled],
        run.truth["first_reversal_time"][filled],
        rtol=0,
        atol=1e-12,
    )
    # integers come from a corner of the cell
    steps = run.values["steps"][filled]
    assert np.all((steps >= 100 * 2.0 - 100) & (steps <= 100 * 3.1))
    # each level runs the longest predicted runs first
    for index in run.planned[1:]:
        predicted = run.truth["t_final"].ravel()[index]
        assert predicted[0] >= predicted[-1]


def test_a_band_thinner_than_a_cell_along_a_boundary_is_found():
    def outcome(x, y, m):
        r = np.hypot(x - 0.2 * m, y)
        ring = (r >= math.sqrt(0.4)) & (r < math.sqrt(0.4) + 0.02)  # ~1.3 finest points
        return np.where(disc(x, y, m), 1, np.where(ring, 3, 0))

    run = Synthetic(outcome, linear_time, levels=3).run()
    ring = run.truth["outcome"] == 3
    assert ring.sum() > 200
    assert not run.wrong.any()


def test_an_island_inside_one_agreeing_cell_is_missed():
    """The limit of refinement from a coarse grid: a feature that no declared point and
    no neighbour of a boundary cell touches is not seen."""

    def outcome(x, y, m):
        island = np.hypot(x + 0.81, y - 0.81) < 0.045  # between declared points
        return np.where(disc(x, y, m), 1, np.where(island, 4, 0))

    run = Synthetic(outcome, linear_time, levels=3).run()
    island = run.truth["outcome"] == 4
    assert island.sum() > 10
    assert np.array_equal(run.wrong, island)


def test_reversal_time_jump_refines_inside_one_outcome():
    def outcome(x, y, m):
        return np.ones_like(x)

    def time(x, y, m):
        return np.where(x < 0.3 * y + 0.01, 1.0, 3.0) + 0.1 * y

    plain = Synthetic(outcome, time, levels=2).run()
    assert plain.computed.sum() == plain.levels.level0().size  # nothing to refine
    jumps = Synthetic(outcome, time, levels=2).run(jump=0.5)
    assert jumps.computed.sum() > 2 * jumps.levels.level0().size
    error = np.abs(jumps.values["first_reversal_time"] - jumps.truth["first_reversal_time"])
    error_plain = np.abs(
        plain.values["first_reversal_time"] - plain.truth["first_reversal_time"]
    )
    assert np.mean(error > 0.5) < 0.25 * np.mean(error_plain > 0.5)


def test_the_sign_of_the_lyapunov_exponent_is_refined_like_an_outcome():
    """One outcome everywhere, the exponent positive inside the disc: refinement follows
    the sign boundary, and every point ends with the right sign."""

    def outcome(x, y, m):
        return np.ones_like(x)

    plain = Synthetic(outcome, linear_time, levels=2).run()
    assert plain.computed.sum() == plain.levels.level0().size
    run = Synthetic(outcome, linear_time, levels=2)
    x, y, m = np.meshgrid(
        np.linspace(-1, 1, 129), np.linspace(-1, 1, 97), np.arange(2), indexing="ij"
    )
    run.truth["lyapunov"] = np.where(disc(x, y, m), 0.3, -0.05) + 0.01 * x
    run.values["lyapunov"] = np.full(x.shape, np.nan)
    run.run()
    assert run.computed.sum() > 2 * run.levels.level0().size
    assert np.array_equal(run.values["lyapunov"] > 0, run.truth["lyapunov"] > 0)


# --- the specification ------------------------------------------------------------------


def test_refine_and_stop_in_the_configuration():
    s = Sweep.from_toml(REFINED_TOML)
    assert s.refine == {"levels": 2, "axes": ["spin", "delta_deg"]}
    assert s.stop is None and "stop" not in s.to_dict()
    assert Sweep.from_toml(s.to_toml()) == s
    fine = s.finest()
    assert fine.shape == (33, 17) and fine.refine is None
    # every declared value is on the finest grid
    np.testing.assert_allclose(fine.grid_axes[0].values[::4], s.grid_axes[0].values)
    np.testing.assert_allclose(fine.grid_axes[1].values[::4], s.grid_axes[1].values)
    stopped = Sweep(
        **{
            **s.to_dict(),
            "stop": "first_reversal",
            "refine": {"levels": 1, "axes": ["delta_deg"], "reversal_time_jump": 0.5},
        }
    )
    assert stopped.finest().shape == (9, 9) and stopped.finest().stop == "first_reversal"
    assert 'stop = "first_reversal"' in stopped.to_toml()
    assert Sweep.from_toml(stopped.to_toml()) == stopped
    # a sweep without either keeps the configuration (and hash) it had before them
    plain = Sweep(**{k: v for k, v in s.to_dict().items() if k != "refine"})
    assert set(plain.to_dict()) == {
        "name",
        "method",
        "reversal_band",
        "tile_size",
        "output",
        "repeats",
        "seed",
        "axes",
        "fixed",
        "random",
    }


@pytest.mark.parametrize(
    "refine, message",
    [
        ({"levels": 0}, "refine.levels must be an integer from 1"),
        ({}, "refine.levels is missing"),  # an empty [refine]: it said "got None"
        ({"axes": ["spin"]}, "refine.levels is missing"),
        ({"levels": 2, "axes": ["mu"]}, "refine.axes: 'mu' is not an axis"),
        ({"levels": 2, "axes": "spin"}, "refine.axes must be a list"),
        ({"levels": 2, "typo": 1}, r"refine: unknown keys \['typo'\]"),
        ({"levels": 2, "reversal_time_jump": 0}, "refine.reversal_time_jump must be"),
        ("three", "refine must be a table"),
    ],
)
def test_bad_refine_tables_name_the_key(refine, message):
    with pytest.raises(ValueError, match=message):
        Sweep(**{**Sweep.from_toml(REFINED_TOML).to_dict(), "refine": refine})


def test_refine_needs_ranges_and_netcdf():
    base = Sweep.from_toml(REFINED_TOML).to_dict()
    with pytest.raises(ValueError, match="'mu' is not a range"):
        Sweep(
            **{
                **base,
                "axes": {**base["axes"], "mu": [0.3, 0.5]},
                "fixed": {k: v for k, v in base["fixed"].items() if k != "mu"},
                "refine": {"levels": 1, "axes": ["mu"]},
            }
        )
    with pytest.raises(ValueError, match="written as netCDF"):
        Sweep(**{**base, "output": "zarr"})
    with pytest.raises(ValueError, match="stop must be one of 'first_reversal'"):
        Sweep(**{**base, "stop": "t_end"})


# --- refined sweeps end to end -----------------------------------------------------------


@pytest.fixture(scope="module")
def small_runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("refined")
    s = Sweep.from_toml(REFINED_TOML)
    refined = run_sweep(s, root / "refined", progress=False, workers=2)
    full = run_sweep(s.finest(), root / "full", progress=False, workers=2)
    return s, root, refined, full


def test_refined_result_is_the_full_map_where_simulated(small_runs):
    s, _, refined, full = small_runs
    assert refined.sizes == {"launch_spin": 33, "delta_deg": 17}
    xr.align(refined, full, join="exact")  # the same coordinates
    sim = refined.computed.values == 1
    assert refined.attrs["points_simulated"] == sim.sum()
    assert 0.2 < sim.mean() < 0.9
    # the declared grid is simulated, and simulated points are the full run's, bit for bit
    assert sim[::4, ::4].all()
    for name in full.data_vars:
        np.testing.assert_array_equal(
            refined[name].values[sim], full[name].values[sim], err_msg=name
        )
    # inputs are never filled: the default time step is exact everywhere
    np.testing.assert_array_equal(refined.dt.values, full.dt.values)
    c = compare_with_full(refined, full)
    assert c["mismatch"] <= 0.02, c["misses"]
    assert refined.computed.attrs == COMPUTED_ATTRS
    assert set(refined.data_vars) == set(full.data_vars) | {"computed"}
    for name in full.data_vars:
        assert refined[name].attrs == full[name].attrs
    assert Sweep.from_toml(refined.attrs["sweep_config"]) == s


def test_refined_sweep_with_random_draws_has_them_at_every_point(tmp_path):
    from sweep_helpers import small_sweep

    s = small_sweep(refine={"levels": 2})
    ds = run_sweep(s, tmp_path, progress=False)
    fine = s.finest()
    assert ds.sizes == {"launch_spin": 13, "delta_deg": 2, "mu": 2, "repeat": 2}
    assert 0 < ds.attrs["points_simulated"] < fine.size
    (rp,) = fine.random_params
    np.testing.assert_array_equal(
        ds.roll_deg.values.ravel(), rp.draw(fine.seed, np.arange(fine.size))
    )


def test_refined_sweep_resumes_level_by_level(small_runs, tmp_path):
    s, root, refined, _ = small_runs
    out = tmp_path / "again"
    run_sweep(s, out, progress=False, workers=1)
    tiles = sorted(out.glob("levels/level-*/tile-*.nc"))
    assert {p.parent.name for p in tiles} == {"level-0", "level-1", "level-2"}
    before = file_stats(out, "tile-*.nc")
    # lose the result, a tile of level 1 and every tile of level 2, as a crash would
    (out / "sweep.nc").unlink()
    lost = [out / "levels/level-1/tile-000000.nc", *out.glob("levels/level-2/tile-*.nc")]
    for path in lost:
        path.unlink()
    (out / "levels/level-0/tile-000000.nc").write_bytes(b"truncated")
    run_sweep(s, out, progress=False, workers=2)
    after = file_stats(out, "tile-*.nc")
    redone = {str(p.relative_to(out)) for p in lost} | {"levels/level-0/tile-000000.nc"}
    assert set(after) == set(before)
    assert {k for k in after if after[k] != before[k]} == redone
    assert_same_file(out / "sweep.nc", root / "refined" / "sweep.nc")
    # another configuration in the same directory is refused
    other = Sweep(**{**s.to_dict(), "refine": {"levels": 1}})
    with pytest.raises(ValueError, match="holds a different sweep"):
        run_sweep(other, out, progress=False)


def test_cli_refine_stop_info_plot(tmp_path, capsys):
    config = tmp_path / "small.toml"
    config.write_text(REFINED_TOML)
    out = tmp_path / "run"
    assert (
        main(
            [
                "sweep",
                str(config),
                "--out",
                str(out),
                "--refine",
                "1",
                "--stop",
                "first_reversal",
                "--quiet",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "17 x 9" not in printed and "153 points (" in printed and "simulated" in printed
    stored = Sweep.from_toml(out / "sweep.toml")
    assert stored.refine["levels"] == 1 and stored.stop == "first_reversal"
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "launch_spin (17), delta_deg (9)" in info and "simulated:" in info
    png = tmp_path / "map.png"
    assert main(["plot", str(out / "sweep.nc"), "--out", str(png)]) == 0
    assert png.stat().st_size > 5_000
    # an unfinished refined directory says how far it got
    (out / "sweep.nc").unlink()
    for path in out.glob("levels/level-1/*.nc"):
        path.unlink()
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    assert "levels started: 2 of 2" in capsys.readouterr().out


# --- acceptance (slow): the demo map against the full grid --------------------------------


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("RATTLESWEEP_SLOW"), reason="slow: set RATTLESWEEP_SLOW=1 to run"
)
def test_demo_map_refined_three_levels_matches_the_full_grid(tmp_path):
    from rattlesweep.sweep._config.demo import DEMO_TOML

    demo = Sweep.from_toml(DEMO_TOML).to_dict()
    demo.pop("stop", None)
    refined = Sweep(**{**demo, "refine": {"levels": 3}})
    assert refined.finest().shape == (321, 257, 2)
    a = run_sweep(refined, tmp_path / "refined", progress=False)
    full = run_sweep(refined.finest(), tmp_path / "full", progress=False)
    c = compare_with_full(a, full)
    assert c["simulated"] <= 0.20
    assert c["mismatch"] <= 0.005, c["misses"]
    d = c["time_difference"]
    assert d.size > 10_000 and np.quantile(d, 0.99) < 0.1
