"""The ``rattlesweep`` command line: sweeps, resuming, maps, file summaries, single runs
and their animations.

The package loads only the standard library, so that :func:`run` is answering Ctrl-C
before any numerical library loads; each command imports what it needs when it runs.
Its modules: the sweep commands (``_sweeps``), the commands that read results
(``_outputs``), those of one launch or body (``_launches``) and the parser (``_parser``).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import warnings
from typing import Any, Iterator

from ._parser import build_parser

__all__ = ["build_parser", "main", "run"]


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """A warning as the command's one line on stderr, without Python's source line."""
    print(f"rattlesweep: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    with warnings.catch_warnings():  # restores Python's own display on return
        warnings.showwarning = _show_warning
        with _compiles_announced():
            return _main(argv)


class _Stderr(logging.StreamHandler):
    """Log records as the command's own lines on whatever ``sys.stderr`` is now."""

    def __init__(self) -> None:
        super().__init__()
        self.setFormatter(logging.Formatter("rattlesweep: %(message)s"))

    @property
    def stream(self) -> Any:
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:
        pass


_ELAPSED_EVERY = 5.0  # seconds between the lines of a running compile


@contextlib.contextmanager
def _compiles_announced() -> Iterator[None]:
    """While a command runs, a first call that compiles kernels says so on stderr as
    the command's own line, with the elapsed time every few seconds while it compiles."""
    from .._cold_start import LOG, show_elapsed

    handler = _Stderr()
    LOG.addHandler(handler)
    show_elapsed(_ELAPSED_EVERY)
    try:
        yield
    finally:
        show_elapsed(None)
        LOG.removeHandler(handler)


def _main(argv: list[str] | None) -> int:
    try:
        args = build_parser().parse_args(argv)
        status = args.func(args, argv)
        sys.stdout.flush()  # a closed pipe is then found here, not at interpreter exit
        return status
    except KeyboardInterrupt:
        # Ctrl-C outside the tiles (while an output is checked or merged): what was
        # written is intact, as every file is written atomically
        print("rattlesweep: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of the output went away (``rattlesweep info DIR | head``): nothing to
        # report; stdout is pointed at devnull so that Python's flush at exit stays quiet
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except ValueError as exc:
        print(f"rattlesweep: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that cannot be read or written: the message says which
        print(f"rattlesweep: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:
        # Ctrl-C while a compiled extension loads surfaces as the ImportError it causes
        # (numba's "numba._devicearray failed to import")
        if not _caused_by_interrupt(exc):
            raise
        print("rattlesweep: interrupted", file=sys.stderr)
        return 130


def _caused_by_interrupt(exc: BaseException) -> bool:
    """Whether a KeyboardInterrupt is among the causes of ``exc``."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def run() -> None:
    """The command's entry point: :func:`main`, then exit with its status.

    Ctrl-C anywhere in the command (its imports included: the package loads its heavy
    libraries only once the command runs) ends it with status 130 and one line. The
    process then exits at once, without the interpreter's shutdown, whatever the
    status: a sweep stopped by a second Ctrl-C does not wait for the tiles still
    computing (a kernel call cannot be interrupted, and a tile of long launches may
    take hours; their threads would keep the process alive for results nothing writes
    any more); and the shutdown, a second or two of unloading the numerical libraries,
    restores the default action of SIGINT, so a Ctrl-C then killed a finished command by
    the signal. Once :func:`main` has returned, a Ctrl-C is only noted: the command
    says that it came after the work was complete and exits 130 (the shell's "stopped by
    Ctrl-C"; what it wrote is complete, each file written atomically). Nothing is left
    for the shutdown to do: every file is closed, a sweep's lock released and a cluster
    client closed by then."""
    late: Any = None
    try:
        status = main()
        late = _hold_interrupts()
    except KeyboardInterrupt:  # outside main's own handling (while it reports an error,
        late = late or _hold_interrupts()  # or just after it returned)
        print("rattlesweep: interrupted", file=sys.stderr)
        status = 130
    _flush()
    if late() and status == 0:
        print(
            "rattlesweep: interrupted after the command had finished; what it wrote is "
            "complete",
            file=sys.stderr,
        )
        status = 130
        _flush()
    os._exit(status)


def _hold_interrupts() -> Any:
    """From now on a SIGINT is noted, never raised (a handler that records it, the
    signal blocked in this thread); returns a function that says whether one came."""
    caught: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    return lambda: bool(caught) or signal.SIGINT in signal.sigpending()


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a reader gone, a stream closed: nothing to say
            pass
