"""Property-based tests (hypothesis) of sweep configurations in TOML, valid and corrupted.

A configuration file is either refused with a ``ValueError`` (for a value the strategy
made bad on purpose, one that names its key), or it makes a :class:`~rattlesweep.Sweep`
that reads back from its own TOML unchanged, whose every grid point passes the batch
layer's checks (the corner check at construction promises that), and whose run gives,
at every point, the result of that launch run directly, clean as in
tests/test_properties.py.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("hypothesis")

from hypothesis import event, given, note
from hypothesis import strategies as st

import rattlesweep as rs
from rattlesweep.sweep._execution.run import run_sweep
from rattlesweep.sweep._config.toml_io import format_toml
from strategies import corruptions, sweep_configs
from test_properties import OBSERVABLES, assert_names, check_trajectories, rerun_batch

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


def check_sweep(sweep: rs.Sweep, run: bool) -> None:
    """Round trip, every point accepted, and (``run``) the run equal to the direct one."""
    again = rs.Sweep.from_toml(sweep.to_toml())
    assert again == sweep and again.config_hash() == sweep.config_hash()
    assert rs.Sweep(**sweep.to_dict()) == sweep
    if not sweep.simulates:  # no t_end (a corrupted file may lose it): stability maps only
        return
    bodies, kwargs = sweep.points(0, sweep.size)
    direct = rs.run_batch(
        bodies, method=sweep.method, reversal_band=sweep.reversal_band, **kwargs
    )
    check_trajectories(
        direct,
        rerun_batch(
            functools.partial(
                rs.run_batch, bodies, method=sweep.method, reversal_band=sweep.reversal_band
            ),
            direct,
            kwargs,
        ),
        shrink=2.0 if sweep.method == "euler" else 8.0,
    )
    if not run:
        return
    with tempfile.TemporaryDirectory() as tmp:
        ds = run_sweep(sweep, tmp, progress=False, workers=1, command="test")
        assert ds.outcome.shape == sweep.shape
        for name in OBSERVABLES:
            np.testing.assert_array_equal(
                ds[name].values.ravel(), direct[name].values, err_msg=name
            )
        again = run_sweep(sweep, tmp, progress=False, workers=1, command="test")
        for name in OBSERVABLES:
            np.testing.assert_array_equal(again[name].values, ds[name].values)


@given(case=sweep_configs(), run=st.integers(0, 3))
def test_sweep_files(case, run):
    """A generated configuration file, possibly with one value made bad."""
    config, bad_keys = case
    text = format_toml(config)
    note(text)
    try:
        sweep = rs.Sweep.from_toml(text)
    except ValueError as exc:
        assert bad_keys, f"a valid configuration was refused: {exc}"
        (key,) = bad_keys
        assert_names(exc, {key, key.rpartition(".")[2]})
        event("refused")
        return
    event(f"accepted ({'with' if bad_keys else 'no'} value made bad)")
    check_sweep(sweep, run=run == 0)


@given(case=sweep_configs(), data=st.data())
def test_corrupted_sweep_files(case, data):
    """A configuration file damaged as files get damaged or hand-edited is refused with a
    ValueError, or reads as a sweep that keeps every promise of a sweep."""
    text = format_toml(case[0])
    damaged = data.draw(corruptions(text))
    note(damaged)
    try:
        sweep = rs.Sweep.from_toml(damaged)
    except ValueError as exc:
        assert str(exc)
        event("refused")
        return
    event("accepted")
    check_sweep(sweep, run=False)


@given(case=sweep_configs(), junk=st.binary(min_size=1, max_size=8), at=st.integers(0))
def test_sweep_files_with_bad_bytes(case, junk, at):
    """Bytes that may not be UTF-8 in a configuration file: a file that cannot be read as
    TOML is a ValueError that names it; one that can is refused or accepted as text."""
    raw = format_toml(case[0]).encode()
    at %= len(raw) + 1
    raw = raw[:at] + junk + raw[at:]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sweep.toml"
        path.write_bytes(raw)
        try:
            sweep = rs.Sweep.from_toml(path)
        except ValueError as exc:
            if str(exc).startswith("cannot"):
                assert str(path) in str(exc)
            event("refused")
            return
    event("accepted")
    check_sweep(sweep, run=False)
