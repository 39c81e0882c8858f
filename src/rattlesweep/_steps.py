"""Time steps of a batch: each launch's default step, its step count, and the warnings
about them (a step so coarse that results may be artefacts; a batch so long that it
takes minutes or more)."""

from __future__ import annotations

import warnings
from typing import Any, Mapping, Protocol, Sequence

import numpy as np

from ._validation import fail_where

__all__ = [
    "COARSE_DT",
    "LONG_RUN_STEPS",
    "MAX_STEPS",
    "RK4_LIMIT",
    "CoarseStepWarning",
    "LongRunWarning",
    "announce_long_run",
    "default_dts",
    "step_counts",
    "steps_for",
    "time_steps",
    "warn_coarse_dt",
]


class AnyBody(Protocol):
    """What the step layer asks of a body of either model."""

    @property
    def name(self) -> str: ...

    def default_dt(self, g: float = 9.81) -> float: ...


COARSE_DT = 4.0
"""A time step above this many times the body's default draws a
:class:`CoarseStepWarning`."""

RK4_LIMIT = 2.0 * 2.0**0.5 * 64.0 / (2.0 * np.pi)
"""RK4 is unstable for an oscillation of angular frequency ω when ω dt > 2√2: at about
this many times the default step (1/64 of the shortest small-oscillation period)."""


class CoarseStepWarning(RuntimeWarning):
    """A time step so coarse that a result, statuses included, may be a numerical
    artefact."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so


def default_dts(table: Sequence[AnyBody], index: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Each trajectory's default time step (s), computed once per distinct (body, g)."""
    keys, inverse = np.unique(
        np.stack([index.astype(float), g]), axis=1, return_inverse=True
    )
    per_key = np.array([table[int(i)].default_dt(float(gv)) for i, gv in keys.T])
    return per_key[inverse.reshape(-1)]


def warn_coarse_dt(
    table: Sequence[AnyBody],
    index: np.ndarray,
    g: np.ndarray,
    dt: np.ndarray,
    stacklevel: int,
    default: np.ndarray | None = None,
) -> None:
    """Warn when a given time step exceeds COARSE_DT times the default of its
    trajectory (``default``, or its body's at its g), naming the worst trajectory's
    body, its default and RK4's stability limit; ``stacklevel`` as for
    :func:`warnings.warn`, counted from the caller."""
    if dt.size == 0:
        return
    body_default = default_dts(table, index, g)
    default = body_default if default is None else default
    worst = int(np.argmax(dt / default))
    ratio = dt[worst] / default[worst]
    why = (
        "1/64 of its shortest small-oscillation period"
        if default[worst] == body_default[worst]
        else "the longest that follows its damping, smallest principal moment / damping"
    )
    if ratio > COARSE_DT:
        warnings.warn(
            f"dt = {dt[worst]:.3g} s is {ratio:.3g} times the default step of body "
            f"{table[index[worst]].name!r} ({default[worst]:.3g} s, {why}): RK4 loses "
            f"accuracy beyond a few times the default "
            f"and is unstable from about {RK4_LIMIT:.0f} times it (semi-implicit Euler "
            f"sooner); statuses such as capsized or lifted_off of such a run may be "
            f"numerical artefacts",
            CoarseStepWarning,
            stacklevel=stacklevel + 1,
        )


LONG_RUN_STEPS = 10**9
"""Steps in a batch (over all its launches) beyond which :func:`announce_long_run` warns
before the run: at about 10**6 steps per second on a core, a quarter of an hour of one
core or more."""


class LongRunWarning(UserWarning):
    """A batch about to take a very large number of steps (minutes or more)."""

    __module__ = "rattlesweep"  # where users import it from: tracebacks and pickles say so


def announce_long_run(
    steps: np.ndarray,
    t_end: np.ndarray,
    dt: np.ndarray,
    default_from: Mapping[str, np.ndarray] | None,
    stacklevel: int,
) -> None:
    """Warn before a batch of more than LONG_RUN_STEPS steps, with the count, the
    longest launch's t_end and dt, and the inputs a default dt came from."""
    total = float(np.sum(steps, dtype=float))
    if total <= LONG_RUN_STEPS:
        return
    i = int(np.argmax(steps))
    source = (
        ""
        if default_from is None
        else " (the body's default step at "
        + ", ".join(f"{k} = {float(v.flat[i]):g}" for k, v in default_from.items())
        + ")"
    )
    warnings.warn(
        f"this batch takes up to {total:.3g} steps in all ({len(steps):,} "
        f"launch{'es' if len(steps) != 1 else ''}; the longest "
        f"t_end = {float(t_end.flat[i]):g} s / dt = {float(dt.flat[i]):.3g} s{source} = "
        f"{int(steps.flat[i]):,} steps; fewer where launches end early, at a capsize or "
        f"a stop): at about 1e6 steps per second on a core, up to roughly "
        f"{total / 1e6 / 60:.3g} core-minutes",
        LongRunWarning,
        stacklevel=stacklevel + 1,
    )


MAX_STEPS = 2**53
"""The most steps a trajectory can take: the kernel counts steps in float64, which
counts integers exactly up to 2**53."""


def _show_body(body: Any) -> str:
    """A body for an error message: its name and semi-axes, the parameters its default
    step depends on most."""
    axes = ", ".join(
        f"{k} = {getattr(body, k)!r}" for k in ("a", "b", "c") if hasattr(body, k)
    )
    return f"body = {body.name!r} with {axes} m"


def steps_for(
    t_end: np.ndarray,
    dt: np.ndarray,
    default_from: Mapping[str, np.ndarray] | None = None,
    bodies: tuple[Sequence[AnyBody], np.ndarray] | None = None,
) -> np.ndarray:
    """Steps each trajectory takes: ceil(t_end/dt), at least 1. More than
    :data:`MAX_STEPS` is a ValueError naming ``t_end`` and ``dt``, and, when ``dt`` is
    the default step, the inputs ``default_from`` it was derived from (name -> values)
    and the body, from ``bodies`` (the distinct bodies and each trajectory's index)."""
    steps = np.maximum(np.ceil(t_end / dt * (1.0 - 1e-12)), 1)
    bad = ~(steps <= MAX_STEPS)  # NaN too: a default step that overflowed
    if np.any(bad):
        i = int(np.argmax(bad))
        where = f" at index ({i},)" if steps.size > 1 else ""
        shown = (
            []
            if default_from is None
            else [f"{k} = {float(v.flat[i])!r}" for k, v in default_from.items()]
        )
        if default_from is not None and bodies is not None:
            shown.append(_show_body(bodies[0][int(bodies[1].flat[i])]))
        source = (
            "" if not shown else " (the body's default step at " + ", ".join(shown) + ")"
        )
        raise ValueError(
            f"t_end / dt must be at most 2**53 steps (the kernel counts steps in float64); "
            f"got t_end = {float(t_end.flat[i])!r} s and dt = {float(dt.flat[i])!r} s"
            f"{source}, {float(steps.flat[i]):.3g} steps{where}"
        )
    return steps.astype(np.int64)


def time_steps(
    table: Sequence[AnyBody],
    index: np.ndarray,
    flat: Mapping[str, np.ndarray],
    *,
    longest: tuple[np.ndarray, tuple[str, ...]] | None = None,
    stacklevel: int,
) -> tuple[np.ndarray, dict[str, np.ndarray] | None]:
    """Each launch's time step (s), and the inputs it comes from when it is the default
    (None when ``dt`` is given): the ``dt`` of ``flat`` (the flat inputs) or the body's
    default at its ``g``, shortened where the model's bound ``longest`` (each launch's
    longest step, and the inputs it depends on) is shorter, and to ``t_end`` where
    that is shorter still (0 < t_end). A ``dt`` given is refused
    beyond ``t_end`` (in both models), and draws a :class:`CoarseStepWarning`
    when far beyond the default (``stacklevel`` as for :func:`warnings.warn`, counted
    from the caller)."""
    default = default_dts(table, index, flat["g"])
    depends: tuple[str, ...] = ("g",)
    if longest is not None:
        bound, names = longest
        default = np.minimum(default, bound)
        depends = ("g", *names)
    if "dt" not in flat:
        # a launch shorter than the default step takes one step of its t_end, rather
        # than a whole default step past it
        t_end = flat["t_end"]
        short = (t_end > 0) & (t_end < default)
        return np.where(short, t_end, default), {k: flat[k] for k in depends}
    dt = flat["dt"]
    fail_where(
        "dt",
        dt,
        dt > flat["t_end"],
        "must be at most t_end (a launch takes whole steps, so one step of dt "
        "would run it past t_end)",
    )
    warn_coarse_dt(table, index, flat["g"], dt, stacklevel=stacklevel + 1, default=default)
    return dt, None


def step_counts(
    t_end: np.ndarray,
    dt: np.ndarray,
    default_from: Mapping[str, np.ndarray] | None,
    bodies: tuple[Sequence[AnyBody], np.ndarray],
    *,
    announce: bool,
    stacklevel: int,
) -> np.ndarray:
    """:func:`steps_for` each trajectory, and, when ``announce``, a
    :class:`LongRunWarning` before a batch of more than :data:`LONG_RUN_STEPS` steps
    (``stacklevel`` as for :func:`warnings.warn`, counted from the caller)."""
    steps = steps_for(t_end, dt, default_from, bodies)
    if announce:
        announce_long_run(steps, t_end, dt, default_from, stacklevel=stacklevel + 1)
    return steps
