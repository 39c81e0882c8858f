"""Bodies: mass properties against direct quadrature, validation, derived properties,
value semantics."""

import copy
import math
import pickle

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import Body
from rattlesweep._launches import distinct_bodies
from rattlesweep._validation import as_float_array, fail_where, finite_vector, positive


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
    assert body.inertia[0, 1] == pytest.approx(
        (i1 - i2) * math.sin(delta) * math.cos(delta)
    )
    assert body.misalignment == pytest.approx(delta)
    np.testing.assert_allclose(
        np.linalg.eigvalsh(body.inertia), np.linalg.eigvalsh(plain.inertia), rtol=1e-12
    )


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
    assert pitch == pytest.approx(
        math.sqrt(m * g * (rx - ell) / (iyy + m * ell**2)), rel=1e-12
    )
    assert roll == pytest.approx(
        math.sqrt(m * g * (ry - ell) / (ixx + m * ell**2)), rel=1e-12
    )
    pitch0, roll0 = body.small_oscillation_frequencies(g, rolling=False)
    assert pitch0 == pytest.approx(math.sqrt(m * g * (rx - ell) / iyy), rel=1e-12)
    assert body.default_dt(g) == pytest.approx(2 * math.pi / max(pitch0, roll0) / 64)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(a=-1.0), "a must be a finite number > 0"),
        (dict(c=0.0), "c must be a finite number > 0"),
        (dict(mass=float("nan")), "mass must be"),
        (dict(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1.5]]), "symmetric"),
        (dict(inertia=np.diag([1.0, 1.0, -0.5])), "positive definite"),
        (dict(inertia=np.diag([1.0, 1.0, 3.0])), "triangle inequality"),
        (dict(com=(0.0, 0.0, 0.001)), "strictly inside"),
        (dict(com=(0.2, 0.0, -0.01)), "strictly inside"),
        (dict(b=0.01), "b\\*\\*2/c"),
    ],
)
def test_invalid_bodies_are_refused(kwargs, message):
    args = dict(
        a=0.1,
        b=0.03,
        c=0.02,
        mass=1.0,
        com=(0.0, 0.0, -0.0075),
        inertia=np.diag([1e-4, 2e-3, 2e-3]),
    )
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        Body(**args)


def test_a_radius_of_curvature_that_overflows_is_refused():
    """c so small against a that a**2/c overflows: the body was accepted, and its
    default step was NaN (found by the property tests)."""
    with pytest.raises(ValueError, match=r"a\*\*2/c overflows float64.*c = 5e-324"):
        Body.ellipsoid(966.0, 1.0, 5e-324, 1.0)


def test_scales_too_far_apart_for_float64_are_refused():
    """Radii of curvature that fit float64 but rocking frequencies that do not: the body
    was accepted with a NaN default step (found by the property tests)."""
    with pytest.raises(ValueError, match="too far apart in scale for float64"):
        Body.ellipsoid(486.0, 0.058, 1e-300, 3.4e165)
    kl = Body.preset("kane_levinson")
    with pytest.raises(
        ValueError,
        match=r"g = 1.7e\+308 m s-2 is too large for body "
        r"'kane_levinson'",
    ):
        kl.default_dt(1.7e308)


def test_semi_axes_too_far_apart_for_the_inertia_are_refused_by_name():
    """b = 2e9 m under a = 0.05 m: the misaligned inertia's smallest principal moment was
    lost in the rounding of its largest, and the body was refused as an inertia that is
    not positive definite, naming no parameter the caller gave (found by the long
    property-test run, through a sweep file with ``b`` fixed). The bound: the smallest
    moment above 1e-12 of the largest, semi-axes within about 1e6 of each other."""
    for make in (Body.semi_ellipsoid, Body.ellipsoid):
        with pytest.raises(
            ValueError,
            match=r"semi-axes a = 0.05, b = 2084882453.0, c = "
            r"0.01 m are too far apart in scale",
        ):
            make(0.05, 2084882453.0, 0.01, 1.0)
    with pytest.raises(ValueError, match=r"b = 2084882453.0.*too far apart"):
        Body.semi_ellipsoid(0.05, 2084882453.0, 0.01, 1.0, 0.02)
    # a flat, long body well inside the bound is still a body
    flat = Body.semi_ellipsoid(1.0, 1e-4, 1e-5, 1.0)
    assert np.linalg.eigvalsh(flat.inertia)[0] > 0.0
    with pytest.raises(ValueError, match=r"b = 2084882453.0.*too far apart"):
        rs.Sweep(
            axes={"spin": {"start": 0.0, "stop": 0.0, "num": 1}},
            fixed={"b": 2084882453.0, "t_end": 0.015625},
        )


@pytest.mark.parametrize("delta", ["abc", None, [0.1], math.nan, math.inf])
def test_semi_ellipsoid_refuses_a_misalignment_that_is_no_number(delta):
    # a string raised math.isfinite's TypeError (found by the property tests)
    with pytest.raises(ValueError, match="delta must be a finite number"):
        Body.semi_ellipsoid(0.05, 0.01, 0.01, 0.02, delta)


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


# --- value semantics ------------------------------------------------------------------

_BASE = dict(
    a=0.1,
    b=0.03,
    c=0.02,
    mass=1.0,
    com=(0.0, 0.0, -0.0075),
    inertia=np.diag([1e-4, 2e-3, 2e-3]),
)


def _body(**changes):
    return Body(**{**_BASE, **changes})


def test_equal_parameters_make_equal_bodies_whatever_the_name():
    one, two = _body(name="one"), _body(name="two")
    assert one is not two
    assert one == two and not one != two
    assert hash(one) == hash(two)
    assert Body.preset("toy") == Body.preset("toy")
    assert hash(Body.preset("toy")) == hash(Body.preset("toy"))
    # the containers the parameters came in do not matter, only their values
    same = _body(
        com=np.array([0.0, 0.0, -0.0075]), inertia=np.diag([1e-4, 2e-3, 2e-3]).tolist()
    )
    assert same == one and hash(same) == hash(one)


@pytest.mark.parametrize(
    "changes",
    [
        dict(a=0.11),
        dict(b=0.031),
        dict(c=0.021),
        dict(mass=1.1),
        dict(com=(0.001, 0.0, -0.0075)),
        dict(com=(0.0, 0.001, -0.0075)),
        dict(com=(0.0, 0.0, -0.008)),
        dict(inertia=np.diag([1.1e-4, 2e-3, 2e-3])),
        dict(inertia=np.diag([1e-4, 2.1e-3, 2e-3])),
        dict(inertia=np.diag([1e-4, 2e-3, 2.1e-3])),
        dict(inertia=np.array([[1e-4, 1e-5, 0], [1e-5, 2e-3, 0], [0, 0, 2e-3]])),
        dict(inertia=np.array([[1e-4, 0, 1e-5], [0, 2e-3, 0], [1e-5, 0, 2e-3]])),
        dict(inertia=np.array([[1e-4, 0, 0], [0, 2e-3, 1e-5], [0, 1e-5, 2e-3]])),
        dict(full_ellipsoid=True),
    ],
)
def test_any_parameter_change_makes_a_different_body(changes):
    base, other = _body(), _body(**changes)
    assert base != other and not base == other
    assert len({base, other}) == 2


def test_a_one_ulp_change_makes_a_different_body():
    inertia = np.diag([1e-4, 2e-3, 2e-3])
    inertia[2, 2] = np.nextafter(inertia[2, 2], 1.0)
    assert _body(inertia=inertia) != _body()
    assert _body(mass=np.nextafter(1.0, 2.0)) != _body()


def test_bodies_work_as_dict_keys_and_set_members():
    toy, golden = Body.preset("toy"), Body.preset("golden")
    table = {toy: "toy", golden: "golden"}
    assert table[Body.preset("toy")] == "toy" and table[Body.preset("golden")] == "golden"
    assert _body() not in table
    assert len({toy, Body.preset("toy"), golden, _body(), _body(name="x")}) == 3
    assert toy != "toy" and toy != toy.describe()


def test_bodies_stay_read_only_and_equal_through_copies_and_pickles():
    toy = Body.preset("toy")
    hash(toy)  # caches the key before the copies
    for clone in (copy.copy(toy), copy.deepcopy(toy), pickle.loads(pickle.dumps(toy))):
        assert clone == toy and hash(clone) == hash(toy) and clone.name == "toy"
        with pytest.raises(ValueError):
            clone.inertia[0, 0] = 1.0
        with pytest.raises(ValueError):
            clone.com[0] = 1.0


def test_body_does_not_keep_or_freeze_the_callers_com_array():
    com = np.array([0.0, 0.0, -0.0075])
    body = _body(com=com)
    com[2] = -0.01  # the caller's array stays writable and the body does not see this
    assert body.com[2] == -0.0075 and body == _body()


def test_distinct_bodies_merges_equal_values_and_keeps_names_apart():
    toy, golden = Body.preset("toy"), Body.preset("golden")
    toy_again = Body.preset("toy")  # another object, same values and name
    renamed = Body.semi_ellipsoid(
        toy.a, toy.b, toy.c, toy.mass, math.radians(5.0), name="mine"
    )
    assert renamed == toy
    items = [toy_again, golden, toy, renamed, golden, renamed]
    for bodies in (items, np.array(items, dtype=object)):
        table, index = distinct_bodies(bodies)
        assert len(table) == 3
        assert table[0] is toy_again and table[1] is golden and table[2] is renamed
        assert index.tolist() == [0, 1, 0, 2, 1, 2]
        assert [table[i].name for i in index] == [b.name for b in items]


def test_batch_names_follow_the_bodies_when_values_are_equal():
    toy = Body.preset("toy")
    renamed = Body.semi_ellipsoid(
        toy.a, toy.b, toy.c, toy.mass, math.radians(5.0), name="mine"
    )
    bodies = np.array([toy, renamed, Body.preset("toy")], dtype=object)
    ds = rs.run_batch(bodies, spin=3.0, roll=0.01, t_end=0.05)
    assert list(ds.body_name.values) == ["toy", "mine", "toy"]
    for name in ("final_spin", "max_tilt", "energy_final", "steps"):
        assert ds[name].values[0] == ds[name].values[1] == ds[name].values[2]


@pytest.mark.parametrize(
    "body",
    [
        Body.preset("toy"),
        Body.preset("kane_levinson"),
        Body.ellipsoid(0.05, 0.05, 0.05, 1.0),
    ],
)
def test_default_dt_is_the_uncached_formula_bit_for_bit(body):
    for g in (9.81, 1.62, 9.81):
        w = max(
            *body.small_oscillation_frequencies(g, rolling=True),
            *body.small_oscillation_frequencies(g, rolling=False),
        )
        w = w if w > 0.0 else math.sqrt(g / body.c)
        assert body.default_dt(g) == 2.0 * math.pi / w / 64.0
    assert body.default_dt(10) == body.default_dt(10.0)
    assert copy.deepcopy(body).default_dt() == body.default_dt()


@pytest.mark.parametrize("g", [0.0, -9.81, math.nan, math.inf, "earth", None])
def test_default_dt_refuses_a_bad_g(g):
    with pytest.raises(ValueError, match=r"g must be a finite number > 0, got "):
        Body.preset("toy").default_dt(g)


# --- validation -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "value",
    [0, 0.0, -1.0, math.nan, math.inf, -math.inf, "x", None, [1.0, 2.0], 1j, 10**400],
)
def test_positive_refuses_with_name_value_and_rule(value):
    with pytest.raises(ValueError) as info:
        positive("mass", value)
    assert str(info.value) == f"mass must be a finite number > 0, got {value!r}"


def test_positive_returns_a_float():
    for value in (2, 2.0, np.float32(2.0), np.int64(2), np.array(2.0)):
        v = positive("a", value)
        assert v == 2.0 and type(v) is float
    for value in ("2", True, 2 + 0j):  # real numbers only, as in the TOML file
        with pytest.raises(ValueError, match="a must be a finite number > 0"):
            positive("a", value)
    assert positive("a", 5e-324) == 5e-324


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(a="wide"), "a must be a finite number > 0, got 'wide'"),
        (dict(mass=None), "mass must be a finite number > 0, got None"),
        (
            dict(com="low"),
            r"com must be a number or an array of numbers \(real numbers: not "
            r"booleans, strings or complex numbers\), got 'low'",
        ),
        (dict(com=(0.0, -0.0075)), r"com must have shape \(3,\), got \(2,\)"),
        (
            dict(com=(0.0, math.nan, -0.0075)),
            r"com must be finite, got \[0.0, nan, -0.0075\]",
        ),
        (
            dict(inertia=[[1, 0], [0, 1, 2]]),
            "inertia must be a number or an array of numbers",
        ),
    ],
)
def test_non_numbers_are_refused_with_the_parameter_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        _body(**kwargs)


def test_point_masses_are_validated():
    base = _body()
    with pytest.raises(
        ValueError, match=r"masses\[1\] mass must be a finite number > 0, got -0.1"
    ):
        base.with_point_masses([(0.1, (0, 0, -0.005)), (-0.1, (0, 0, -0.005))])
    with pytest.raises(ValueError, match=r"masses\[0\] position must have shape \(3,\)"):
        base.with_point_masses([(0.1, (0, -0.005))])
    with pytest.raises(ValueError, match=r"masses\[0\] position must be a number"):
        base.with_point_masses([(0.1, "here")])


def test_finite_vector():
    given = np.array([1.0, 2.0, 3.0])
    out = finite_vector("v", given, 3)
    np.testing.assert_array_equal(out, given)
    assert out is not given and out.dtype == float
    assert finite_vector("v", [1, 2], 2).tolist() == [1.0, 2.0]
    with pytest.raises(ValueError, match=r"^v must have shape \(2,\), got \(3,\)$"):
        finite_vector("v", given, 2)
    with pytest.raises(ValueError, match=r"^v must be finite, got \[1.0, inf\]$"):
        finite_vector("v", [1.0, math.inf], 2)


def test_as_float_array():
    assert (
        as_float_array("spin", 3).shape == () and as_float_array("spin", 3).dtype == float
    )
    given = np.array([1.0, 2.0])
    assert as_float_array("spin", given) is given
    assert np.isnan(
        as_float_array("spin", None)
    )  # as numpy converts it: caught as non-finite
    for bad in ("fast", [1.0, [2.0, 3.0]], {"x": 1}, 1j):
        with pytest.raises(ValueError) as info:
            as_float_array("spin", bad)
        assert str(info.value) == (
            "spin must be a number or an array of numbers (real "
            "numbers: not booleans, strings or complex numbers), "
            f"got {bad!r}"
        )


def test_fail_where():
    arr = np.array([[1.0, 2.0], [-3.0, -4.0]])
    fail_where("dt", arr, arr > 5.0, "must be <= 5")  # nothing bad: no error
    with pytest.raises(ValueError) as info:
        fail_where("dt", arr, arr < 0.0, "must be finite and > 0")
    assert str(info.value) == "dt must be finite and > 0; got -3.0 at index (1, 0)"
    scalar = np.asarray(-1.0)
    with pytest.raises(ValueError) as info:
        fail_where("g", scalar, scalar <= 0.0, "must be finite and > 0")
    # a plain float's repr, not numpy's np.float64(-1.0)
    assert str(info.value) == "g must be finite and > 0; got -1.0"
