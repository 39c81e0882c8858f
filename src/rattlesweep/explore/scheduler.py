"""Sharing the machine between the page's sessions.

Work comes as jobs of a session and a kind (``"run"``, ``"map"``). A job is a function
doing one bounded piece of work per call (a run: all of it; a map: one chunk of launches)
and returning ``(done, result)``. A fixed set of worker threads takes pieces round-robin
over the sessions with work waiting, a session's run before its map, so one session's
map cannot hold up another session's runs for longer than a piece. The kernels release
the GIL (numba ``nogil``), so workers run on separate cores; each piece is serial (no
numba threads inside these threads).

A new job of a session and kind supersedes the one before it: a waiting one is dropped
at once, a running one finishes its current piece and its result is dropped. Either way
its future raises :class:`Superseded`.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from concurrent.futures import Future
from typing import Any, Callable

__all__ = ["Job", "Scheduler", "Superseded"]

Step = Callable[[], "tuple[bool, Any]"]


class Superseded(Exception):
    """The job was replaced by a newer one of the same session and kind."""


class Job:
    """One session's work of one kind; ``future`` gets its result."""

    def __init__(self, session: str, kind: str, step: Step) -> None:
        self.session, self.kind, self.step = session, kind, step
        self.future: Future[Any] = Future()
        self.superseded = False
        self.pieces = 0
        # perf_counter times (s): queued, first piece started, last piece finished
        self.queued = time.perf_counter()
        self.started: float | None = None
        self.finished: float | None = None


class Scheduler:
    """Round-robin worker threads over sessions (see the module's description)."""

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self._cv = threading.Condition()
        self._waiting: dict[str, dict[str, Job]] = {}
        self._running: dict[tuple[str, str], Job] = {}
        self._order: deque[str] = deque()
        self._closed = False
        self.completed = 0
        self.superseded = 0
        self._threads = [
            threading.Thread(target=self._work, name=f"explore-worker-{i}", daemon=True)
            for i in range(workers)
        ]
        for t in self._threads:
            t.start()

    def submit(self, session: str, kind: str, step: Step) -> Job:
        """Queue a job, superseding the session's previous job of this kind."""
        job = Job(session, kind, step)
        with self._cv:
            if self._closed:
                raise RuntimeError("the scheduler is closed")
            queue = self._waiting.setdefault(session, {})
            old = queue.pop(kind, None)
            if old is not None:
                self._drop(old)
            running = self._running.get((session, kind))
            if running is not None:
                running.superseded = True
            queue[kind] = job
            if session not in self._order:
                self._order.append(session)
            self._cv.notify()
        return job

    def cancel(self, session: str, kind: str) -> None:
        """Supersede a session's job of this kind without a new one."""
        with self._cv:
            old = self._waiting.get(session, {}).pop(kind, None)
            if old is not None:
                self._drop(old)
            running = self._running.get((session, kind))
            if running is not None:
                running.superseded = True

    def busy(self) -> int:
        """Jobs waiting or running."""
        with self._cv:
            return len(self._running) + sum(len(q) for q in self._waiting.values())

    def close(self) -> None:
        with self._cv:
            self._closed = True
            for queue in self._waiting.values():
                for job in queue.values():
                    self._drop(job)
            self._waiting.clear()
            self._order.clear()
            self._cv.notify_all()

    def _drop(self, job: Job) -> None:
        job.superseded = True
        self.superseded += 1
        job.future.set_exception(Superseded(f"{job.kind} superseded by a newer one"))

    def _take(self) -> Job | None:
        with self._cv:
            while not self._order and not self._closed:
                self._cv.wait()
            if self._closed:
                return None
            session = self._order.popleft()
            queue = self._waiting[session]
            kind = "run" if "run" in queue else next(iter(queue))
            job = queue.pop(kind)
            if queue:
                self._order.append(session)
            else:
                del self._waiting[session]
            self._running[(session, kind)] = job
            if job.started is None:
                job.started = time.perf_counter()
            return job

    def _work(self) -> None:
        while True:
            job = self._take()
            if job is None:
                return
            try:
                done, result = job.step()
                error: BaseException | None = None
            except Exception as exc:  # reported to the request waiting on it
                done, result, error = True, None, exc
            job.pieces += 1
            job.finished = time.perf_counter()
            with self._cv:
                del self._running[(job.session, job.kind)]
                if job.superseded:
                    self.superseded += 1
                    job.future.set_exception(Superseded(f"{job.kind} superseded"))
                elif error is not None:
                    job.future.set_exception(error)
                elif done:
                    self.completed += 1
                    job.future.set_result(result)
                else:
                    # the next piece waits its turn behind the other sessions
                    queue = self._waiting.setdefault(job.session, {})
                    if job.kind in queue:  # a newer job arrived meanwhile
                        job.future.set_exception(Superseded(f"{job.kind} superseded"))
                    else:
                        queue[job.kind] = job
                        if job.session not in self._order:
                            self._order.append(job.session)
                        self._cv.notify()
