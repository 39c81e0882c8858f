"""Running tiles in parallel and handing each finished tile's results to the caller, in
the calling thread, in the order they finish: on local threads, or as dask tasks on a
dask.distributed cluster, whose workers send results back through dask and never touch
the output."""

from __future__ import annotations

import signal
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from typing import Any, Callable

from .._config.spec import Sweep
from .tiles import compute_tile

__all__ = ["run_tiles"]

Handler = Callable[[Any], None]


def run_tiles(
    sweep: Sweep,
    todo: list[Any],
    on_result: Handler,
    *,
    client: Any = None,
    workers: int = 1,
    compute: Callable[[Sweep, Any], Any] = compute_tile,
    on_wait: Callable[[], None] | None = None,
    on_stopping: Callable[[int], None] | None = None,
) -> None:
    """Compute the tiles ``todo`` of ``sweep`` and call ``on_result`` with each result as
    it arrives. ``client`` (a ``distributed.Client``) runs them on its cluster; without
    it, ``workers`` local threads run them. A task is ``compute(sweep, item)`` for each
    item of ``todo``: by default an item is a tile number (:func:`compute_tile`); other
    items name their task by their ``key`` attribute.

    Ctrl-C stops handing out tiles and raises ``KeyboardInterrupt``: on local threads the
    tiles in flight finish (the kernel cannot be interrupted) and are handed over first,
    unless Ctrl-C is pressed again; on a cluster they are cancelled. A result being
    handed over when Ctrl-C comes is handed over in full.
    An exception in ``on_result`` or a task stops the run and propagates.
    On local threads ``on_wait`` (a progress bar's ``tick``) is called in the calling
    thread about every 0.1 s while tiles run, and ``on_stopping`` once with the number
    of tiles still running when they have not finished ``STOPPING_NOTE`` s after the
    first Ctrl-C (so that a wait for long tiles is explained, and a short one is not).
    """
    if client is None:
        _run_threads(sweep, todo, on_result, workers, compute, on_wait, on_stopping)
    else:
        _run_cluster(sweep, todo, on_result, client, compute)


class _Interrupts:
    """Ctrl-C turned into a count the runner polls, for the duration of a ``with``.

    A ``KeyboardInterrupt`` raised at an arbitrary instant can leave a lock held: the one
    xarray takes around a netCDF write, or one inside ``concurrent.futures``; whatever
    takes that lock again (the next tile's write, the pool's shutdown) then waits forever.
    So in the main thread, where Python delivers SIGINT, the default handler is replaced
    by one that only counts, and the runner decides where to stop. Elsewhere (a thread,
    or a handler of the caller's own) nothing changes and ``count`` stays 0.
    """

    def __init__(self) -> None:
        self.count = 0
        self._previous: Any = None

    def _handler(self, signum: int, frame: Any) -> None:
        self.count += 1

    def __enter__(self) -> "_Interrupts":
        if threading.current_thread() is threading.main_thread() and _raises_interrupt(
            signal.getsignal(signal.SIGINT)
        ):
            self._previous = signal.signal(signal.SIGINT, self._handler)
            # a Ctrl-C the caller's handler counted but a library swallowed (while the
            # output was checked): no tile is started
            self.count = min(1, getattr(self._previous, "count", 0))
        return self

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def _raises_interrupt(handler: Any) -> bool:
    """Whether ``handler`` is Python's default SIGINT handler or one that behaves as it
    does (the command line's, which also counts)."""
    return handler is signal.default_int_handler or bool(
        getattr(handler, "raises_keyboard_interrupt", False)
    )


_END = object()
_POLL = 0.1
"""Seconds between checks for Ctrl-C while tiles run."""

STOPPING_NOTE = 2.0
"""Seconds after a first Ctrl-C from which the wait for the tiles still running is
explained (``on_stopping``)."""


def _run_threads(
    sweep: Sweep,
    todo: list[Any],
    on_result: Handler,
    workers: int,
    compute: Callable[[Sweep, Any], Any],
    on_wait: Callable[[], None] | None = None,
    on_stopping: Callable[[int], None] | None = None,
) -> None:
    # a few tiles queued per thread keeps the threads busy while this thread writes;
    # the rest are handed out as tiles finish, so results never pile up in memory
    window = 2 * workers
    queue = iter(todo)
    running: set[Future] = set()
    pool = ThreadPoolExecutor(workers, thread_name_prefix="rattlesweep-tile")

    def refill() -> None:
        while len(running) < window:
            tile = next(queue, _END)
            if tile is _END:
                return
            running.add(pool.submit(compute, sweep, tile))

    stop_seen = None  # when the first Ctrl-C was seen (monotonic s); None before it
    with _Interrupts() as interrupts:
        try:
            refill()
            # after the first Ctrl-C no tile is handed out and the tiles running finish
            # and are written; after a second one nothing more is waited for
            while running and interrupts.count < 2:
                finished, _ = wait(running, timeout=_POLL, return_when=FIRST_COMPLETED)
                for future in finished:
                    running.discard(future)
                    on_result(future.result())
                if on_wait is not None:
                    on_wait()
                if interrupts.count == 0:
                    refill()
                else:  # tiles queued but not started are dropped: only running ones end
                    for future in list(running):
                        if future.cancel():
                            running.discard(future)
                    now = time.monotonic()
                    stop_seen = now if stop_seen is None else stop_seen
                    if running and on_stopping and now - stop_seen >= STOPPING_NOTE:
                        on_stopping(len(running))
                        on_stopping = None
        finally:
            pool.shutdown(wait=not interrupts.count, cancel_futures=True)
        if interrupts.count:
            raise KeyboardInterrupt


def _run_cluster(
    sweep: Sweep,
    todo: list[Any],
    on_result: Handler,
    client: Any,
    compute: Callable[[Sweep, Any], Any],
) -> None:
    import dask
    from distributed import as_completed

    # the sweep goes into the graph once, as a literal the scheduler can hand to any
    # worker again (a worker that dies takes nothing with it that cannot be recomputed)
    tag = sweep.config_hash()[:12]
    shared = dask.delayed(sweep, traverse=False, name=f"rattlesweep-config-{tag}")
    task = dask.delayed(compute, pure=False)
    futures = client.compute(
        [
            task(shared, t, dask_key_name=f"rattlesweep-tile-{tag}-{getattr(t, 'key', t)}")
            for t in todo
        ]
    )
    try:
        for future in as_completed(futures):
            result = future.result()
            future.release()  # the worker may drop it now
            on_result(result)
    except BaseException:
        client.cancel(futures)
        raise
