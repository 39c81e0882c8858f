"""What a first call that compiles kernels tells its user, and the time it spends.

numba compiles a kernel specialisation on its first call in a fresh installation (or
after an upgrade), which takes minutes where a run takes seconds. Such a call is never
silent: once per process the logger ``rattlesweep`` says, at WARNING (so that Python
prints it on stderr when nothing configured logging), what compiles, how long that
usually takes and that ``rattlesweep compile`` builds every kernel ahead. Silence it
with ``logging.getLogger("rattlesweep").setLevel(logging.ERROR)``. This module loads
only the standard library until a compile starts, so that the command line can set it
up before anything numerical loads. The command line also asks for a line with the
elapsed time every few seconds while a compile runs (:func:`show_elapsed`).
:func:`compile_seconds` is the time this process has spent compiling, which rates and
ETAs leave out.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import threading
import time
from typing import Any, Iterator, TextIO

__all__ = ["announce", "compile_seconds", "compiling", "show_elapsed"]

LOG = logging.getLogger("rattlesweep")

_STATE: dict[str, Any] = {
    "told": False,
    "seconds": 0.0,  # closed intervals with some compile running
    "active": 0,  # compiles running now (threads wait for numba's lock in turn)
    "since": 0.0,  # when the running interval began
    "every": None,
    "stream": None,
    "done": None,  # set when the running interval ends: stops its clock
}
_LOCK = threading.Lock()


def show_elapsed(every: float | None, stream: TextIO | None = None) -> None:
    """While a compile runs, write ``compiling the kernels: N s`` to ``stream`` (stderr)
    every ``every`` seconds; None: not at all (the default of a library)."""
    _STATE["every"], _STATE["stream"] = every, stream


def compile_seconds() -> float:
    """Seconds of wall time during which this process was compiling kernels."""
    with _LOCK:
        running = time.perf_counter() - _STATE["since"] if _STATE["active"] else 0.0
        return float(_STATE["seconds"] + running)


def estimate_s(job_names: list[str]) -> float:
    """Typical seconds on one core to compile the jobs ``job_names`` and what they need
    that is not cached yet."""
    from ._core import specialisations  # numba: loaded with the kernels, not before

    jobs = specialisations.with_what_they_need(job_names)
    return sum(job.typical_s for job in jobs if not job.cached())


def _minutes(seconds: float) -> str:
    if seconds < 90:
        return f"about {max(10, round(seconds, -1)):.0f} s"
    return f"about {seconds / 60:.0f} min"


def announce(job_names: list[str]) -> None:
    """Say, once per process, that a call needing the jobs ``job_names`` of
    :data:`.specialisations.JOBS` (the first names what the call runs) compiles, when
    some of them are not cached, with the typical time for all of them."""
    if _STATE["told"] or all(name in _CACHED for name in job_names):
        return
    from ._core import specialisations  # numba: loaded with the kernels, not before

    missing = [name for name in job_names if not specialisations.job(name).cached()]
    _CACHED.update(set(job_names) - set(missing))
    if not missing:
        return
    with _LOCK:
        if _STATE["told"]:
            return
        _STATE["told"] = True
    LOG.warning(
        "compiling the simulation kernels for %s (first use after installing: %s on "
        "one core; later processes load them in about a second). `rattlesweep "
        "compile` builds every kernel ahead, in parallel.",
        specialisations.job(job_names[0]).label,
        _minutes(estimate_s(missing)),
    )


_CACHED: set[str] = set()  # jobs found cached in this process: not looked up again


@contextlib.contextmanager
def compiling(job_name: str | None) -> Iterator[None]:
    """Around a first call that compiles: the notice (once per process, see
    :func:`announce`) naming the job ``job_name`` of :data:`.specialisations.JOBS`
    (None: a kernel outside them), the elapsed-time lines when asked, and the compile
    clock."""
    if job_name is not None:
        announce([job_name])
    elif not _STATE["told"]:
        _STATE["told"] = True
        LOG.warning(
            "compiling a simulation kernel (first use after installing); `rattlesweep "
            "compile` builds the kernels ahead, in parallel."
        )
    ticker = None
    with _LOCK:
        _STATE["active"] += 1
        if _STATE["active"] == 1:  # the first of compiles running at once
            _STATE["since"] = time.perf_counter()
            _STATE["done"] = done = threading.Event()
            if _STATE["every"]:
                ticker = threading.Thread(
                    target=_tick,
                    args=(done, _STATE["since"], _STATE["every"], _STATE["stream"]),
                    name="rattlesweep-compile-clock",
                    daemon=True,
                )
                ticker.start()
    try:
        yield
    finally:
        with _LOCK:
            _STATE["active"] -= 1
            if _STATE["active"] == 0:
                _STATE["seconds"] += time.perf_counter() - _STATE["since"]
                _STATE["done"].set()
        if ticker is not None:
            ticker.join()


def _tick(done: threading.Event, since: float, every: float, stream: TextIO | None) -> None:
    """One line with the elapsed time every ``every`` seconds until ``done``: one clock
    for all the compiles running at once (threads of a sweep wait for numba's lock in
    turn), counted from the first."""
    out = stream or sys.stderr
    while not done.wait(every):
        out.write(f"compiling the kernels: {time.perf_counter() - since:.0f} s\n")
        out.flush()
