"""A plain-text progress bar for tiles: tiles done, trajectories per second, ETA."""

from __future__ import annotations

import sys
import time
from typing import Any, Callable, Mapping, TextIO

from ..._cold_start import compile_seconds

__all__ = ["Progress"]


class Progress:
    """Report finished tiles to ``stream``: redrawn in place on a terminal, otherwise a line
    every ``every`` seconds at most (and at the end); a tile counted within ``every`` of
    the last line is shown by :meth:`tick`, which the runner calls while it waits.

    The rate and ETA leave out the time this process spends compiling kernels
    (``compile_clock`` gives the seconds compiled so far), which would otherwise
    inflate the ETA many times over, and the closing line gives it apart.
    ``compiling`` says that the first tiles compile the kernels elsewhere (on a
    cluster's workers, out of this clock's sight): the bar says so, and the rate and ETA
    leave out the time to the first finished tile."""

    def __init__(
        self,
        total_tiles: int,
        total_points: int,
        done_tiles: int,
        done_points: int,
        *,
        stream: TextIO | None = None,
        enabled: bool = True,
        every: float = 10.0,
        compiling: bool = False,
        compile_clock: Callable[[], float] = compile_seconds,
    ) -> None:
        self.total_tiles, self.total_points = total_tiles, total_points
        self.done_tiles, self.done_points = done_tiles, done_points
        self.reused = done_tiles
        self.new_points = 0
        self.new_steps = 0
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.every = every
        self.t0 = time.perf_counter()
        self._rate_t0, self._rate_points = self.t0, 0  # what the rate is measured over
        self._clock = compile_clock
        self._compiled_t0 = compile_clock()
        self._compiling = compiling and done_tiles < total_tiles
        self._last = -1e9
        self._shown = done_tiles  # the tiles the last line counted
        self._tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        if enabled and done_tiles:
            self._write(
                f"resuming: {done_tiles} of {_count(total_tiles, 'tile')} already done\n"
            )
        if enabled and self._compiling:
            self._write(
                "the workers compile the simulation kernels first (first run only: "
                "minutes)...\n"
            )

    def note(self, text: str) -> None:
        """Report something the user must know (even with the bar disabled), on a line
        of its own."""
        self._write(text + "\n")

    @property
    def rate(self) -> float:
        """Trajectories per second computed in this run, compile time left out."""
        elapsed = time.perf_counter() - self._rate_t0 - self.compile_s
        return self._rate_points / elapsed if elapsed > 0 else 0.0

    @property
    def compile_s(self) -> float:
        """Seconds this process has compiled kernels since the bar began."""
        return self._clock() - self._compiled_t0

    def update(self, summary: Mapping[str, Any]) -> None:
        """Count a tile just written (``summary``: its points ``n``, ``steps``)."""
        self.done_tiles += 1
        self.done_points += summary["n"]
        self.new_points += summary["n"]
        self.new_steps += summary.get("steps", 0)
        now = time.perf_counter()
        if self._compiling:  # the kernels are compiled now: measure the rate from here
            self._compiling = False
            self._rate_t0 = now
        else:
            self._rate_points += summary["n"]
        self._show(now)

    def tick(self) -> None:
        """Show the tiles counted since the last line, once ``every`` seconds have passed
        since it (without this, a tile held back by ``every`` would wait for the next
        tile to finish, possibly long after it was written)."""
        if self.done_tiles != self._shown:
            self._show(time.perf_counter())

    def _show(self, now: float) -> None:
        if self.enabled and (
            self._tty
            or now - self._last >= self.every
            or self.done_tiles == self.total_tiles
        ):
            self._last, self._shown = now, self.done_tiles
            self._write(self.line() + ("\r" if self._tty else "\n"))

    def line(self) -> str:
        frac = self.done_tiles / self.total_tiles if self.total_tiles else 1.0
        bar = "#" * int(frac * 24)
        rate = self.rate
        left = self.total_points - self.done_points
        eta = _clock(left / rate) if rate > 0 else "?"
        return (
            f"[{bar:<24}] {self.done_tiles}/{_count(self.total_tiles, 'tile')}  "
            f"{rate:,.0f} traj/s  ETA {eta}"
        )

    def close(self, message: str = "") -> None:
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.t0
        end = "\n" if self._tty and self.done_tiles > self.reused else ""
        compiled = self.compile_s
        apart = f", and {compiled:.1f} s compiling the kernels" if compiled >= 0.05 else ""
        computed = self.done_tiles - self.reused
        work = (
            f"{self.new_points:,} trajectories in {elapsed - compiled:.1f} s "
            f"({self.rate:,.0f} traj/s){apart}"
            if computed
            else "nothing to compute"
        )
        self._write(
            f"{end}{message or 'done'}: {_count(computed, 'tile')} computed, "
            f"{self.reused} reused, {work}\n"
        )

    def interrupted(self) -> None:
        """Close on Ctrl-C: end the bar's line on a terminal, and say nothing more (the
        caller's message says what is kept)."""
        if self.enabled and self._tty and self.done_tiles > self.reused:
            self._write("\n")

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()


def _clock(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def _count(n: int, noun: str) -> str:
    """``1 tile``, ``2 tiles``."""
    return f"{n:,} {noun}{'' if n == 1 else 's'}"
