"""Sphinx configuration of the rattlesweep documentation.

Build (from the repository root, with the ``docs`` extra installed)::

    .venv/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

The notebooks are rendered from ``notebooks/`` with the outputs stored in them (a
full-size run by ``notebooks/store_outputs.py``), without executing them: the build stays
fast, and the test suite executes every notebook anyway; the pages of
generated content (API stubs, the command-line help, the table of sweep parameters) are
written under ``docs/generated/`` at the start of each build.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import rattlesweep

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import generate  # noqa: E402  (docs/generate.py, next to this file)

project = "rattlesweep"
author = "the rattlesweep developers"
copyright = "2025, the rattlesweep developers"
release = rattlesweep.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "gallery/*.md", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# --- API reference ----------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "none"  # numpydoc renders the types from the docstrings
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# --- notebooks --------------------------------------------------------------------------
nb_execution_mode = "off"  # rendered with their stored outputs: the suite executes them
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

# --- HTML -------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"rattlesweep {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navbar_end": ["navbar-icon-links"],
    "secondary_sidebar_items": ["page-toc"],
    "show_toc_level": 2,
}
html_show_sourcelink = False


def _copy_notebooks() -> None:
    target = HERE / "generated" / "notebooks"
    target.mkdir(parents=True, exist_ok=True)
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        shutil.copyfile(nb, target / nb.name)


def setup(app):
    # autosummary writes a stub per documented name and never removes one: a stub of a
    # name that moved would be an orphan page, which -W turns into an error
    shutil.rmtree(HERE / "generated" / "api", ignore_errors=True)
    generate.write_all(HERE / "generated")
    _copy_notebooks()
