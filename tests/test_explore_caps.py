"""The explorer's caps hold for every point of a map, not only the settings' own run:
a map whose far corner needs more steps than the cap is refused before any work."""

import pytest

from rattlesweep.explore.caps import CapExceeded, Caps
from rattlesweep.explore.settings import defaults, map_sweep


def test_a_map_whose_corner_takes_too_many_steps_is_refused_before_any_work():
    settings = {**defaults(), "t_end": 10.0}  # its own run: damping 0, 36 304 steps
    axes = {
        "x": {"param": "damping", "start": 0, "stop": 1e3, "num": 5},
        "y": {"param": "spin", "start": -5, "stop": 5, "num": 5},
    }
    with pytest.raises(CapExceeded) as refused:
        map_sweep(settings, axes, Caps())
    assert "time steps of a map point" in str(refused.value)
    assert "exceeds the explorer's cap max_steps = 200000" in str(refused.value)
    axes["x"]["stop"] = 1e-3  # a damping the step size does not follow
    assert map_sweep(settings, axes, Caps()).max_steps <= Caps().max_steps


@pytest.mark.parametrize("key", ["num", "levels"])
def test_a_fractional_count_is_refused_not_truncated(key):
    axes = {
        "x": {"param": "spin", "start": -5, "stop": 5, "num": 5},
        "y": {"param": "mu", "start": 0.2, "stop": 0.5, "num": 3},
        "levels": 1,
    }
    if key == "num":
        axes["x"]["num"] = 2.5
    else:
        axes["levels"] = 1.5
    with pytest.raises(ValueError, match=r"must be a whole number, got (2\.5|1\.5)"):
        map_sweep({**defaults(), "t_end": 2.0}, axes, Caps())
