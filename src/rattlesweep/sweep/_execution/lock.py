"""A lock file that keeps two sweeps out of one output: the first to create it holds it;
another sweep started into the same output meanwhile is refused with the holder named.

The file records the holder's host, process id and process start time. A lock left by a
process that no longer runs on this host (killed, crashed, or its id since reused by
another program) is stale and taken over. A lock held on another host cannot be checked
from here; the refusal says which file to remove once that process is known to be gone.
"""

from __future__ import annotations

import datetime
import json
import os
import socket
import sys
from pathlib import Path
from typing import Any

__all__ = ["LOCK_NAME", "SweepLock", "SweepLocked"]

LOCK_NAME = ".rattlesweep.lock"


class SweepLocked(ValueError):
    """Raised when another running sweep holds the output's lock."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so


def _start_time(pid: int) -> str | None:
    """The start time of a process (clock ticks since boot, Linux), None where unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # the command name (field 2) is in parentheses and may hold spaces
    return stat[stat.rindex(")") + 2 :].split()[19]


def _running(pid: int, started: str | None) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        pass
    now = _start_time(pid)
    return started is None or now is None or now == started


class SweepLock:
    """The lock file ``path`` of an output: :meth:`acquire` creates it, :meth:`release`
    removes it. A sweep directory's is ``DIR/.rattlesweep.lock``; a local zarr store's
    lies beside it, ``STORE.lock`` (zarr warns about foreign files inside a store)."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.held = False

    def _describe(self) -> dict[str, Any]:
        return {
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "started": _start_time(os.getpid()),
            "since": datetime.datetime.now().isoformat(timespec="seconds"),
            "command": " ".join(sys.argv),
        }

    def _create(self) -> bool:
        # written in full under a private name, then linked into place: the link fails
        # when the lock exists, and a lock is never seen half-written
        tmp = self.path.with_name(f"{self.path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(self._describe()))
        try:
            os.link(tmp, self.path)
        except FileExistsError:
            return False
        finally:
            tmp.unlink(missing_ok=True)
        return True

    def _holder(self) -> tuple[dict[str, Any] | None, str]:
        try:
            text = self.path.read_text()
        except FileNotFoundError:
            return None, ""
        try:
            holder = json.loads(text)
            if not isinstance(holder, dict):
                raise ValueError
            return holder, text
        except ValueError:
            return {}, text  # not a lock this module wrote

    def acquire(self) -> "SweepLock":
        """Take the lock, taking over a stale one; SweepLocked when a running sweep holds
        it."""
        for _ in range(3):
            # held before the link, so that an interrupt just after it still releases
            # it (release removes only a lock this process wrote)
            self.held = True
            if self._create():
                return self
            self.held = False
            holder, text = self._holder()
            if holder is None:
                continue  # released meanwhile
            if holder and not self._stale(holder):
                raise SweepLocked(self._refusal(holder))
            # move the stale file aside; if another process replaced it meanwhile, the
            # file moved is not the one read, and goes back
            aside = self.path.with_name(f"{self.path.name}.stale.{os.getpid()}")
            try:
                os.rename(self.path, aside)
            except FileNotFoundError:
                continue
            if aside.read_text() != text:
                os.rename(aside, self.path)
                continue
            aside.unlink()
        raise SweepLocked(
            f"cannot take the lock {self.path}: other processes keep taking it"
        )

    def _stale(self, holder: dict[str, Any]) -> bool:
        if holder.get("host") != socket.gethostname():
            return False
        try:
            pid = int(holder["pid"])
        except (KeyError, TypeError, ValueError):
            return True
        return not _running(pid, holder.get("started"))

    def in_use(self) -> str | None:
        """Who holds the lock, when a sweep that is running does (the process, its host,
        since when and its command); None when nobody does or its holder is gone."""
        holder, _ = self._holder()
        if not holder or self._stale(holder):
            return None
        return self._who(holder)

    def _who(self, holder: dict[str, Any]) -> str:
        here = holder.get("host") == socket.gethostname()
        return (
            f"process {holder.get('pid')} on {'this host' if here else holder.get('host')}"
            f", since {holder.get('since')} ({holder.get('command', '')})"
        )

    def _refusal(self, holder: dict[str, Any]) -> str:
        where = (
            self.path.parent if self.path.name == LOCK_NAME else self.path.with_suffix("")
        )
        here = holder.get("host") == socket.gethostname()
        who = self._who(holder)
        advice = (
            "wait for it to finish or stop it"
            if here
            else f"if that process is gone, remove {self.path}"
        )
        return f"{where} is in use by another sweep: {who}; {advice}"

    def release(self) -> None:
        """Remove the lock. Where that fails (the filesystem went read-only or away),
        the file stays and the next sweep finds it stale."""
        if self.held:
            self.held = False
            holder, _ = self._holder()
            if not holder or (holder.get("host"), holder.get("pid")) != (
                socket.gethostname(),
                os.getpid(),
            ):
                return  # not written (an interrupt before the link), or not ours
            try:
                self.path.unlink(missing_ok=True)
            except OSError:
                pass

    def __enter__(self) -> "SweepLock":
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
