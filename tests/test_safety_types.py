"""One rule for the API and the TOML file: numeric inputs take real numbers only (Python
or NumPy ints and floats, arrays of them); booleans are taken only where a boolean is
meant, and only as booleans."""

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep.sweep import Sweep

TOY = rs.Body.preset("toy")
KL = dict(
    a=0.2,
    b=0.03,
    c=0.02,
    mass=1.0,
    com=(0.0, 0.0, -0.01),
    inertia=np.diag([1e-4, 2e-3, 2e-3]),
)
REAL = (
    r"must be a number or an array of numbers \(real numbers: not booleans, strings "
    r"or complex numbers\)"
)


@pytest.mark.parametrize(
    "name, value",
    [
        ("spin", np.array([1 + 1j, 2.0])),
        ("spin", 2 + 0j),
        ("spin", np.complex128(2)),
        ("spin", True),
        ("spin", np.bool_(True)),
        ("spin", np.array([True, False])),
        ("spin", "5"),
        ("spin", np.array(["5"])),
        ("mu", [0.3, True]),
        ("mu", [0.3, "0.4"]),
        ("t_end", "1"),
        ("damping", False),
        ("roll", [[0.1], [0.2, 0.3]]),
    ],
)
def test_run_batch_refuses_what_is_not_a_real_number(name, value):
    kwargs = {"t_end": 0.01, name: value}
    with pytest.raises(ValueError, match=rf"^{name} {REAL}, got "):
        rs.run_batch(TOY, **kwargs)


@pytest.mark.parametrize(
    "name, value",
    [
        ("roll_deg", np.timedelta64(1, "s")),
        ("spin", np.timedelta64(5, "ms")),
        ("spin", np.array([1, 2], dtype="timedelta64[s]")),
        ("spin", np.datetime64("2020-01-01")),
        ("mu", [0.3, np.timedelta64(1, "s")]),
    ],
)
def test_run_batch_refuses_times_and_dates(name, value):
    # timedelta64 is an integer type to NumPy: it ran as its count of units
    kwargs = {"t_end": 0.01, name: value}
    with pytest.raises(ValueError, match=rf"^{name} {REAL}[;,] "):
        rs.run_batch(TOY, **kwargs)


def test_run_batch_refuses_a_time_for_a_scalar_parameter():
    with pytest.raises(ValueError, match=rf"^t_end {REAL}; a time or a date"):
        rs.run_batch(TOY, spin=5.0, t_end=np.timedelta64(1, "s"))


@pytest.mark.parametrize(
    "value",
    [
        np.ma.masked_array([1.0, 2.0], mask=[0, 1]),
        np.ma.masked_array([1.0, 2.0], mask=[0, 0]),
        [1.0, np.ma.masked],
    ],
)
def test_run_batch_refuses_masked_arrays(value):
    # the masked entry was simulated all the same
    with pytest.raises(ValueError, match=r"^spin (must be a plain array|" + REAL + ")"):
        rs.run_batch(TOY, spin=value, t_end=0.01)


@pytest.mark.parametrize(
    "value",
    [
        np.float32(2.5),
        np.float64(2.5),
        np.int64(2),
        np.array(2.5),
        np.array([1, 2]),
        [1.0, np.float32(2)],
        np.arange(3, dtype=np.int32),
    ],
)
def test_run_batch_takes_numpy_scalars_0d_arrays_and_integer_arrays(value):
    ds = rs.run_batch(TOY, spin=value, t_end=0.01)
    assert np.array_equal(ds.launch_spin.values, np.ravel(np.asarray(value, dtype=float)))


@pytest.mark.parametrize("flag", ["false", "true", 0, 1, None, np.array(False)])
def test_full_ellipsoid_takes_booleans_only(flag):
    with pytest.raises(
        ValueError,
        match=rf"full_ellipsoid must be a boolean \(true or "
        rf"false\), got {re_escape(flag)}",
    ):
        rs.Body(**KL, full_ellipsoid=flag)
    assert rs.Body(**KL, full_ellipsoid=np.bool_(False)).full_ellipsoid is False


def re_escape(value):
    import re

    return re.escape(repr(value))


def test_toml_body_table_full_ellipsoid_string_refused():
    text = """
        [axes]
        spin = [1.0]
        [fixed]
        t_end = 1.0
        body = { a = 0.2, b = 0.03, c = 0.02, mass = 1.0, com = [0.0, 0.0, -0.01], inertia = [[1e-4, 0, 0], [0, 2e-3, 0], [0, 0, 2e-3]], full_ellipsoid = "false" }
    """  # noqa: E501 (a TOML inline table is one line)
    with pytest.raises(ValueError, match=r"full_ellipsoid must be a boolean.*'false'"):
        Sweep.from_toml(text)


@pytest.mark.parametrize("value", [True, "3", 1 + 0j, "1e-2"])
def test_body_dimensions_and_sweep_values_refuse_the_same(value):
    with pytest.raises(ValueError, match=r"a must be a finite number > 0"):
        rs.Body(**{**KL, "a": value})
    with pytest.raises(ValueError, match=r"fixed\.mu: must be a number"):
        Sweep(axes={"spin": [1.0]}, fixed={"t_end": 1.0, "mu": value})
    with pytest.raises(ValueError, match=r"axes\.spin: values must be numbers"):
        Sweep(axes={"spin": [1.0, value]}, fixed={"t_end": 1.0})


@pytest.mark.parametrize(
    "name, value",
    [
        ("parallel", "false"),
        ("parallel", 0),
        ("threads", True),
        ("reversal_band", "0.1"),
        ("reversal_band", True),
    ],
)
def test_run_batch_options_take_their_own_types(name, value):
    with pytest.raises(ValueError, match=rf"{name} must be"):
        rs.run_batch(TOY, spin=1.0, t_end=0.01, **{name: value})


def test_array_likes_of_numbers_are_taken_and_a_missing_value_is_a_non_finite_launch():
    """A pandas Series, a nullable Float64 array and a result's own DataArray are what
    NumPy takes as numbers: taken (a regression of the types round refused them), with
    pandas' NA a non_finite launch; a Series of booleans or strings is still refused."""
    pd = pytest.importorskip("pandas")
    for value in (
        pd.Series([-3.0, 3.0]),
        rs.run_batch(TOY, spin=[-3.0, 3.0], t_end=0.01).launch_spin,
    ):
        ds = rs.run_batch(TOY, spin=value, t_end=0.01)
        np.testing.assert_array_equal(ds.launch_spin.values, [-3.0, 3.0])
    ds = rs.run_batch(TOY, spin=pd.array([-3.0, None], dtype="Float64"), t_end=0.01)
    assert list(rs.decode(ds).status.values) == ["ok", "non_finite"]
    for bad in (pd.Series([True, False]), pd.Series(["1", "2"])):
        with pytest.raises(
            ValueError, match="spin must be a number or an array of numbers"
        ):
            rs.run_batch(TOY, spin=bad, t_end=0.01)
