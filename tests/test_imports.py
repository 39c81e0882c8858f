"""Import costs: the package and a sweep specification load without the heavy libraries
they do not use (dask, netCDF4, matplotlib)."""

import importlib
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import rattlesweep as rs

HEAVY = ("dask", "netCDF4", "matplotlib")
SRC = str(Path(rs.__file__).resolve().parents[1])


def _imported_after(code: str) -> dict[str, bool]:
    """Run ``code`` in a fresh interpreter; which of HEAVY are imported afterwards."""
    probe = textwrap.dedent(code) + textwrap.dedent(f"""
        import json, sys
        print(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))
    """)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([SRC, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True
    ).stdout
    return json.loads(out.splitlines()[-1])


def test_import_rattlesweep_loads_no_heavy_library():
    assert _imported_after("import rattlesweep") == {m: False for m in HEAVY}


def test_making_and_writing_a_sweep_loads_no_heavy_library():
    got = _imported_after("""
        from rattlesweep import Sweep
        s = Sweep(axes={"spin": [1.0, 2.0]}, fixed={"t_end": 1.0},
                  random={"roll_deg": {"uniform": [0.1, 0.2]}}, repeats=2)
        assert Sweep.from_toml(s.to_toml()) == s
    """)
    assert got == {m: False for m in HEAVY}


def test_lazy_names_resolve_and_are_listed():
    from rattlesweep import sweep
    from rattlesweep.sweep._execution import run

    assert rs.Sweep is sweep.Sweep
    assert rs.run_sweep is run.run_sweep and rs.resume is run.resume
    assert sweep.run_sweep is run.run_sweep and sweep.resume is run.resume
    assert rs.sweep is sweep
    # the public names of functions the private subpackages hold, and the path the API
    # reference gave compare_with_full before the subpackages
    from rattlesweep.sweep._execution.estimate import estimate
    from rattlesweep.sweep._outputs.compare import compare_with_full

    assert sweep.estimate is estimate
    assert sweep.compare_with_full is compare_with_full
    assert sweep.compare.compare_with_full is compare_with_full
    for name in rs.__all__:
        assert name in dir(rs) and getattr(rs, name) is not None
    for name in sweep.__all__:
        assert name in dir(sweep) and getattr(sweep, name) is not None
    try:
        rs.no_such_name
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("an unknown attribute must raise AttributeError")


def test_making_a_sweep_runs_no_kernel():
    """The corner check validates every combination of the axis extremes without the
    kernel: no numba kernel is compiled or loaded to build a configuration."""
    probe = textwrap.dedent("""
        from rattlesweep import Sweep
        from rattlesweep._core import stepper
        s = Sweep(axes={"spin": [1.0, 2.0], "mu": [0.3, float("inf")]},
                  fixed={"t_end": 1.0, "roll_deg": 0.5})
        assert s.tile_size > 0
        kernels = [f for f in vars(stepper).values() if hasattr(f, "signatures")]
        assert kernels
        print(sum(len(f.signatures) for f in kernels))
    """)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([SRC, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True
    ).stdout
    assert out.split()[-1] == "0"


# exception classes users do not catch: raised and handled inside the explorer's server
INTERNAL = {"SettingError", "CapExceeded", "Superseded", "PortInUse", "DamagedFile", "Busy"}


def _exception_classes() -> dict[str, str]:
    """Every exception or warning class the package defines: name -> module."""
    found = {}
    pattern = re.compile(r"^class (\w+)\((\w*(?:Error|Warning|Exception))\):", re.M)
    for path in Path(SRC, "rattlesweep").rglob("*.py"):
        module = ".".join(path.relative_to(SRC).with_suffix("").parts)
        for name, _ in pattern.findall(path.read_text()):
            found[name] = module
    return found


def test_every_public_exception_and_warning_is_at_the_top_level():
    found = _exception_classes()
    known = {"CoarseStepWarning", "LongRunWarning", "SweepWriteError", "UnitsWarning"}
    assert known <= set(found)
    for name, module in found.items():
        if name in INTERNAL:
            continue
        assert name in rs.__all__ and name in dir(rs), name
        assert getattr(rs, name) is getattr(importlib.import_module(module), name), name
    assert not INTERNAL & set(rs.__all__)


def test_sweep_errors_and_the_plots_load_on_first_use_only():
    # names from the sweep package, without dask or netCDF4 until the sweep runs
    assert _imported_after("""
        import rattlesweep as rs
        from rattlesweep.sweep._outputs.store import SweepWriteError
        from rattlesweep.sweep._execution.lock import SweepLocked
        assert rs.SweepWriteError is SweepWriteError and rs.SweepLocked is SweepLocked
        assert issubclass(rs.CoarseStepWarning, RuntimeWarning)
    """) == {m: False for m in HEAVY}
    # rs.plot with no import of rattlesweep.plot first: matplotlib then, and only then
    got = _imported_after("""
        import sys
        import rattlesweep as rs
        assert "matplotlib" not in sys.modules
        assert callable(rs.plot.time_series) and callable(rs.plot.reversal_map)
    """)
    assert got["matplotlib"] and not got["dask"]


def test_the_command_starts_without_numerical_libraries():
    """The command's module loads only the standard library, so rattlesweep.cli:run is
    running (and turns a Ctrl-C into status 130) before numpy, numba or xarray load."""
    probe = textwrap.dedent("""
        import json, sys
        import rattlesweep.cli
        print(json.dumps([m for m in ("numpy", "numba", "xarray") if m in sys.modules]))
    """)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([SRC, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True
    ).stdout
    assert json.loads(out.splitlines()[-1]) == []


def test_python_m_rattlesweep_is_the_command_line():
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([SRC, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    out = subprocess.run(
        [sys.executable, "-m", "rattlesweep", "--version"],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    ).stdout
    assert rs.__version__ in out
    bad = subprocess.run(
        [sys.executable, "-m", "rattlesweep", "no-such-command"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert bad.returncode == 2 and "no-such-command" in bad.stderr


def test_dir_lists_the_public_names_only():
    import rattlesweep.tidy  # noqa: F401  (a submodule once imported is listed too)

    listed = dir(rs)
    assert set(rs.__all__) <= set(listed) and "tidy" in listed
    assert not {"Any", "TYPE_CHECKING", "importlib", "annotations"} & set(listed)
    assert not [n for n in listed if n.startswith("_") and n != "__version__"]


def test_all_is_what_the_api_reference_documents():
    page = (Path(SRC).parent / "docs" / "api.rst").read_text()
    documented = set(re.findall(r"^   ([A-Za-z_]\w*)", page, re.M))
    assert documented  # the page's autosummary entries, first component of each
    # the planar model's module: its guide imports from it; rattlesweep.io is documented
    # but kept out of __all__, where a star import would shadow the standard library's
    assert set(rs.__all__) == (documented - {"io"}) | {"planar", "__version__"}
    assert rs.io.write_netcdf


PUBLIC = {
    "CoarseStepWarning": ("a coarse step",),
    "LongRunWarning": ("a long run",),
    "UnitsWarning": ("roll=30",),
    "SweepWriteError": ("disk full",),
    "SweepLocked": ("locked",),
    "DesignRefused": ("too heavy", 0.004),
}


def test_public_exceptions_are_named_at_the_top_level_and_pickle():
    import pickle

    assert set(PUBLIC) == set(_exception_classes()) - INTERNAL
    for name, args in PUBLIC.items():
        cls = getattr(rs, name)
        assert cls.__module__ == "rattlesweep" and cls.__qualname__ == name
        back = pickle.loads(pickle.dumps(cls(*args)))
        assert type(back) is cls and str(back) == args[0], name
        assert vars(back) == vars(cls(*args)), name
    assert pickle.loads(pickle.dumps(rs.DesignRefused("x", 0.004))).max_coin_mass == 0.004
