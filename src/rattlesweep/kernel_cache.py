"""Compiling every kernel ahead of use, in parallel, and where the compiled kernels live.

numba compiles each kernel specialisation on its first call and caches the machine code
on disk, so only the first process of a fresh installation pays for it.
:func:`compile_kernels` (``rattlesweep compile``) pays it once, ahead: it walks the
specialisations the library can call (:data:`rattlesweep._core.specialisations.JOBS`)
in several worker processes, each job after the ones whose cached kernels it reuses,
and reports each as it finishes. A second call finds everything cached and returns in
about a second.

The cache lives where numba puts it (:func:`cache_directories`): beside the package's
sources when they are writable, else in the user's cache directory, or under
``NUMBA_CACHE_DIR`` when that is set. Many processes, or a cluster's workers on a shared
file system, can use one cache: point ``NUMBA_CACHE_DIR`` of each at the same directory
and run ``rattlesweep compile`` there once. Processes compiling into one cache at once
are safe: every save of a kernel holds a lock on its index (see
:mod:`rattlesweep._core.jit`). Machine code is kept per processor type, so workers of
different processors each add their own.
"""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TextIO

from ._core import specialisations
from ._core.jit import cache_directories

__all__ = ["CacheReport", "cache_directories", "cache_size", "compile_kernels"]


@dataclass(frozen=True)
class CacheReport:
    """What :func:`compile_kernels` did: the jobs it ``compiled`` (names), the number
    that were cached ``already``, the wall ``seconds`` it took, the cache
    ``directories`` and their ``size_bytes`` afterwards."""

    compiled: tuple[str, ...]
    already: int
    seconds: float
    directories: tuple[Path, ...]
    size_bytes: int


def cache_size(directories: list[Path] | tuple[Path, ...]) -> int:
    """Bytes of compiled kernels (numba's ``.nbi``/``.nbc`` files) in ``directories``."""
    return sum(
        path.stat().st_size
        for directory in directories
        if directory.is_dir()
        for path in directory.glob("*.nb[ic]")
    )


def _where(directories: tuple[Path, ...]) -> str:
    if len(directories) == 1:
        return str(directories[0])
    return f"{len(directories)} folders under {os.path.commonpath(directories)}"


def _default_jobs() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def _priorities() -> dict[str, float]:
    """Each job's typical seconds plus the longest chain of jobs waiting for it: the
    scheduler starts the job at the head of the longest chain first."""
    waiting: dict[str, list[str]] = {job.name: [] for job in specialisations.JOBS}
    for job in specialisations.JOBS:
        for name in job.after:
            waiting[name].append(job.name)
    chain: dict[str, float] = {}

    def length(name: str) -> float:
        if name not in chain:
            chain[name] = specialisations.job(name).typical_s + max(
                (length(later) for later in waiting[name]), default=0.0
            )
        return chain[name]

    return {name: length(name) for name in waiting}


class _Worker:
    """A process that compiles the jobs it is sent, one name a line on its stdin, and
    answers ``ok NAME SECONDS`` or ``error NAME MESSAGE`` on its stdout."""

    def __init__(self, answers: queue.Queue) -> None:
        self.log: IO[str] = tempfile.TemporaryFile("w+")  # its stderr, read if it dies
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "rattlesweep.kernel_cache"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
            bufsize=1,
        )
        self.job: str | None = None
        self.since = 0.0
        threading.Thread(target=self._read, args=(answers,), daemon=True).start()

    def _read(self, answers: queue.Queue) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            answers.put((self, line.strip()))
        answers.put((self, None))

    def send(self, name: str) -> None:
        assert self.proc.stdin is not None
        self.job, self.since = name, time.perf_counter()
        self.proc.stdin.write(name + "\n")
        self.proc.stdin.flush()

    def last_words(self) -> str:
        self.log.seek(0)
        return self.log.read()[-2000:]

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        if self.proc.stdin is not None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
        self.proc.wait()
        self.log.close()


def compile_kernels(
    jobs: int | None = None,
    *,
    stream: TextIO | None = None,
    every: float = 5.0,
    only: list[str] | None = None,
) -> CacheReport:
    """Compile every kernel specialisation the library can call into numba's on-disk
    cache, in ``jobs`` worker processes (default: the cores this process may use),
    writing a line to ``stream`` (default stderr; pass ``io.StringIO()`` for none) as
    each finishes, and one every ``every`` seconds while they run. Specialisations
    already cached are not compiled again; ``only`` names the jobs of
    :data:`rattlesweep._core.specialisations.JOBS` to compile (with those they need)
    instead of all. On Ctrl-C the workers are stopped; what they finished stays
    cached."""
    out = stream if stream is not None else sys.stderr
    if jobs is None:
        jobs = _default_jobs()
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(
            f"jobs must be a whole number of processes of at least 1, got {jobs!r}"
        )
    start = time.perf_counter()
    try:
        directories = tuple(cache_directories())
    except RuntimeError as error:  # no directory numba can write in
        raise OSError(
            f"numba cannot cache compiled kernels anywhere here ({error}); point "
            "NUMBA_CACHE_DIR at a writable directory"
        ) from None
    everything = specialisations.JOBS
    if only is not None:
        everything = specialisations.with_what_they_need(only)
    done = {job.name for job in everything if job.cached()}
    pending = [job for job in everything if job.name not in done]

    def write(text: str) -> None:
        out.write(text + "\n")
        out.flush()

    if not pending:
        size = cache_size(directories)
        write(
            f"all {len(everything)} kernel specialisations are compiled already, in "
            f"{_where(directories)} ({size / 1e6:.0f} MB); nothing to do"
        )
        return CacheReport(
            (), len(everything), time.perf_counter() - start, directories, size
        )

    priority = _priorities()
    pending.sort(key=lambda job: -priority[job.name])
    total_s = sum(job.typical_s for job in pending)
    n_workers = min(jobs, len(pending))
    write(
        f"compiling {len(pending)} of {len(everything)} kernel specialisations in "
        f"{n_workers} process{'es' if n_workers > 1 else ''} (about {total_s / 60:.0f} "
        f"min of compiling on one core), into {_where(directories)}"
    )
    answers: queue.Queue = queue.Queue()
    workers = [_Worker(answers) for _ in range(n_workers)]
    compiled: list[str] = []
    try:
        while pending or any(w.job for w in workers):
            for worker in workers:
                if worker.job is None:
                    ready = next(
                        (job for job in pending if all(name in done for name in job.after)),
                        None,
                    )
                    if ready is None:
                        break
                    pending.remove(ready)
                    worker.send(ready.name)
            try:
                worker, answer = answers.get(timeout=every)
            except queue.Empty:
                now = time.perf_counter()
                running = ", ".join(
                    f"{specialisations.job(w.job).label} ({now - w.since:.0f} s)"
                    for w in workers
                    if w.job
                )
                write(f"[{now - start:4.0f} s] compiling {running}")
                continue
            if answer is None:
                raise RuntimeError(
                    f"a compile process ended while compiling {worker.job}:\n"
                    f"{worker.last_words()}"
                )
            status, name, detail = (answer.split(" ", 2) + ["", ""])[:3]
            if status != "ok":
                raise RuntimeError(f"compiling {name} failed: {detail}")
            worker.job = None
            done.add(name)
            compiled.append(name)
            write(
                f"[{time.perf_counter() - start:4.0f} s] {len(compiled)}/"
                f"{len(compiled) + len(pending) + sum(1 for w in workers if w.job)} "
                f"{specialisations.job(name).label} ({float(detail):.0f} s)"
            )
    except KeyboardInterrupt:
        kept = len(compiled)
        write(
            f"interrupted: {kept} specialisation{' is' if kept == 1 else 's are'} compiled "
            "and kept in the cache; `rattlesweep compile` again compiles the rest"
        )
        raise
    finally:
        # every job reported is saved, so the workers are stopped at once (a worker
        # left to exit on its own takes seconds to tear down numba)
        for worker in workers:
            worker.stop()
    size = cache_size(directories)
    seconds = time.perf_counter() - start
    write(
        f"compiled {len(compiled)} kernel specialisations in {seconds:.0f} s; the cache "
        f"holds {size / 1e6:.0f} MB in {_where(directories)}"
    )
    return CacheReport(
        tuple(compiled), len(done) - len(compiled), seconds, directories, size
    )


def _serve() -> None:
    """A worker of :func:`compile_kernels`: compile each job named on stdin."""
    for line in sys.stdin:
        name = line.strip()
        began = time.perf_counter()
        try:
            specialisations.job(name).compile()
        except Exception as error:  # reported to the parent, which stops
            message = f"{type(error).__name__}: {error}".replace("\n", " ")
            print(f"error {name} {message}", flush=True)
            continue
        print(f"ok {name} {time.perf_counter() - began:.2f}", flush=True)


if __name__ == "__main__":
    _serve()
