"""A refactoring guard: a fixed batch of 3-D and planar launches (every friction regime,
both methods, sliding launches, records) gives today's results: bit-identical when the
contact rolls or is frictionless, identical to rounding with Coulomb friction. The
reference was written by ``tests/data/make_reference.py`` from the code of an earlier
commit; a deliberate change of results rewrites it there, with the reason in the commit."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent / "data"))
import make_reference

REFERENCE = np.load(make_reference.PATH)


@pytest.fixture(scope="module")
def current():
    return make_reference.flatten(make_reference.runs())


def _cases():
    return sorted({key.split(":")[0] for key in REFERENCE.files})


@pytest.mark.parametrize("label", _cases())
def test_results_match_the_reference(current, label):
    keys = [k for k in REFERENCE.files if k.startswith(label + ":")]
    assert keys
    exact = label.endswith(("rolling", "frictionless"))
    for key in keys:
        assert key in current, f"{key} is no longer computed"
        want, got = REFERENCE[key], current[key]
        assert got.shape == want.shape, key
        if exact or not np.issubdtype(want.dtype, np.floating):
            np.testing.assert_array_equal(got, want, err_msg=key)
        else:
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12, err_msg=key)
