"""rattlesweep design: a printable rattleback with coin pockets.

One run of the command line (the default search, as a user would run it) makes the files
that most tests read: the STL, design.toml, sweep.toml, the placement sheet and the
reversal map. The chosen design is then checked with launches the search never made."""

import math
import os
import re
import struct
import tomllib

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.cli import main

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("manifold3d")

from rattlesweep.design import (  # noqa: E402
    COINS,
    Coin,
    DesignRefused,
    Launches,
    Material,
    Part,
    PrintSettings,
    body_of,
    design,
    load_body,
)
from rattlesweep.design.constraints import check_margin  # noqa: E402
from rattlesweep.design.mass import moments_of  # noqa: E402
from rattlesweep.design.mesh import (  # noqa: E402
    PRINT_FROM_BODY,
    coin_meshes,
    core_mesh,
    moments_of_mesh,
)
from rattlesweep.sweep import Sweep  # noqa: E402

SHELL = (0.07, 0.02, 0.018)  # m: 140 x 40 x 18 mm


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    out = tmp_path_factory.mktemp("design")
    a, b, c = SHELL
    status = main(
        ["design", "--a", str(a), "--b", str(b), "--c", str(c), "--out", str(out)]
    )
    assert status == 0
    with open(out / "design.toml", "rb") as f:
        doc = tomllib.load(f)
    return out, doc


def part_from(doc):
    """The Part that a design.toml describes, rebuilt from its tables."""
    shell, coin, pr = doc["shell"], doc["coins"], doc["print"]
    settings = PrintSettings(
        Material(pr["material"], pr["density"], pr["density_source"]),
        pr["infill"],
        pr["wall"],
        pr["clearance"],
        pr["rim"],
    )
    the_coin = Coin(
        coin["name"],
        coin["mass"],
        coin["diameter"],
        coin["thickness"],
        coin["inner_diameter"],
        coin["source"],
    )
    (x, y, _), (x2, y2, _) = coin["centres"]
    assert (x2, y2) == (-x, -y)
    return Part(shell["a"], shell["b"], shell["c"], the_coin, x, y, settings)


def launches():
    """Launches as a person makes them, none of them the search's: spins 3-10 rad/s,
    tilts below 1 degree, friction over 0.2-0.5 (its ends included)."""
    rng = np.random.default_rng(33)
    n = 24
    spin = rng.uniform(3.0, 10.0, n)
    tilt = np.radians(rng.uniform(0.05, 0.95, n))
    heading = rng.uniform(0, 2 * np.pi, n)
    mu = np.concatenate([[0.2, 0.5, 0.2, 0.5], rng.uniform(0.2, 0.5, n - 4)])
    return spin, tilt * np.cos(heading), tilt * np.sin(heading), mu


def reversals(body, sign):
    """First reversal times (s, NaN for none within 15 s) of launches spun with sign."""
    spin, roll, pitch, mu = launches()
    ds = rs.run_batch(
        body,
        spin=sign * spin,
        roll=roll,
        pitch=pitch,
        mu=mu,
        t_end=15.0,
        stop="first_reversal",
    )
    assert (ds.status.values == 0).all()
    return ds.first_reversal_time.values


def test_stl_is_watertight_has_the_size_and_the_pockets(made):
    out, doc = made
    mesh = trimesh.load(out / "rattleback.stl")
    assert mesh.is_watertight and mesh.is_volume
    a, b, c = SHELL
    # millimetres, flat face on the bed
    np.testing.assert_allclose(
        mesh.bounds, [[-a * 1e3, -b * 1e3, 0], [a * 1e3, b * 1e3, c * 1e3]], atol=0.01
    )
    part = part_from(doc)
    r, t = part.pocket_radius, part.coin.thickness
    solid = 2 / 3 * math.pi * a * b * c * 1e9
    pockets = 2 * math.pi * r * r * t * 1e9
    assert mesh.volume == pytest.approx(solid - pockets, rel=1e-3)
    # each pocket: a circle of the pocket's radius in the bed face (z = 0) and a floor
    # at the coin's depth, around the coin centre mirrored in y (print pose)
    v = mesh.vertices
    at_floor = np.isclose(v[:, 2], t * 1e3, atol=1e-6)
    near = np.zeros(len(v), dtype=bool)
    for x, y, _ in doc["coins"]["centres"]:
        d = np.hypot(v[:, 0] - x * 1e3, v[:, 1] + y * 1e3)
        rim = np.isclose(v[:, 2], 0.0, atol=1e-6) & np.isclose(d, r * 1e3, rtol=1e-3)
        floor = at_floor & np.isclose(d, r * 1e3, rtol=1e-3)
        assert rim.sum() >= 200 and floor.sum() >= 200
        near |= d <= r * 1e3 * 1.001
    assert not (at_floor & ~near).any()  # nothing else at that depth


def test_mesh_mass_properties_match_the_simulated_body(made):
    """The STL's part at the material's density, less the infill core's share, plus the
    coins as meshed discs, against the Body in design.toml (within 0.5 %)."""
    out, doc = made
    part = part_from(doc)
    mesh = trimesh.load(out / "rattleback.stl")
    mesh.apply_transform(np.linalg.inv(PRINT_FROM_BODY))  # back to the body frame, m
    rho, infill = part.settings.material.density, part.settings.infill
    total = moments_of_mesh(mesh, rho) + moments_of_mesh(
        core_mesh(part), -(1 - infill) * rho
    )
    for coin in coin_meshes(part):
        total = total + moments_of_mesh(coin, part.coin.density)
    body = load_body(out / "design.toml")
    assert total.mass == pytest.approx(body.mass, rel=5e-3)
    assert np.linalg.norm(total.com - body.com) <= 5e-3 * np.linalg.norm(body.com)
    scale = np.abs(body.inertia).max()
    assert np.abs(total.inertia - body.inertia).max() <= 5e-3 * scale
    # the product of inertia that makes it a rattleback, on its own scale
    assert total.inertia[0, 1] == pytest.approx(body.inertia[0, 1], rel=5e-3)
    assert body.inertia[0, 1] != 0


@pytest.mark.parametrize("coin", ["usd_0.25", "washer_M10"])
def test_mesh_and_closed_form_agree_for_coins_and_washers(coin):
    part = Part(*SHELL, COINS[coin], 0.024, -0.003, PrintSettings(infill=0.35))
    from rattlesweep.design.mesh import mesh_moments

    m, exact = mesh_moments(part), moments_of(part)
    assert m.mass == pytest.approx(exact.mass, rel=5e-3)
    np.testing.assert_allclose(
        m.inertia, exact.inertia, atol=5e-3 * np.abs(exact.inertia).max()
    )
    assert m.inertia[0, 1] == pytest.approx(exact.inertia[0, 1], rel=5e-3)


def test_design_reverses_in_the_bad_sense_only(made):
    out, doc = made
    body = load_body(out / "design.toml")
    pred = doc["prediction"]
    assert pred["preferred_sense"] == "cw" and pred["robust"]
    bad, good = reversals(body, +1.0), reversals(body, -1.0)  # cw preferred: n < 0 spins on
    assert np.isfinite(bad).all(), bad
    assert np.isnan(good).all(), good
    # the predicted times bracket what these launches show at the friction range's ends
    lo, hi = pred["first_reversal_time_mu_low"], pred["first_reversal_time_mu_high"]
    assert 0 < lo["min"] <= lo["median"] <= lo["max"] < 15
    assert 0 < hi["min"] <= hi["median"] <= hi["max"] < 15
    assert doc["prediction"]["launches_in_search"] > 1000


def test_mirrored_placement_reverses_the_preference(made):
    _, doc = made
    mirror = body_of(part_from(doc).mirrored())
    assert np.isnan(reversals(mirror, +1.0)).all()
    assert np.isfinite(reversals(mirror, -1.0)).all()


def test_design_toml_is_a_body_for_sweeps_and_the_map_sweep_loads(made):
    out, doc = made
    body = load_body(out / "design.toml")
    # the [body] table, copied as it is into a sweep file
    text = (out / "design.toml").read_text()
    table = text[text.index("[body]\n") + len("[body]\n") :].split("\n[", 1)[0]
    sweep = Sweep.from_toml(
        f"[axes]\nspin = [5.0]\n\n[fixed]\nt_end = 1.0\n\n[fixed.body]\n{table}\n"
    )
    assert sweep.fixed["body"]["mass"] == body.mass
    np.testing.assert_array_equal(sweep.fixed["body"]["inertia"], body.inertia)
    mapped = Sweep.from_toml(out / "sweep.toml")
    assert set(mapped.axes) == {"spin", "mu"}
    assert mapped.fixed["body"]["inertia"][0][1] == pytest.approx(body.inertia[0, 1])


def test_placement_sheet_is_one_to_one(made):
    out, doc = made
    from matplotlib.image import imread

    png = imread(out / "placement_sheet.png")
    height_px, width_px = png.shape[:2]
    pdf = (out / "placement_sheet.pdf").read_bytes()
    box = [
        float(v) for v in re.search(rb"/MediaBox \[\s*([\d.\s]+)\]", pdf).group(1).split()
    ]
    width_pt, height_pt = box[2] - box[0], box[3] - box[1]
    # the PNG at 300 dpi and the PDF (72 pt per inch) show the same real size
    assert width_px / 300 == pytest.approx(width_pt / 72, abs=1 / 300 * 2)
    assert height_px / 300 == pytest.approx(height_pt / 72, abs=1 / 300 * 2)
    # the sheet holds the whole face with a margin: wider than 2a, taller than 2b (mm)
    a, b, _ = SHELL
    assert width_pt / 72 * 25.4 > 2 * a * 1e3
    assert height_pt / 72 * 25.4 > 2 * b * 1e3
    with open(out / "placement_sheet.png", "rb") as f:
        data = f.read()
    phys = data.index(b"pHYs")
    (ppm_x,) = struct.unpack(">I", data[phys + 4 : phys + 8])
    assert ppm_x == pytest.approx(300 / 0.0254, rel=1e-3)  # dots per metre
    assert (out / "reversal_map.png").stat().st_size > 10_000


def test_search_and_map_data_are_kept(made):
    import xarray as xr

    out, doc = made
    with xr.open_dataset(out / "search.nc") as s:
        n = int(s.sizes["candidate"])
        assert doc["prediction"]["placements_tried"] == n
        assert s.first_reversal_time.size == doc["prediction"]["launches_in_search"]
        best = s.isel(candidate=int(s.attrs["best_candidate"]))
        assert (float(best.x), float(best.y)) == pytest.approx(
            tuple(doc["coins"]["centres"][0][:2])
        )
        assert bool(best.robust)
    with xr.open_dataset(out / "reversal_map.nc") as m:
        assert m.first_reversal_time.dims == ("spin", "mu")
        t = m.first_reversal_time
        # the map agrees with the preference: reversals for spins of the bad sense only
        assert t.sel(spin=t.spin[t.spin >= 3]).notnull().all()
        assert t.sel(spin=t.spin[t.spin <= -3]).isnull().all()


def test_too_heavy_coins_are_refused_with_the_largest_mass_that_works():
    a, b, c = 0.05, 0.014, 0.015  # b**2/c = 13 mm: G must stay low
    with pytest.raises(
        DesignRefused,
        match=r"design refused: .* 20 g .* the largest coin "
        r"mass that would do, at this coin's size, is [\d.]+ g per coin",
    ) as e:
        design(a, b, c, coin="usd_0.01", coin_mass=0.02)
    m_max = e.value.max_coin_mass
    said = float(re.search(r"is ([\d.]+) g per coin", str(e.value)).group(1))
    assert said == pytest.approx(m_max * 1e3, rel=5e-3)
    assert 0 < m_max < 0.02
    coin = COINS["usd_0.01"]
    part = Part(a, b, c, coin, 0.0, 0.0, PrintSettings())

    def with_mass(m):
        return Part(
            a, b, c, Coin("x", m, coin.diameter, coin.thickness), 0.0, 0.0, part.settings
        )

    check_margin(with_mass(0.99 * m_max), 0.1)  # passes
    with pytest.raises(DesignRefused):
        check_margin(with_mass(1.01 * m_max), 0.1)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"infill": 0.0}, r"infill = 0.0 is invalid: it must be a fraction in \(0, 1\]"),
        ({"infill": 1.5}, r"infill = 1.5 is invalid"),
        ({"infill": float("nan")}, r"infill = nan is invalid"),
        ({"shell": (0.05, 0.012, 0.03)}, r"cannot rock stably.*b\*\*2/c"),
        (
            {"shell": (0.05, 0.013, 0.01), "coin": "eur_2"},
            r"coin diameter = 0.02575 m is too wide for the flat face",
        ),
        ({"shell": (-0.05, 0.02, 0.018)}, r"a = -0.05 is invalid"),
        (
            {"shell": (70, 20, 18)},
            r"a = 70 is invalid: it must be a finite length > 0 and at "
            r"most 1 m \(SI units: m\); 70 looks like millimetres",
        ),
        ({"mu": (0.5, 0.2)}, r"mu high = 0.2 is invalid"),
        ({"prefer": "left"}, r"prefer = 'left' is invalid"),
        ({"coins": 3}, r"coins = 3 is invalid"),
        ({"coin": "EUR_3"}, r"coin 'EUR_3' is unknown"),
        ({"coin": "doubloon"}, r"coin 'doubloon' is unknown"),
        (
            {
                "coin": None,
                "coin_mass": -1.0,
                "coin_diameter": 0.02,
                "coin_thickness": 0.002,
            },
            r"coin mass must be a finite number > 0",
        ),
        ({"margin": 1.0}, r"margin = 1.0 is invalid: it must be a fraction in \[0, 1\)"),
    ],
)
def test_bad_inputs_are_refused_before_any_simulation(kwargs, message, monkeypatch):
    import rattlesweep.design.search as search

    def no_compute(*args, **kw):
        raise AssertionError("a simulation started")

    monkeypatch.setattr(search, "run_batch", no_compute)
    kwargs = dict(kwargs)
    shell = kwargs.pop("shell", SHELL)
    with pytest.raises(ValueError, match=message):
        design(*shell, **kwargs)


def test_cli_reports_bad_input_as_an_error(capsys):
    assert (
        main(
            [
                "design",
                "--a",
                "0.07",
                "--b",
                "0.02",
                "--c",
                "0.018",
                "--infill",
                "0",
                "--out",
                "unused",
            ]
        )
        == 2
    )
    assert "infill = 0.0 is invalid" in capsys.readouterr().err


def test_every_coin_is_offered_and_documented():
    from pathlib import Path

    from rattlesweep.cli import build_parser

    help_text = " ".join(
        build_parser()
        ._subparsers._group_actions[0]  # noqa: SLF001
        .choices["design"]
        .format_help()
        .split()
    )
    page = Path(__file__).resolve().parent.parent / "docs/guide/design.md"
    doc = page.read_text() if page.is_file() else None
    for name, coin in COINS.items():
        assert name in help_text
        assert coin.source
        if doc is not None:
            row = next(line for line in doc.splitlines() if line.startswith(f"| `{name}`"))
            cells = [c.strip() for c in row.split("|")[1:-1]]
            assert float(cells[1]) == pytest.approx(coin.mass * 1e3, abs=0.005)
            assert float(cells[2].split()[0]) == pytest.approx(coin.diameter * 1e3)
            assert float(cells[3]) == pytest.approx(coin.thickness * 1e3)


# --- what a new user's trial found (issue 33, second round) ---------------------------

CHEAP = dict(
    grid=(2, 2),
    refine=0,
    reversal_map=False,
    launches=Launches(spins=(5.0,), tilts=((0.01, 0.0),), n_mu=2, t_end=2.0),
)


def no_simulation(monkeypatch):
    import rattlesweep.design.search as search

    def no_compute(*args, **kw):
        raise AssertionError("a simulation started")

    monkeypatch.setattr(search, "run_batch", no_compute)


def test_a_directory_holding_files_is_refused_before_any_simulation(
    made, tmp_path, monkeypatch, capsys
):
    out, _ = made
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    no_simulation(monkeypatch)
    a, b, c = SHELL
    assert (
        main(["design", "--a", str(a), "--b", str(b), "--c", str(c), "--out", str(out)])
        == 2
    )
    err = capsys.readouterr().err
    assert str(out) in err and "a previous design (8 of its 8 files" in err
    assert "design.toml" in err and "--force" in err
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    other = tmp_path / "notes"
    other.mkdir()
    (other / "shopping.txt").write_text("milk")
    with pytest.raises(ValueError, match=r"already holds 1 entries: shopping.txt"):
        design(*SHELL, out=other)
    assert (other / "shopping.txt").read_text() == "milk"


def test_overwrite_replaces_the_design_files_and_keeps_others(tmp_path):
    out = tmp_path / "d"
    out.mkdir()
    (out / "shopping.txt").write_text("milk")
    (out / "design.toml").write_text("old")
    d = design(*SHELL, coin="usd_0.01", out=out, overwrite=True, **CHEAP)
    assert (out / "shopping.txt").read_text() == "milk"
    assert load_body(out / "design.toml").mass == pytest.approx(d.body.mass)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # no temporary left


def test_a_failed_write_leaves_no_half_design(tmp_path, monkeypatch):
    import rattlesweep.design.files as files

    def broken(*args, **kw):
        raise OSError("disk full")

    monkeypatch.setattr(files, "write_sheet", broken)
    with pytest.raises(OSError, match="disk full"):
        design(*SHELL, out=tmp_path / "d", **CHEAP)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def not_robust(tmp_path_factory):
    """gbp_0.10 on the 140 x 40 x 18 mm shell: no placement reverses the slowest
    wrong-way flicks (3 rad/s) within 15 s (a grid of 161 placements and four
    refinement levels finds none either)."""
    out = tmp_path_factory.mktemp("not_robust") / "d"
    a, b, c = SHELL
    import contextlib
    import io

    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        status = main(
            [
                "design",
                "--a",
                str(a),
                "--b",
                str(b),
                "--c",
                str(c),
                "--coin",
                "GBP_0.10",
                "--out",
                str(out),
            ]
        )
    return out, status, stdout.getvalue(), stderr.getvalue()


def test_a_design_not_robust_fails_loudly_and_says_what_to_try(not_robust, made):
    out, status, stdout, stderr = not_robust
    from rattlesweep.cli._launches import NOT_ROBUST_STATUS

    assert status == NOT_ROBUST_STATUS != 0
    with open(out / "design.toml", "rb") as f:
        doc = tomllib.load(f)
    pred = doc["prediction"]
    assert not pred["robust"] and pred["bad_sense_reversed_fraction"] < 1
    assert "NOT ROBUST" in stdout and "NOT ROBUST" in stderr
    assert "--accept-not-robust" in stderr
    missed = round((1 - pred["bad_sense_reversed_fraction"]) * 36)
    assert f"{missed} of 36 launches" in stdout and "did not reverse within 15 s" in stdout
    assert "what to try" in stdout and "wider shell (e.g. --b 0.022)" in stdout
    # the sheet and the map carry the red warning; a robust design's do not
    from matplotlib.image import imread

    def red(path):
        img = imread(path)[..., :3]
        return int(((img[..., 0] > 0.9) & (img[..., 1] < 0.2) & (img[..., 2] < 0.2)).sum())

    good, _ = made
    for name in ("placement_sheet.png", "reversal_map.png"):
        assert red(out / name) > 1000
        assert red(good / name) == 0


def test_accept_not_robust_exits_zero(not_robust, tmp_path, capsys):
    a, b, c = SHELL
    assert (
        main(
            [
                "design",
                "--a",
                str(a),
                "--b",
                str(b),
                "--c",
                str(c),
                "--coin",
                "gbp_0.10",
                "--out",
                str(tmp_path / "d"),
                "--accept-not-robust",
                "--quiet",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert "NOT ROBUST" in captured.out and captured.err == ""


def test_progress_is_shown(not_robust, monkeypatch):
    _, _, _, stderr = not_robust
    for line in (
        "searching 24 placements x 72 launches...",
        "refining (level 1 of 2)",
        "reversal map: 41 spins x 9 friction values...",
        "writing files into",
    ):
        assert line in stderr
    from rattlesweep._run import kernels_compiled

    assert kernels_compiled()  # the kernels ran, so numba cached them
    import rattlesweep.design.api as api

    monkeypatch.setattr(api, "kernels_compiled", lambda: False)
    said = []
    design(*SHELL, progress=said.append, **CHEAP)
    assert said[0].startswith("compiling the simulation kernels (first run only")
    assert re.fullmatch(r"searching \d+ placements x 4 launches\.\.\.", said[1])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"shell": (70, 20, 18)},
            r"a = 70 is invalid: .*; 70 looks like millimetres: give "
            r"metres, e.g. 0.07",
        ),
        (
            {"wall": 1.2},
            r"wall = 1.2 is invalid.*1.2 looks like millimetres: give metres, e.g. "
            r"0.0012",
        ),
        ({"clearance": 0.4}, r"0.4 looks like millimetres: give metres, e.g. 0.0004"),
        ({"rim": 2}, r"2 looks like millimetres: give metres, e.g. 0.002"),
        ({"infill": 20}, r"infill = 20 is invalid: .*it is a fraction: 20 % is 0.2"),
        ({"wall": 0.02}, r"wall = 0.02 m is too thick for this shell.*c = 0.018 m"),
        (
            {"density": 1.24},
            r"density = 1.24 is invalid.*looks like g/cm\^3: 1.24 g/cm\^3 is "
            r"1240 kg/m\^3",
        ),
        ({"material": "nylon"}, r"material 'nylon' is unknown.*--density"),
    ],
)
def test_unit_mistakes_are_named(kwargs, message, monkeypatch):
    no_simulation(monkeypatch)
    kwargs = dict(kwargs)
    with pytest.raises(ValueError, match=message):
        design(*kwargs.pop("shell", SHELL), **kwargs)


def test_density_overrides_the_material(monkeypatch):
    """The largest coin mass scales with the print's mass, so with the density."""
    no_simulation(monkeypatch)
    a, b, c = 0.05, 0.014, 0.015
    masses = []
    for material, density in (("pla", None), ("nylon", 2 * 1240.0)):
        with pytest.raises(DesignRefused) as e:
            design(
                a, b, c, coin="usd_0.01", coin_mass=0.05, material=material, density=density
            )
        masses.append(e.value.max_coin_mass)
    assert masses[1] == pytest.approx(2 * masses[0], rel=1e-9)
    assert (
        main(
            [
                "design",
                "--a",
                "0.05",
                "--b",
                "0.014",
                "--c",
                "0.015",
                "--coin-mass",
                "0.05",
                "--material",
                "nylon",
                "--density",
                "2480",
                "--out",
                "unused",
            ]
        )
        == 2
    )


def test_simulate_and_animate_take_the_design_toml(made, tmp_path):
    import xarray as xr

    out, doc = made
    # a wrong-way flick (cw preferred: n > 0) reverses; the numbers are the design's
    assert (
        main(
            [
                "simulate",
                "--body",
                str(out / "design.toml"),
                "--spin",
                "7",
                "--mu",
                "0.3",
                "--roll-deg",
                "0.5",
                "--t-end",
                "15",
                "--out",
                str(tmp_path / "run.nc"),
            ]
        )
        == 0
    )
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        assert ds.attrs["body_name"] == "printed rattleback"
        assert math.isfinite(float(ds.first_reversal_time))
    assert (
        main(
            [
                "animate",
                "--body",
                str(out / "design.toml"),
                "--spin",
                "7",
                "--mu",
                "0.3",
                "--t-end",
                "1",
                "--frames",
                "3",
                "--dpi",
                "30",
                "--out",
                str(tmp_path / "a.gif"),
            ]
        )
        == 0
    )
    assert (tmp_path / "a.gif").stat().st_size > 1000


def test_coin_names_in_any_case_and_the_help(monkeypatch):
    from rattlesweep.cli import build_parser
    from rattlesweep.design import make_coin

    assert make_coin("EUR_1") == COINS["eur_1"]
    assert make_coin("washer_m10") == COINS["washer_M10"]
    help_text = " ".join(
        build_parser()
        ._subparsers._group_actions[0]  # noqa: SLF001
        .choices["design"]
        .format_help()
        .split()
    )
    assert "--coins" not in help_text
    assert "Two coins are used" in help_text
    assert help_text.count("which this overrides") >= 4  # coin mass, diameter, thickness,
    # density


def test_sheet_labels_clear_the_outline_and_each_other(made):
    _, doc = made
    from rattlesweep.design.sheet import placement_sheet
    from matplotlib.patches import Ellipse

    for banner in (None, "NOT ROBUST: test\nsecond line"):
        fig = placement_sheet(part_from(doc), "cw", banner)
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        renderer = FigureCanvasAgg(fig).get_renderer()
        ax = fig.axes[0]
        outline = next(p for p in ax.patches if isinstance(p, Ellipse))
        path = outline.get_transform().transform_path(outline.get_path())
        boxes = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
        assert len(boxes) >= 8
        labels = [t for t in ax.texts if t.get_text().startswith("coin centre")]
        assert len(labels) == 2
        for box in boxes:
            assert not path.intersects_bbox(box, filled=False)
        for i, box in enumerate(boxes):
            for other in boxes[i + 1 :]:
                assert not box.overlaps(other)


def test_map_names_its_tilt_and_its_dashed_lines(made):
    import xarray as xr

    from rattlesweep.design.maps import map_figure

    out, doc = made
    with xr.open_dataset(out / "reversal_map.nc") as m:
        data = m.load()
    roll, pitch = Launches().tilts[0]  # one of the search's tilts
    assert data.attrs["roll_deg"] == pytest.approx(math.degrees(roll))
    assert data.attrs["pitch_deg"] == pytest.approx(math.degrees(pitch))
    fig = map_figure(data, "cw", (3.0, 10.0))
    ax = fig.axes[0]
    assert f"launch tilt {math.degrees(roll):.2g} deg roll" in ax.get_title()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["a person's flick: 3 to 10 rad/s, either sense (the search's spins)"]


def test_summary_and_files_speak_plainly(made, not_robust):
    out, doc = made
    _, _, stdout, _ = not_robust
    assert "t_end" not in stdout and "to never" not in stdout
    assert "within 15 s of spinning" in stdout
    sweep = tomllib.loads((out / "sweep.toml").read_text())
    assert sweep["fixed"]["body"]["name"] == doc["body"]["name"] == "printed rattleback"
    assert "body_name" not in (out / "sweep.toml").read_text()


def coin_table():
    """The docs' coin table: name -> the cell 'robust on 140 x 40 x 18 mm'."""
    from pathlib import Path

    page = Path(__file__).resolve().parent.parent / "docs/guide/design.md"
    if not page.is_file():
        pytest.skip("docs/guide/design.md is not in this checkout")
    rows = [line for line in page.read_text().splitlines() if line.startswith("| `")]
    return {row.split("`")[1]: row.split("|")[-2].strip() for row in rows}


def test_the_coin_table_says_what_the_design_runs_show(made, not_robust):
    table = coin_table()
    assert table["eur_1"] == "yes"  # made: robust
    assert table["gbp_0.10"].startswith("no")  # not_robust: exit status 3


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("RATTLESWEEP_SLOW"), reason="slow: set RATTLESWEEP_SLOW=1 to run"
)
@pytest.mark.parametrize("name", sorted(COINS))
def test_every_coin_table_claim(name):
    """Each row's claim, by the default search: robust or not on the example shell, and
    robust on the shell named beside a 'no'."""
    cell = coin_table()[name]
    d = design(*SHELL, coin=name, reversal_map=False)
    assert d.robust == cell.startswith("yes"), d.summary()
    other = re.search(r"`(--[^`]+)`", cell)
    if other:
        args = other.group(1).split()
        shell = dict(zip("abc", SHELL))
        shell.update({k[2:]: float(v) for k, v in zip(args[::2], args[1::2])})
        assert design(
            shell["a"], shell["b"], shell["c"], coin=name, reversal_map=False
        ).robust


def test_a_new_directory_gets_the_usual_permissions(tmp_path):
    import stat

    umask = os.umask(0o022)
    try:
        design(*SHELL, out=tmp_path / "d", **CHEAP)
    finally:
        os.umask(umask)
    assert stat.S_IMODE((tmp_path / "d").stat().st_mode) == 0o755
