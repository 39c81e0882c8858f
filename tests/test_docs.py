"""The documentation site builds without a warning (``sphinx-build -W``): every
docstring in the API reference parses, every cross-reference resolves, and the notebooks
render with the outputs stored in them (without being executed: tests/test_notebooks.py
executes them).

Needs the ``docs`` extra, which CI (.ci/run) installs; skipped without it."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")
pytest.importorskip("pydata_sphinx_theme")
pytest.importorskip("numpydoc")
pytest.importorskip("myst_nb")

DOCS = Path(__file__).resolve().parent.parent / "docs"


def test_docs_build_without_warnings(tmp_path):
    out = tmp_path / "html"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-W",
            "--keep-going",
            "-q",
            "-b",
            "html",
            "-d",
            str(tmp_path / "doctrees"),
            str(DOCS),
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout[-5000:] + result.stderr[-5000:]
    for page in (
        "index",
        "tutorial",
        "model",
        "api",
        "cli",
        "toml",
        "gallery",
        "notebooks",
        "guide/simulate",
        "guide/sweeps",
        "guide/benchmarks",
        "generated/api/rattlesweep.run_batch",
        "generated/notebooks/02_rattleback_reversal",
        # the public exceptions and warnings, documented where users import them from
        "generated/api/rattlesweep.CoarseStepWarning",
        "generated/api/rattlesweep.SweepWriteError",
        "generated/api/rattlesweep.DesignRefused",
    ):
        assert (out / f"{page}.html").is_file(), page
    design = (out / "guide/design.html").read_text()
    assert "../generated/api/rattlesweep.DesignRefused.html" in design
    api = (out / "generated/api/rattlesweep.run_batch.html").read_text()
    assert "mu_static" in api and "Returns" in api
    # the tables of inputs, from their descriptions: the default step's damping bound too
    for page in ("toml", "guide/results"):
        html = (out / f"{page}.html").read_text()
        assert "smallest principal moment of inertia" in html, page
    assert "launch_angle" in (out / "guide/results.html").read_text()
    cli = (out / "cli.html").read_text()
    assert "rattlesweep sweep" in cli and "--scheduler" in cli
    assert (out / "_images").is_dir() and any((out / "_images").glob("reversal_map*.png"))
    # the notebooks are shown with their stored outputs: text and pictures
    for page in sorted((out / "generated/notebooks").glob("0*.html")):
        html = page.read_text()
        assert "rattlesweep 0" in html and "size: full" in html, page.name
        assert "<img" in html, page.name
    shutil.rmtree(tmp_path, ignore_errors=True)
