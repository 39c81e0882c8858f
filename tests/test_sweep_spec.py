"""Sweep specifications below the public surface: the TOML writer, the corner check's one
call into the batch layer, the tile-size choice, and the value object's immutability."""

import math
import pickle
import warnings
import tomllib

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.rattleback import batch
from rattlesweep.sweep import Sweep
from rattlesweep.sweep._config import corners
from rattlesweep.sweep._config.corners import TILE_STEPS, choose_tile_size
from rattlesweep.sweep._config.toml_io import format_toml, read_toml


def _same(a, b) -> bool:
    """Equality of plain data in which NaN equals NaN."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(map(_same, a, b))
    return type(a) is type(b) and a == b


# --- the TOML writer ---------------------------------------------------------------------

DOCUMENTS = {
    "numbers": {
        "i": 3,
        "neg": -7,
        "big": 2**62,
        "f": 0.1,
        "tiny": 1e-300,
        "huge": 1.5e300,
        "exp": 1e-07,
        "negzero": -0.0,
        "inf": math.inf,
        "minus_inf": -math.inf,
        "nan": math.nan,
        "t": True,
        "f2": False,
    },
    "strings": {
        "plain": "abc",
        "quotes": "say \"hi\" 'there'",
        "backslash": "C:\\dir\\x",
        "controls": "tab\there\nnew\rcr\bbs\ffeed\x00nul\x1fus\x7fdel",
        "unicode": "Füße – 角度 ε",
        "astral": "rattle 😀 𝛿",
        "empty": "",
        "toml_like": "[axes] = { x = 1 } # not a comment",
    },
    "keys": {
        "bare-key_1": 1,
        "with space": 2,
        "dotted.key": 3,
        "": 4,
        "é": 5,
        'quote"d': 6,
        "back\\slash": 7,
        "123": 8,
    },
    "tables": {
        "name": "top",
        "n": 1,
        "axes": {
            "spin": {"start": -1.0, "stop": 1.0, "num": 3},
            "mu": [0.3, math.inf],
            "delta_deg": {"values": [1.0, 2.0], "units": "deg"},
        },
        "fixed": {
            "body": {
                "a": 0.1,
                "com": [0.0, 0.0, -0.01],
                "inertia": [[1.0, 0.0], [0.0, 2.0]],
                "nested": {"deeper": {"x": -math.inf, "s": 'a"b'}},
                "empty": {},
                "full_ellipsoid": False,
            }
        },
        "lists": {
            "mixed_nesting": [[1, 2], [3.5, [4.0, "x"]]],
            "empty": [],
            "of_tables": [{"a": 1}, {"b": {"c": 2}}],
        },
    },
    # top-level values after a table still come out before every table
    "late_scalar": {"first": {"x": 1}, "late": 2.5, "second": {"y": [1, 2]}},
}


@pytest.mark.parametrize("name", sorted(DOCUMENTS))
def test_format_toml_round_trips(name):
    doc = DOCUMENTS[name]
    text = format_toml(doc, comment="a comment")
    assert text.startswith("# a comment\n")
    assert text.isascii()
    back = tomllib.loads(text)
    assert _same(
        back,
        {k: v for k, v in doc.items() if not isinstance(v, dict)}
        | {k: v for k, v in doc.items() if isinstance(v, dict)},
    ), text
    assert format_toml(back, comment="a comment") == text


def test_format_toml_is_a_readable_config_file():
    text = format_toml(DOCUMENTS["tables"])
    lines = text.splitlines()
    assert lines[:2] == ['name = "top"', "n = 1"]
    assert "[axes]" in lines and "[fixed]" in lines
    assert "spin = { start = -1.0, stop = 1.0, num = 3 }" in lines
    assert "mu = [0.3, inf]" in lines
    keys = format_toml(DOCUMENTS["keys"]).splitlines()
    assert keys[:4] == ["bare-key_1 = 1", '"with space" = 2', '"dotted.key" = 3', '"" = 4']
    assert '"\\u00E9" = 5' in keys
    assert format_toml({"s": "😀"}) == 's = "\\U0001F600"\n'


@pytest.mark.parametrize(
    "value, error",
    [
        (None, TypeError),
        (object(), TypeError),
        ({1: 2}, TypeError),
        ("\ud800", ValueError),
    ],
)
def test_format_toml_refuses_what_toml_cannot_hold(value, error):
    with pytest.raises(error):
        format_toml({"t": {"v": value}})


def test_read_toml_names_the_file(tmp_path):
    with pytest.raises(ValueError, match=r"cannot read .*missing\.toml"):
        read_toml(tmp_path / "missing.toml")
    latin = tmp_path / "latin.toml"
    latin.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(
        ValueError,
        match=r"cannot parse .*latin\.toml as TOML: it is not "
        r"UTF-8",
    ):
        read_toml(latin)
    utf8 = tmp_path / "utf8.toml"
    utf8.write_bytes('name = "café" # ε\n'.encode("utf-8"))
    assert read_toml(utf8) == {"name": "café"}
    assert read_toml(str(utf8)) == {"name": "café"}
    assert read_toml('x = 1\ny = "a.toml"') == {"x": 1, "y": "a.toml"}


# --- sweeps through TOML -----------------------------------------------------------------


def _configurations():
    toy = rs.Body.preset("toy")
    custom = rs.Body(
        toy.a, toy.b, toy.c, toy.mass, toy.com, toy.inertia, name='my "odd" body \\ ü'
    )
    return {
        "ranges_units_random": dict(
            axes={
                "spin": {"start": -12.0, "stop": 12.0, "num": 4},
                "delta_deg": [-4.0, 3.0],
                "mu": [0.3, math.inf],
            },
            fixed={"t_end": 3.0, "damping": 1e-7},
            random={"roll_deg": {"uniform": [0.3, 0.8]}},
            repeats=2,
            seed=7,
            tile_size=5,
        ),
        "log_rpm_ms_normal": dict(
            axes={
                "damping": {"start": 1e-6, "stop": 1e-4, "num": 3, "scale": "log"},
                "spin": {"values": [60.0, 120.0], "units": "rpm"},
            },
            fixed={
                "t_end": {"value": 500, "units": "ms"},
                "roll": {"value": 0.5, "units": "deg"},
            },
            random={"pitch": {"normal": [0.0, 0.1], "units": "deg"}},
            repeats=3,
            seed=2**40,
            method="euler",
            reversal_band=0.1,
            name='Füße – ε 😀 "quoted" \\',
        ),
        "body_axis": dict(
            axes={"body": ["toy", "kane_levinson"], "spin": [-5.0, 5.0]},
            fixed={"t_end": 1.0, "mu": 0.4, "mu_static": math.inf},
        ),
        "body_table": dict(axes={"spin": [1.0, 2.0]}, fixed={"t_end": 1.0, "body": custom}),
        "preset_no_t_end": dict(
            axes={"yaw_deg": [0.0, 90.0]}, fixed={"body": "kane_levinson"}
        ),
        "axis_order": dict(
            axes={"mu": [0.3, 0.5], "spin": [1.0], "roll_deg": [0.1, 0.2]},
            fixed={"t_end": 1.0},
        ),
    }


@pytest.mark.parametrize("name", sorted(_configurations()))
def test_sweep_toml_round_trip(name):
    s = Sweep(**_configurations()[name])
    text = s.to_toml()
    again = Sweep.from_toml(text)
    assert again == s and again.dims == s.dims and again.shape == s.shape
    assert again.to_toml() == text and again.config_hash() == s.config_hash()
    assert Sweep(**s.to_dict()) == s
    assert Sweep.from_dict(tomllib.loads(text)) == s


# --- the corner check --------------------------------------------------------------------


def test_corner_check_reaches_the_batch_layer_only_through_max_steps(monkeypatch):
    def no_prepare(*args, **kwargs):
        raise AssertionError("the corner check must call the batch layer via _max_steps")

    seen = []

    def fake_max_steps(bodies, kwargs):
        seen.append((len(bodies), sorted(kwargs)))
        return 1000

    monkeypatch.setattr(batch, "prepare", no_prepare)
    monkeypatch.setattr(corners, "_max_steps", fake_max_steps)
    s = Sweep(
        axes={"spin": {"start": -5.0, "stop": 5.0, "num": 50}, "mu": [0.1, 0.2, 0.3]},
        fixed={"t_end": 1.0},
        random={"roll_deg": {"uniform": [0.1, 0.2]}},
        repeats=4,
    )
    assert len(seen) == 1 and seen[0][0] == 2 * 2 * 2  # every corner, in one call
    assert {"spin", "mu", "roll", "t_end"} <= set(seen[0][1])
    assert s.tile_size == choose_tile_size(1000, 50 * 3 * 4)


def test_corner_check_names_the_first_offending_corner(monkeypatch):
    def fussy(bodies, kwargs):
        if np.any((kwargs["spin"] > 4.0) & (kwargs["mu"] < 0.2)):
            raise ValueError("spin too fast for mu")
        return 10

    monkeypatch.setattr(corners, "_max_steps", fussy)
    with pytest.raises(
        ValueError,
        match=r"^spin too fast for mu \(at the sweep corner "
        r"spin=5 rad s-1, mu=0\.1; fixed: fixed.t_end = "
        r"1\.0\)$",
    ):
        Sweep(axes={"spin": [-5.0, 5.0], "mu": [0.1, 0.3]}, fixed={"t_end": 1.0})


def test_stability_only_sweeps_size_tiles_for_one_second(monkeypatch):
    t_ends = []

    def record(bodies, kwargs):
        t_ends.append(np.unique(kwargs["t_end"]).tolist())
        return 1000

    monkeypatch.setattr(corners, "_max_steps", record)
    Sweep(axes={"spin": [1.0, 2.0]})
    Sweep(axes={"spin": [1.0, 2.0], "t_end": [2.0, 3.0]})
    assert t_ends == [[1.0], [2.0, 3.0]]


@pytest.mark.parametrize(
    "max_steps, size, expected",
    [
        (10**9, 10**6, 256),  # very long runs: the smallest tile
        (10, 10**9, 65536),  # very short runs: the largest tile
        (1000, 10**9, 20000),  # 2e7 / 1000 steps, rounded up to 32
        (1000, 16 * 5000, 5024),  # at least 16 tiles
    ],
)
def test_choose_tile_size(max_steps, size, expected):
    assert TILE_STEPS == 2e7
    tile = choose_tile_size(max_steps, size)
    assert tile == expected and tile % 32 == 0


@pytest.mark.parametrize("tile_size", [1, 2, 5, 7, 64, 66, 67, 256, 10_000])
def test_tiles_are_grid_blocks_of_consecutive_points_covering_the_grid(tile_size):
    s = Sweep(
        axes={"spin": list(range(41)), "delta_deg": list(range(33)), "mu": [0.3, 1.0]},
        fixed={"t_end": 1.0},
        tile_size=tile_size,
    )
    cover = np.zeros(s.shape, dtype=int)
    for tile in range(s.n_tiles):
        start, stop = s.tile_range(tile)
        assert 0 < stop - start <= tile_size
        block = np.zeros(s.shape, dtype=bool)
        block[s.tile_region(tile)] = True
        # the block's points are exactly the flat range, in order
        np.testing.assert_array_equal(np.flatnonzero(block.ravel()), np.arange(start, stop))
        cover[block] += 1
    assert np.all(cover == 1)
    # full tiles hold more than half of tile_size points (runs are cut evenly)
    full = np.prod(s.tile_shape)
    assert tile_size / 2 < full <= tile_size or full == s.size


# --- the value object --------------------------------------------------------------------


def test_sweep_is_immutable_picklable_and_does_not_touch_its_arguments():
    axes = {"spin": [2.0, 1.0], "delta_deg": np.array([1.0, 2.0])}
    fixed = {"t_end": 1.0}
    s = Sweep(axes=axes, fixed=fixed, tile_size=3)
    assert fixed == {"t_end": 1.0} and isinstance(axes["delta_deg"], np.ndarray)
    for attr in (
        "axes",
        "fixed",
        "random",
        "repeats",
        "seed",
        "method",
        "reversal_band",
        "tile_size",
        "name",
        "grid_axes",
        "random_params",
        "shape",
    ):
        with pytest.raises(AttributeError):
            setattr(s, attr, None)
    with pytest.raises(AttributeError):
        s.new_attribute = 1
    with pytest.raises(TypeError):
        hash(s)
    back = pickle.loads(pickle.dumps(s))
    assert back == s and back.shape == (2, 2) and back.tile_size == 3
    np.testing.assert_array_equal(back.points(0, 4)[1]["spin"], s.points(0, 4)[1]["spin"])
    assert repr(s).startswith("Sweep(axes={'spin': {'values': [2.0, 1.0]}, 'delta_deg'")
    assert repr(s).endswith("tile_size=3, output='netcdf', name='sweep')")


def test_the_order_of_the_axes_is_part_of_the_configuration(tmp_path):
    """The axes' order is the result's dimension order: a reordered configuration is a
    different sweep (a resume into its directory would otherwise merge tiles laid out
    the other way)."""
    from rattlesweep.sweep._outputs.directory import TileDirectory

    fixed = {"t_end": 0.1}
    a = Sweep(axes={"spin": [1.0, 2.0], "mu": [0.3, math.inf]}, fixed=fixed)
    b = Sweep(axes={"mu": [0.3, math.inf], "spin": [1.0, 2.0]}, fixed=fixed)
    assert a != b and a.config_hash() != b.config_hash()
    assert (
        a == Sweep.from_toml(a.to_toml())
        and a.config_hash() == Sweep.from_toml(a.to_toml()).config_hash()
    )
    assert a.differences(b) == ["axes: order spin, mu -> mu, spin"]
    first = TileDirectory(a, tmp_path)
    first.open()
    first.close()
    with pytest.raises(
        ValueError, match="holds a different sweep.*order spin, mu -> mu, spin"
    ):
        TileDirectory(b, tmp_path).open()


def test_every_value_of_a_launch_angle_axis_is_checked_before_compute():
    """The tilt is periodic in a launch angle: a roll axis whose extremes are upright
    launches can hold a value between them that puts the rim on the floor (-1.7e15 deg
    is 133 deg). Only the extremes were checked, and the sweep failed in its first tile
    without naming the axis (found by the long property-test run)."""
    with pytest.raises(
        ValueError,
        match=r"puts the rim .* \(at the sweep corner "
        r"delta_deg=0 degree, roll_deg=-1.69611e\+15 degree; "
        r"fixed: fixed.t_end = 0.015625\)",
    ):
        Sweep(
            axes={
                "delta_deg": {"start": 0.0, "stop": 0.0, "num": 1},
                "roll_deg": {"start": -3392225027273791.0, "stop": 5.000000001, "num": 3},
            },
            fixed={"t_end": 0.015625},
        )


def test_a_rule_broken_by_a_fixed_value_names_it():
    """A fixed roll of 1e300 deg (132 deg modulo 360) puts the rim on the floor at every
    corner; the message named only the varying axis (found by the long property-test
    run)."""
    with pytest.raises(
        ValueError,
        match=r"puts the rim .*\(at the sweep corner delta_deg=0 "
        r"degree; fixed: fixed.roll_deg = 1e\+300, "
        r"fixed.t_end = 0.015625\)",
    ):
        Sweep(
            axes={"delta_deg": {"start": 0.0, "stop": 0.0, "num": 1}},
            fixed={"roll_deg": 1e300, "t_end": 0.015625},
        )


def test_a_random_launch_angle_range_is_checked_between_its_bounds():
    """uniform [-300, 300] deg: both bounds are upright launches (cos 300 deg = 0.5), but
    draws near 180 deg put the rim on the floor; the multiples of pi inside the range
    stand for them in the check."""
    with pytest.raises(
        ValueError,
        match=r"initial tilt 180 deg.*\(at the sweep corner "
        r"spin=1 rad s-1, roll_deg=-180 degree; fixed: "
        r"fixed.t_end = 0.1\)",
    ):
        Sweep(
            axes={"spin": {"start": 1.0, "stop": 2.0, "num": 2}},
            fixed={"t_end": 0.1},
            random={"roll_deg": {"uniform": [-300.0, 300.0]}},
            repeats=2,
            seed=1,
        )
    Sweep(
        axes={"spin": {"start": 1.0, "stop": 2.0, "num": 2}},
        fixed={"t_end": 0.1},
        random={"roll_deg": {"uniform": [-80.0, 80.0]}},
        repeats=2,
        seed=1,
    )
    assert corners.angle_corners([0.1, 2.0, 3.0, -0.2]) == [-0.2, 0.1, 3.0]


def test_a_default_step_too_small_names_the_body_it_comes_from():
    """c = 1e-300 m makes a default step of 1e-152 s: the message named t_end and dt but
    not the semi-axis the step came from (found by the long property-test run)."""
    with pytest.raises(
        ValueError,
        match=r"2\*\*53 steps.*body = 'semi_ellipsoid' with "
        r"a = 0.0475, b = 0.0095, c = 1e-300 m",
    ):
        Sweep(
            axes={"spin": {"start": 0.0, "stop": 0.0, "num": 1}},
            fixed={"c": 1e-300, "t_end": 0.015625},
        )


def test_a_tilt_in_radians_that_can_only_be_degrees_warns_as_run_batch_does():
    """roll = 30 in a sweep (radians, the default) is 1719 degrees: run_batch warns of
    it, and a sweep, which passes its angles on in radians, did not (it launched at
    -81 degrees)."""
    fixed = {"t_end": 0.5}
    with pytest.warns(rs.UnitsWarning, match=r"roll = 30 rad \(1719 degrees\)") as seen:
        Sweep(axes={"spin": [1.0]}, fixed={**fixed, "roll": 30})
    assert seen[0].filename == __file__  # at the caller's line
    for where in (
        {"random": {"pitch": {"uniform": [0.0, 1.7]}}, "repeats": 2},
        {"axes": {"spin": [1.0], "roll": {"values": [0.2, 1.6]}}},
    ):
        with pytest.warns(rs.UnitsWarning, match="is more than 90 degrees from upright"):
            try:
                Sweep(**{"axes": {"spin": [1.0]}, "fixed": fixed, **where})
            except ValueError:
                pass  # and refused where a corner puts the rim on the floor
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for tilt in ({"roll_deg": 30}, {"roll": {"value": 30, "units": "deg"}}):
            Sweep(axes={"spin": [1.0]}, fixed={**fixed, **tilt})
        Sweep(axes={"spin": [1.0]}, fixed={**fixed, "yaw": 30})  # yaw turns freely
