"""rattlesweep design: what a new user's trial found (issue 33, second round): a
directory that holds files, overwriting, failed writes, a design that is not robust,
progress, unit mistakes, and the design files read back by the other commands."""

import math
import os
import re
import tomllib

import pytest

from rattlesweep.cli import main

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("manifold3d")

from rattlesweep.design import (  # noqa: E402
    COINS,
    DesignRefused,
    Launches,
    design,
    load_body,
)
from design_helpers import SHELL, design_help, part_from  # noqa: E402


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


def test_progress_is_shown(not_robust):
    _, _, _, stderr = not_robust
    for line in (
        "searching 24 placements x 72 launches...",
        "refining (level 1 of 2)",
        "reversal map: 41 spins x 9 friction values...",
        "writing files into",
    ):
        assert line in stderr
    said = []
    design(*SHELL, progress=said.append, **CHEAP)
    assert re.fullmatch(r"searching \d+ placements x 4 launches\.\.\.", said[0])


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
    from rattlesweep.design import make_coin

    assert make_coin("EUR_1") == COINS["eur_1"]
    assert make_coin("washer_m10") == COINS["washer_M10"]
    help_text = " ".join(design_help().split())
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
