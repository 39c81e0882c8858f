import math

import pytest

import rattlesweep as rs


@pytest.fixture(scope="session")
def kl():
    return rs.Body.preset("kane_levinson")


HALF_DEGREE = math.radians(0.5)
