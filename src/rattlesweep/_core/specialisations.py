"""Every compiled specialisation the library can call, declared beside the friction levels
that bound them, as the jobs that build them.

A kernel is compiled once per combination of its literal arguments, so the set of
machine-code variants is a design decision. It is:

* **the right-hand side** of each model, ``eval_block(W, level, stage, one_lane,
  lane)``: at ``ROLLING`` every stage for whole blocks; at ``SLIDING`` and ``COUPLES``
  the stages the stepper runs with slips possible (start, mid, last), each for whole
  blocks and for one lane (the located path), :data:`RHS_VARIANTS`. A batch at a level
  compiles its own variants and those of the levels below it: a block without
  couples, or in which no lane slips, steps at a lower level.
* **the entry points** of :mod:`.stepper`: ``integrate_serial`` once per model and
  friction level (threads of the caller spread a batch's blocks over cores), and
  ``contact_slip_velocity`` once for the rattleback (the rolling launch's velocity).

:data:`JOBS` lists them in an order that compiles each shared piece once: the
right-hand side variants first (they depend on nothing, so they compile side by side),
then each model's entries from the lowest level up (a level's copy of the stepper reuses
the cached kernels the level below compiled). ``rattlesweep compile`` walks this list in
several processes; a test checks that running a batch at every level compiles exactly
these variants.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from numba import types

from . import stepper
from .jit import on_disk
from .models import MODEL_NAMES, PLANAR, RATTLEBACK
from .planar import dynamics as planar_dynamics
from .rattleback import dynamics as rattleback_dynamics
from .workspace import COUPLES, LEVEL_NAMES, ROLLING, SLIDING, STAGE_4, STAGE_FIRST
from .workspace import STAGE_MID, STAGE_START

__all__ = [
    "ENTRY_SIGNATURE",
    "JOBS",
    "Job",
    "LAUNCH_JOB",
    "LEVELS",
    "RHS_VARIANTS",
    "entry_job",
    "job",
    "rhs_signature",
    "with_what_they_need",
]

LEVELS = (ROLLING, SLIDING, COUPLES)
"""The friction levels, lowest first; each model compiles a copy of the stepper per
level."""

RHS_VARIANTS = {
    ROLLING: tuple(
        (ROLLING, stage, False) for stage in (STAGE_START, STAGE_FIRST, STAGE_MID, STAGE_4)
    ),
    SLIDING: tuple(
        (SLIDING, stage, one)
        for stage in (STAGE_START, STAGE_MID, STAGE_4)
        for one in (False, True)
    ),
    COUPLES: tuple(
        (COUPLES, stage, one)
        for stage in (STAGE_START, STAGE_MID, STAGE_4)
        for one in (False, True)
    ),
}
"""The right-hand side variants (level of the evaluation, stage, one lane) each friction
level adds, the same for both models."""

_A1 = types.Array(types.float64, 1, "C")
_A3 = types.Array(types.float64, 3, "C")

ENTRY_SIGNATURE = (
    _A3,  # P
    _A3,  # Y
    types.Array(types.int64, 2, "C"),  # nsteps
    types.int64,  # method
    types.int64,  # record_every
    types.float64,  # band
    _A3,  # O
    types.Array(types.float64, 4, "C"),  # REC
)
"""The argument types of ``integrate_serial`` after its literal model and level, as the
batch layer passes them."""

_DYNAMICS = {RATTLEBACK: rattleback_dynamics, PLANAR: planar_dynamics}


def rhs_signature(level: int, stage: int, one_lane: bool) -> tuple[Any, ...]:
    """The signature the stepper compiles ``eval_block`` with for one variant."""
    lane = types.int64 if one_lane else types.literal(0)
    return (
        _A1,
        types.literal(level),
        types.literal(stage),
        types.literal(one_lane),
        lane,
    )


@dataclass(frozen=True)
class Job:
    """One specialisation to compile: ``kernel`` at ``signature``, after the jobs named in
    ``after`` (whose cached kernels it reuses). ``typical_s`` is its compile time in
    seconds on one core of a 2-core machine, given what ``after`` left cached: it sizes
    the notice a cold first call gives."""

    name: str
    label: str
    kernel: Any
    signature: tuple[Any, ...]
    after: tuple[str, ...]
    typical_s: float

    def cached(self) -> bool:
        """Whether numba's on-disk cache holds this specialisation, from the current
        sources."""
        return on_disk(self.kernel, self.signature)

    def compile(self) -> None:
        """Compile it into the cache (or load it, when it is there)."""
        self.kernel.compile(self.signature)


_STAGE_NAMES = {
    STAGE_START: "start",
    STAGE_FIRST: "first",
    STAGE_MID: "mid",
    STAGE_4: "last",
}
# measured compile seconds of the jobs on one core of a 2-core machine, given what the
# jobs before them cached: the right-hand side variants (model, level, stage, one lane)
# that take more than 2 s, and each entry (model, level)
_RHS_TYPICAL_S = {
    (RATTLEBACK, ROLLING, STAGE_START, False): 12.0,
    (RATTLEBACK, ROLLING, STAGE_FIRST, False): 3.0,
    (RATTLEBACK, ROLLING, STAGE_MID, False): 3.0,
    (RATTLEBACK, ROLLING, STAGE_4, False): 3.0,
    (RATTLEBACK, SLIDING, STAGE_START, False): 34.0,
    (RATTLEBACK, SLIDING, STAGE_START, True): 18.0,
    (RATTLEBACK, SLIDING, STAGE_MID, False): 3.0,
    (RATTLEBACK, SLIDING, STAGE_4, False): 3.0,
    (RATTLEBACK, COUPLES, STAGE_START, False): 10.0,
    (RATTLEBACK, COUPLES, STAGE_START, True): 9.0,
    (RATTLEBACK, COUPLES, STAGE_MID, False): 3.0,
    (RATTLEBACK, COUPLES, STAGE_4, False): 3.0,
}
_ENTRY_TYPICAL_S = {
    (RATTLEBACK, ROLLING): 24.0,
    (RATTLEBACK, SLIDING): 40.0,
    (RATTLEBACK, COUPLES): 30.0,
    (PLANAR, ROLLING): 15.0,
    (PLANAR, SLIDING): 15.0,
    (PLANAR, COUPLES): 10.0,
}


def _rhs_name(model: int, level: int, stage: int, one_lane: bool) -> str:
    name = f"rhs:{MODEL_NAMES[model]}:{LEVEL_NAMES[level]}:{_STAGE_NAMES[stage]}"
    return name + (":lane" if one_lane else "")


def _rhs_job(model: int, level: int, stage: int, one_lane: bool) -> Job:
    # the variants of a level share the phases' helpers its start stage compiles (its
    # one-lane variants, those of the one-lane start), and a level's start stage those
    # of the level below
    after: tuple[str, ...] = ()
    if stage != STAGE_START:
        after = (_rhs_name(model, level, STAGE_START, one_lane),)
    elif one_lane:
        after = (_rhs_name(model, level, STAGE_START, False),)
    elif level != ROLLING:
        after = (_rhs_name(model, LEVELS[LEVELS.index(level) - 1], STAGE_START, False),)
    typical = _RHS_TYPICAL_S.get((model, level, stage, one_lane), 2.0)
    return Job(
        name=_rhs_name(model, level, stage, one_lane),
        label=(
            f"{MODEL_NAMES[model]} right-hand side, {LEVEL_NAMES[level]}, "
            f"{_STAGE_NAMES[stage]} stage{', one lane' if one_lane else ''}"
        ),
        kernel=_DYNAMICS[model].eval_block,
        signature=rhs_signature(level, stage, one_lane),
        after=after,
        typical_s=typical,
    )


_LEVEL_WORDS = {
    ROLLING: "with rolling contact",
    SLIDING: "with Coulomb friction",
    COUPLES: "with Coulomb, spin and rolling friction",
}


def entry_job(model: int, level: int) -> str:
    """The name of the job that compiles the stepper of ``model`` at ``level``."""
    return f"entry:{MODEL_NAMES[model]}:{LEVEL_NAMES[level]}"


def _entry_job(model: int, level: int) -> Job:
    below = LEVELS[: LEVELS.index(level) + 1]
    rhs = tuple(
        _rhs_job(model, *variant).name for lower in below for variant in RHS_VARIANTS[lower]
    )
    lower_entry = (entry_job(model, below[-2]),) if len(below) > 1 else ()
    return Job(
        name=entry_job(model, level),
        label=f"{MODEL_NAMES[model]} launches {_LEVEL_WORDS[level]}",
        kernel=stepper.integrate_serial,
        signature=(types.literal(model), types.literal(level), *ENTRY_SIGNATURE),
        after=rhs + lower_entry,
        typical_s=_ENTRY_TYPICAL_S[(model, level)],
    )


LAUNCH_JOB = "launch:rattleback"
"""The job of the rattleback's rolling launch velocity (``contact_slip_velocity``)."""


def _jobs() -> tuple[Job, ...]:
    rhs = [
        _rhs_job(model, *variant)
        for model in (RATTLEBACK, PLANAR)
        for level in LEVELS
        for variant in RHS_VARIANTS[level]
    ]
    entries = [
        _entry_job(model, level) for model in (RATTLEBACK, PLANAR) for level in LEVELS
    ]
    launch = Job(
        name=LAUNCH_JOB,
        label="rattleback launch velocities (rolling)",
        kernel=stepper.contact_slip_velocity,
        signature=(types.literal(RATTLEBACK), _A3, _A3, _A3),
        after=(entry_job(RATTLEBACK, ROLLING),),
        typical_s=3.0,
    )
    return (*rhs, *entries, launch)


JOBS = _jobs()
"""Every specialisation the library calls, each after the jobs it reuses."""

_BY_NAME = {j.name: j for j in JOBS}


def job(name: str) -> Job:
    """The job named ``name``."""
    return _BY_NAME[name]


def with_what_they_need(names: list[str]) -> tuple[Job, ...]:
    """The jobs named and those they wait for, directly or not, in :data:`JOBS` order."""
    needed: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name not in needed:
            needed.add(name)
            todo.extend(_BY_NAME[name].after)
    return tuple(j for j in JOBS if j.name in needed)
