"""The cold start: `rattlesweep compile` builds every kernel ahead in worker processes and
then has nothing to do; a first call that compiles says so once, with the time it
takes, and a line every few seconds on the command line; processes compiling into one
cache at once never mix up two signatures' machine code."""

import io
import logging
import os
import re
import subprocess
import sys
import threading
import time

import pytest

from rattlesweep import _cold_start
from rattlesweep._core import specialisations
from rattlesweep._core.jit import LockedCacheFile
from rattlesweep.cli import main
from rattlesweep.kernel_cache import compile_kernels


@pytest.fixture
def untold(monkeypatch):
    """A process that has not said yet that it compiles."""
    monkeypatch.setitem(_cold_start._STATE, "told", False)
    monkeypatch.setattr(_cold_start, "_CACHED", set())


def test_a_second_compile_finds_everything_compiled_and_says_so():
    compile_kernels(stream=io.StringIO())  # whatever this session has not compiled yet
    out = io.StringIO()
    began = time.perf_counter()
    report = compile_kernels(stream=out)
    seconds = time.perf_counter() - began
    assert report.compiled == () and report.already == len(specialisations.JOBS)
    assert seconds < 5, seconds
    assert re.fullmatch(
        rf"all {len(specialisations.JOBS)} kernel specialisations are compiled already, "
        r"in .+ \(\d+ MB\); nothing to do\n",
        out.getvalue(),
    )
    assert report.size_bytes > 1e6 and report.directories[0].is_dir()


def test_compile_in_worker_processes_into_an_empty_cache(tmp_path):
    """The planar model at rolling contact, in 2 processes into an empty cache: every
    job is reported as it ends, the waits for long ones at least every few seconds, and
    the entry then loads from the cache in a new process without compiling."""
    probe = (
        "import io, sys\n"
        "from rattlesweep.kernel_cache import compile_kernels\n"
        "report = compile_kernels(2, only=['entry:planar:rolling'], every=2.0)\n"
        "print(len(report.compiled))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, env=env, timeout=600
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == ["5"]  # four right-hand side variants and the stepper
    lines = out.stderr.splitlines()
    assert lines[0].startswith("compiling 5 of 5 kernel specialisations in 2 processes")
    stamps = [
        float(m.group(1)) for m in map(re.compile(r"\[ *(\d+) s\]").match, lines) if m
    ]
    assert max(b - a for a, b in zip([0.0, *stamps], stamps)) <= 4.5  # never silent long
    assert any("planar launches with rolling contact" in line for line in lines)
    assert lines[-1].startswith("compiled 5 kernel specialisations in ")
    check = (
        "from rattlesweep._core import specialisations as s\n"
        "print(s.job('entry:planar:rolling').cached(), s.job('entry:planar:sliding')"
        ".cached())\n"
    )
    again = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, env=env, check=True
    )
    assert again.stdout.split() == ["True", "False"]


def test_compile_refuses_a_bad_number_of_processes(capsys):
    with pytest.raises(SystemExit) as exit:
        main(["compile", "--jobs", "0"])
    assert exit.value.code == 2
    assert (
        "--jobs: must be a whole number of at least 1, got '0'" in capsys.readouterr().err
    )
    with pytest.raises(ValueError, match="jobs must be a whole number of processes"):
        compile_kernels(0)


def test_a_first_compile_says_so_once_with_its_time(untold, caplog):
    caplog.set_level(logging.WARNING, logger="rattlesweep")
    name = specialisations.entry_job(0, 1)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(specialisations.Job, "cached", lambda self: False)  # a fresh install
        expected = sum(j.typical_s for j in specialisations.JOBS if _needs(name, j.name))
        with _cold_start.compiling(name):
            pass
        with _cold_start.compiling(specialisations.entry_job(1, 0)):
            pass
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1
    minutes = round(expected / 60)
    assert said[0].startswith(
        "compiling the simulation kernels for rattleback launches with Coulomb friction "
        f"(first use after installing: about {minutes} min on one core;"
    ), said
    assert said[0].endswith("`rattlesweep compile` builds every kernel ahead, in parallel.")


def _needs(name, other):
    """Whether the job ``name`` waits, directly or not, for ``other`` (or is it)."""
    if name == other:
        return True
    return any(_needs(before, other) for before in specialisations.job(name).after)


def test_a_batch_whose_kernels_are_cached_says_nothing(untold, caplog):
    import rattlesweep as rs

    caplog.set_level(logging.WARNING, logger="rattlesweep")
    compile_kernels(stream=io.StringIO())
    rs.run_batch(rs.Body.preset("toy"), spin=[5.0], mu=0.3, t_end=0.01)
    assert caplog.records == []


def test_the_command_line_shows_the_time_while_a_compile_runs():
    """One clock for compiles running at once (a sweep's threads each wait for numba's
    lock), counted from the first, a line every `every` seconds."""
    out = io.StringIO()
    _cold_start.show_elapsed(0.1, out)

    def compile_for(seconds):
        with _cold_start.compiling(specialisations.entry_job(0, 0)):
            time.sleep(seconds)

    threads = [threading.Thread(target=compile_for, args=(0.45,)) for _ in range(3)]
    try:
        before = _cold_start.compile_seconds()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        _cold_start.show_elapsed(None)
    lines = out.getvalue().splitlines()
    assert 3 <= len(lines) <= 5, lines
    assert all(re.fullmatch(r"compiling the kernels: \d s", line) for line in lines)
    assert 0.45 <= _cold_start.compile_seconds() - before < 1.0


def test_compile_time_of_threads_compiling_at_once_counts_once():
    before = _cold_start.compile_seconds()

    def compile_for(seconds):
        with _cold_start.compiling(specialisations.entry_job(0, 0)):
            time.sleep(seconds)

    threads = [threading.Thread(target=compile_for, args=(0.3,)) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert 0.3 <= _cold_start.compile_seconds() - before < 0.5


def test_processes_saving_into_one_cache_keep_every_signature_apart(tmp_path):
    """Eight processes each save their own signatures of one kernel into one index at
    once: every signature loads its own data (numba alone numbers two processes' new
    data files alike, and the index then names the other's machine code)."""
    script = (
        "import sys, time\n"
        "from rattlesweep._core.jit import LockedCacheFile\n"
        "f = LockedCacheFile(sys.argv[1], 'kernel', 'stamp')\n"
        "me = sys.argv[2]\n"
        "time.sleep(max(0.0, float(sys.argv[3]) - time.time()))\n"
        "for i in range(20):\n"
        "    f.save((me, i), f'{me}:{i}')\n"
    )
    start = time.time() + 5.0  # after every process has imported numba
    procs = [
        subprocess.Popen([sys.executable, "-c", script, str(tmp_path), f"p{k}", str(start)])
        for k in range(8)
    ]
    assert all(p.wait(timeout=120) == 0 for p in procs)
    cache = LockedCacheFile(str(tmp_path), "kernel", "stamp")
    index = cache._load_index()
    assert len(index) == 160 and len(set(index.values())) == 160
    for key in index:
        assert cache.load(key) == f"{key[0]}:{key[1]}"
