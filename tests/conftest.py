import math
import os
import tomllib
from pathlib import Path

import pytest

import rattlesweep as rs
from rattlesweep._core import jit

# the tests' own kernels (test_kernel_design.py) inline the package's, but numba keys
# their cache on the test file alone: they go with any change of the package's kernels
# (and of any test file, which costs their compile only)
jit.drop_stale_cache(Path(__file__).parent, depends_on=(Path(jit.__file__).parent,))

try:
    from hypothesis import HealthCheck, Phase, settings
except ImportError:  # the property tests skip themselves without hypothesis
    settings = None

if settings is not None:
    # Examples per property: "ci" keeps the default run short (the property tests add
    # about 40 s on 2 cores); "long" is the thorough run, e.g.
    # HYPOTHESIS_PROFILE=long .venv/bin/python -m pytest tests/test_properties*.py
    _common = dict(
        deadline=None,
        print_blob=True,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
            HealthCheck.filter_too_much,
        ],
    )
    # the same examples every run, so that CI is reproducible; the other profiles draw
    # new ones
    settings.register_profile(
        "ci", max_examples=100, derandomize=True, database=None, **_common
    )
    settings.register_profile("long", max_examples=2000, **_common)
    # "explore": many examples, no shrinking, to find failures fast while working
    settings.register_profile(
        "explore",
        max_examples=300,
        phases=[Phase.explicit, Phase.reuse, Phase.generate],
        **_common,
    )
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def kl():
    return rs.Body.preset("kane_levinson")


HALF_DEGREE = math.radians(0.5)


@pytest.fixture(scope="session")
def made(tmp_path_factory):
    """One run of ``rattlesweep design`` on the example shell, as a user would run it:
    the output directory and its design.toml (shared by test_design.py and
    test_design_trial.py)."""
    pytest.importorskip("trimesh")
    pytest.importorskip("manifold3d")
    from design_helpers import SHELL
    from rattlesweep.cli import main

    out = tmp_path_factory.mktemp("design")
    a, b, c = SHELL
    status = main(
        ["design", "--a", str(a), "--b", str(b), "--c", str(c), "--out", str(out)]
    )
    assert status == 0
    with open(out / "design.toml", "rb") as f:
        doc = tomllib.load(f)
    return out, doc
