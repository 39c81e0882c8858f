"""The advice of a design that is not robust: it says what happened in words that fit
the numbers, and never asks for a heavier and a lighter coin at once."""

from types import SimpleNamespace

import numpy as np
import xarray as xr

from rattlesweep.design.api import _reverses, not_robust_report


def design_with(bad: np.ndarray, good: np.ndarray, com_height: float = 0.010):
    """A stand-in for a Design whose best placement's first reversal times (s, NaN: none)
    are ``bad`` and ``good`` over (spin, mu, tilt) = (3, 2, 2)."""
    times = xr.DataArray(
        np.stack([bad, good]),
        dims=("sense", "spin", "mu", "tilt"),
        coords={"sense": ["bad", "good"], "spin": [3.0, 5.0, 10.0], "mu": [0.2, 0.5]},
    )
    return SimpleNamespace(
        search=SimpleNamespace(best=SimpleNamespace(first_reversal_time=times)),
        launches=SimpleNamespace(t_end=15.0),
        prediction={
            "bad_sense": "ccw",
            "preferred_sense": "cw",
            "com_height": com_height,
            "com_height_limit": 0.020,
            "max_coin_mass": 0.01,
        },
        part=SimpleNamespace(y=0.005, b=0.02),
    )


def test_the_reversal_times_read_right_when_none_some_or_all_reverse():
    never = {
        "min": np.inf,
        "median": np.inf,
        "max": np.inf,
        "not_reversed": 12,
        "launches": 12,
    }
    assert _reverses(0.2, never, 15.0) == (
        "it does not reverse at mu = 0.2 within 15 s of spinning, in any of its 12 launches"
    )
    one = {"min": 2.0, "median": 4.0, "max": np.inf, "not_reversed": 1, "launches": 12}
    assert "but 1 of its 12 launches does not within 15 s" in _reverses(0.2, one, 15.0)
    all_ = {"min": 2.0, "median": 4.0, "max": 9.0, "not_reversed": 0, "launches": 12}
    assert _reverses(0.5, all_, 15.0) == (
        "it reverses at mu = 0.5 after 2-9 s (median 4 s) of spinning"
    )


def test_weak_and_strong_bias_at_once_is_not_mended_by_a_coin_mass():
    bad = np.full((3, 2, 2), 4.0)
    bad[0] = np.nan  # the slowest wrong-way flicks do not reverse
    good = np.full((3, 2, 2), np.nan)
    good[2, 0, 0] = 6.0  # a fast right-way one does
    advice = "\n".join(not_robust_report(design_with(bad, good)))
    assert "heavier" not in advice and "lighter" not in advice
    assert "no coin mass mends both" in advice


def test_one_sided_failures_get_one_sided_advice():
    bad = np.full((3, 2, 2), 4.0)
    bad[0] = np.nan
    weak = "\n".join(not_robust_report(design_with(bad, np.full((3, 2, 2), np.nan))))
    assert "a heavier coin" in weak and "lighter" not in weak
    strong_good = np.full((3, 2, 2), np.nan)
    strong_good[2] = 6.0
    strong = "\n".join(not_robust_report(design_with(np.full((3, 2, 2), 4.0), strong_good)))
    assert "a lighter coin (--coin-mass)" in strong and "heavier" not in strong
    assert "nearer the long axis" not in strong  # no option places the coins by hand
    high = "\n".join(not_robust_report(design_with(bad, np.full((3, 2, 2), np.nan), 0.019)))
    assert "lighter" not in high and "a lower shell" in high
