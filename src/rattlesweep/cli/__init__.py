"""The ``rattlesweep`` command line: sweeps, resuming, maps, file summaries, single runs
and their animations.

The package loads only the standard library, so that :func:`run` is answering Ctrl-C
before any numerical library loads; each command imports what it needs when it runs.
Its modules: the sweep commands (``_sweeps``), the commands that read results
(``_outputs``), those of one launch or body (``_launches``) and the parser (``_parser``).
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any

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
        return _main(argv)


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
    libraries only once the command runs) ends it with status 130 and one line, and the
    process then exits at once, without the interpreter's shutdown: a sweep stopped by
    a second Ctrl-C does not wait for the tiles still computing (a kernel call cannot be
    interrupted, and a tile of long launches may take hours; their threads would keep
    the process alive for results nothing writes any more), and a library whose import
    the interrupt cut short can turn the shutdown into a death by SIGINT. Every file
    written is complete, as each is written atomically, and the sweep's lock is released
    already."""
    try:
        status = main()
    except KeyboardInterrupt:  # outside main's own handling (while it reports an error)
        print("rattlesweep: interrupted", file=sys.stderr)
        status = 130
    if status == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)
