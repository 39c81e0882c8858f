"""Bodies: mass properties against direct quadrature, validation, derived properties."""

import math

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import Body


def _grid_mass_properties(a, b, c, n=120):
    """Centroid and inertia (about the centroid, unit density) of the semi-ellipsoid by a
    midpoint-rule sum over a grid: independent of the closed forms in Body."""
    xs = (np.arange(n) + 0.5) / n * 2 - 1
    zs = -(np.arange(n) + 0.5) / n
    X, Y, Z = np.meshgrid(xs * a, xs * b, zs * c, indexing="ij")
    inside = (X / a) ** 2 + (Y / b) ** 2 + (Z / c) ** 2 <= 1
    dv = (2 * a / n) * (2 * b / n) * (c / n)
    m = inside.sum() * dv
    r = np.stack([X[inside], Y[inside], Z[inside]])
    g = r.mean(axis=1)
    d = r - g[:, None]
    inertia = (np.eye(3) * (d**2).sum() - d @ d.T) * dv
    return m, g, inertia


def test_semi_ellipsoid_matches_quadrature():
    a, b, c = 0.05, 0.02, 0.015
    m, g, inertia = _grid_mass_properties(a, b, c)
    body = Body.semi_ellipsoid(a, b, c, mass=m)
    assert m == pytest.approx(2 / 3 * math.pi * a * b * c, rel=2e-3)
    np.testing.assert_allclose(body.com, g, atol=2e-3 * c)
    np.testing.assert_allclose(body.inertia, inertia, rtol=0, atol=5e-3 * inertia.max())


def test_misalignment_rotates_the_principal_axes():
    delta = math.radians(7.0)
    body = Body.semi_ellipsoid(0.1, 0.03, 0.02, 1.0, delta)
    plain = Body.semi_ellipsoid(0.1, 0.03, 0.02, 1.0)
    i1, i2 = plain.inertia[0, 0], plain.inertia[1, 1]
    assert body.inertia[0, 1] == pytest.approx((i1 - i2) * math.sin(delta) * math.cos(delta))
    assert body.misalignment == pytest.approx(delta)
    np.testing.assert_allclose(np.linalg.eigvalsh(body.inertia),
                               np.linalg.eigvalsh(plain.inertia), rtol=1e-12)


def test_point_masses_follow_parallel_axis_rule():
    base = Body.semi_ellipsoid(0.1, 0.03, 0.02, 1.0)
    d, mp = 0.05, 0.1
    zg = base.com[2]
    body = base.with_point_masses([(mp, (d, 0, zg)), (mp, (-d, 0, zg))])
    assert body.mass == pytest.approx(1.2)
    np.testing.assert_allclose(body.com, base.com, atol=1e-15)
    expected = base.inertia + np.diag([0.0, 2 * mp * d * d, 2 * mp * d * d])
    np.testing.assert_allclose(body.inertia, expected, rtol=1e-12, atol=1e-15)


def test_presets_are_valid_and_documented():
    for name, (_, description) in rs.PRESETS.items():
        body = Body.preset(name)
        assert body.name == name and description
        assert body.com_height > 0
    kl = Body.preset("kane_levinson")
    assert kl.inertia[0, 1] == pytest.approx(0.2e-4)
    assert kl.com_height == pytest.approx(0.01)
    assert kl.radii_of_curvature == pytest.approx((2.0, 0.045))
    with pytest.raises(ValueError, match="unknown.*golden"):
        Body.preset("nope")


def test_zero_spin_frequencies_match_closed_forms():
    body = Body.semi_ellipsoid(0.08, 0.02, 0.015, 0.3)  # I_xy = 0
    g, m, ell = 9.81, body.mass, body.com_height
    rx, ry = body.radii_of_curvature
    ixx, iyy = body.inertia[0, 0], body.inertia[1, 1]
    pitch, roll = body.small_oscillation_frequencies(g)
    assert pitch == pytest.approx(math.sqrt(m * g * (rx - ell) / (iyy + m * ell**2)), rel=1e-12)
    assert roll == pytest.approx(math.sqrt(m * g * (ry - ell) / (ixx + m * ell**2)), rel=1e-12)
    pitch0, roll0 = body.small_oscillation_frequencies(g, rolling=False)
    assert pitch0 == pytest.approx(math.sqrt(m * g * (rx - ell) / iyy), rel=1e-12)
    assert body.default_dt(g) == pytest.approx(2 * math.pi / max(pitch0, roll0) / 64)


@pytest.mark.parametrize("kwargs, message", [
    (dict(a=-1.0), "a must be a finite number > 0"),
    (dict(c=0.0), "c must be a finite number > 0"),
    (dict(mass=float("nan")), "mass must be"),
    (dict(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1.5]]), "symmetric"),
    (dict(inertia=np.diag([1.0, 1.0, -0.5])), "positive definite"),
    (dict(inertia=np.diag([1.0, 1.0, 3.0])), "triangle inequality"),
    (dict(com=(0.0, 0.0, 0.001)), "strictly inside"),
    (dict(com=(0.2, 0.0, -0.01)), "strictly inside"),
    (dict(b=0.01), "b\\*\\*2/c"),
])
def test_invalid_bodies_are_refused(kwargs, message):
    args = dict(a=0.1, b=0.03, c=0.02, mass=1.0, com=(0.0, 0.0, -0.0075),
                inertia=np.diag([1e-4, 2e-3, 2e-3]))
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        Body(**args)


def test_neutral_sphere_is_allowed():
    sphere = Body.ellipsoid(0.05, 0.05, 0.05, 1.0)
    assert sphere.com_height == pytest.approx(0.05)
    assert sphere.small_oscillation_frequencies() == (0.0, 0.0)
    assert sphere.default_dt() == pytest.approx(2 * math.pi * math.sqrt(0.05 / 9.81) / 64)


def test_body_is_immutable():
    body = Body.preset("toy")
    with pytest.raises(Exception):
        body.a = 1.0
    with pytest.raises(ValueError):
        body.inertia[0, 0] = 1.0
