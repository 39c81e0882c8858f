"""Numerical settings that used to pass without a word: a dt longer than t_end, and a
run of billions of steps."""

import warnings

import numpy as np
import pytest

import rattlesweep as rs
from rattlesweep import LongRunWarning

TOY = rs.Body.preset("toy")


def test_dt_longer_than_t_end_is_refused():
    with pytest.raises(ValueError, match=r"dt must be at most t_end .* got .*0\.1"):
        rs.run_batch(TOY, spin=5.0, t_end=0.01, dt=0.1)
    ok = rs.run_batch(TOY, spin=5.0, t_end=0.01, dt=0.002)  # a shorter step runs to t_end
    assert ok.t_final.values.tolist() == pytest.approx([0.01])


def test_the_planar_model_refuses_dt_longer_than_t_end_alike():
    lamina = rs.PlanarBody(0.10, 0.05, 1.0)
    for solid, planar in (
        (rs.run_batch, rs.run_planar_batch),
        (rs.simulate, rs.simulate_planar),
    ):
        with pytest.raises(ValueError) as refused:
            solid(TOY, spin=5.0, t_end=0.01, dt=0.1)
        with pytest.raises(ValueError) as refused_planar:
            planar(lamina, theta=0.1, t_end=0.01, dt=0.1)
        assert str(refused_planar.value) == str(refused.value)
        assert str(refused.value).startswith("dt must be at most t_end")
    ok = rs.run_planar_batch(lamina, theta=0.1, t_end=0.01, dt=0.002)
    assert ok.t_final.values.tolist() == pytest.approx([0.01])


def test_billions_of_steps_are_announced_before_the_run():
    # damping = 1e3 makes the default step 2.75e-10 s: 3.6e9 steps for 1 s of motion
    with warnings.catch_warnings():
        warnings.simplefilter("error", LongRunWarning)  # stop at the announcement
        with pytest.raises(
            LongRunWarning,
            match=r"this batch takes up to 3\.63e\+09 steps in "
            r"all \(1 launch; the longest t_end = 1 s / dt = 2\.75e-10 s "
            r"\(the body's default step at g = 9\.81, damping = 1000\) = "
            r"3,630,359,508 steps; fewer where launches end early, at a capsize or a "
            r"stop\).*up to roughly 60\.5 core-minutes",
        ):
            rs.run_batch(TOY, spin=5.0, t_end=1.0, damping=1e3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LongRunWarning)
        rs.run_batch(TOY, spin=np.ones(4), t_end=0.5)  # 1.4e3 steps: nothing said


def test_a_long_sweep_is_announced_before_anything_is_written(tmp_path):
    from rattlesweep.sweep import Sweep, run_sweep

    s = Sweep(
        axes={"spin": {"start": 1, "stop": 5, "num": 4}},
        fixed={"t_end": 1.0, "damping": 1e3},
    )
    assert s.max_steps == 3_630_359_508
    with warnings.catch_warnings():
        warnings.simplefilter("error", LongRunWarning)
        with pytest.raises(
            LongRunWarning,
            match=r"this sweep takes up to 1\.45e\+10 steps "
            r"\(4 launches, the longest 3,630,359,508 steps\)",
        ):
            run_sweep(s, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_a_launch_shorter_than_the_default_step_ends_at_its_t_end():
    """t_end = 1e-6 s with a default step of 1.4e-3 s: one step of t_end, not a whole
    default step (1400 times as long); a longer launch keeps the default step."""
    toy = rs.Body.preset("toy")
    run = rs.simulate(toy, spin=-3.0, t_end=1e-6)
    assert run.time.values[-1] == pytest.approx(1e-6, rel=1e-12)
    batch = rs.run_batch(toy, spin=-3.0, t_end=[1e-6, 0.5])
    assert batch.dt.values[0] == pytest.approx(1e-6)
    assert batch.dt.values[1] == pytest.approx(toy.default_dt())
