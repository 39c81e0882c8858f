"""rattlesweep design: a printable rattleback with coin pockets.

One run of the command line (the default search, as a user would run it) makes the files
that most tests read: the STL, design.toml, sweep.toml, the placement sheet and the
reversal map. The chosen design is then checked with launches the search never made."""

import math
import re
import struct

import numpy as np
import pytest

from rattlesweep.cli import main

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("manifold3d")

from rattlesweep.design import (  # noqa: E402
    COINS,
    Coin,
    DesignRefused,
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
from design_helpers import SHELL, design_help, part_from, reversals  # noqa: E402


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

    help_text = " ".join(design_help().split())
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
