"""Property-based tests of the type rule shared by the API and the TOML layer: a value
given as any real NumPy or Python type (float32, ints, NumPy scalars, 0-d arrays) runs as
its float64 value; the same value as a bool, a complex number, a string, or an array of
those, is refused naming the parameter, by run_batch, by Body and by Sweep alike."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rattlesweep as rs
from rattlesweep.sweep import Sweep
from strategies import finite

TOY = rs.Body.preset("toy")
VALID = {
    "spin": finite(-30, 30),
    "mu": finite(0.05, 1.0),
    "damping": finite(0, 1e-4),
    "g": finite(5.0, 15.0),
    "roll": finite(-0.1, 0.1),
}
KL = dict(
    a=0.2,
    b=0.03,
    c=0.02,
    mass=1.0,
    com=(0.0, 0.0, -0.01),
    inertia=np.diag([1e-4, 2e-3, 2e-3]),
)


def real_forms(x: float) -> st.SearchStrategy:
    """``x`` as a Python float, a NumPy float64 or float32, a 0-d array of either, or an
    int type when it is integral."""
    forms = [x, np.float64(x), np.float32(x), np.array(x), np.array(x, dtype=np.float32)]
    if float(x).is_integer():
        forms += [int(x), np.int64(x), np.int32(x), np.array(int(x))]
    return st.sampled_from(forms)


def bad_forms(x: float) -> st.SearchStrategy:
    """``x`` as what is not a real number: bools, complex numbers, strings, and arrays
    or lists holding one of them."""
    return st.sampled_from(
        [
            bool(x),
            np.bool_(x),
            complex(x, 0.0),
            complex(x, 1.0),
            np.complex128(x),
            np.complex64(x),
            np.array(x, dtype=complex),
            np.array([x, x], dtype=complex),
            str(x),
            np.str_(str(x)),
            np.array(str(x)),
            np.array([True, False]),
            [x, True],
            [x, str(x)],
            np.array([x, "1"], dtype=object),
            [complex(x, 0.0)],
        ]
    )


@given(data=st.data(), name=st.sampled_from(sorted(VALID)))
def test_real_types_run_as_their_float64_value(data, name):
    x = data.draw(VALID[name], label="value")
    value = data.draw(real_forms(x), label="form")
    as_float = float(np.asarray(value, dtype=float))
    ds = rs.run_batch(TOY, t_end=0.005, **{"spin": 3.0, name: value})
    ref = rs.run_batch(TOY, t_end=0.005, **{"spin": 3.0, name: as_float})
    for var in ("final_spin", "status", "steps"):
        np.testing.assert_array_equal(ds[var].values, ref[var].values)


@given(data=st.data(), name=st.sampled_from(sorted(VALID)))
def test_non_real_types_are_refused_by_name_everywhere(data, name):
    x = data.draw(VALID[name], label="value")
    value = data.draw(bad_forms(x), label="form")
    with pytest.raises(
        ValueError,
        match=rf"^{name} must be a number or an array of "
        r"numbers \(real numbers",
    ):
        rs.run_batch(TOY, t_end=0.005, **{"spin": 3.0, name: value})
    if np.ndim(value) == 0:
        with pytest.raises(ValueError, match=rf"fixed\.{name}: must be a number"):
            Sweep(
                axes={"spin" if name != "spin" else "mu": [1.0]},
                fixed={"t_end": 0.01, name: value},
            )
        with pytest.raises(ValueError, match=r"^a must be a finite number > 0"):
            rs.Body(**{**KL, "a": value})


@given(data=st.data(), name=st.sampled_from(["mu", "damping", "g"]))
def test_sweep_takes_the_real_forms_run_batch_takes(data, name):
    x = data.draw(VALID[name], label="value")
    value = data.draw(real_forms(x), label="form")
    s = Sweep(axes={"spin": [1.0]}, fixed={"t_end": 0.01, name: value})
    assert s.fixed[name] == float(np.asarray(value, dtype=float))
    assert math.isfinite(s.fixed[name])
