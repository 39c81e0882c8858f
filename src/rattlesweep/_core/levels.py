"""The friction levels of the stepper: which right-hand side variant each evaluation
runs, and the switching a level needs, chosen while typing from the literal level of
the entry point (:data:`.workspace.ROLLING`, ``SLIDING``, ``COUPLES``), so that a copy of
the stepper compiles the variants up to its level and nothing above it.

The level an evaluation runs at (``slipping``) is decided at run time, per block and
step: ``COUPLES`` for a block with spin or rolling friction, ``SLIDING`` where some lane
still stepped slips, else ``ROLLING``; it is never above the literal ``level``.
"""

from __future__ import annotations

import numba
from numba import types
from numba.core.errors import TypingError
from numba.extending import overload

from . import models
from .events import locate_where_located, switch_marked
from .jit import OVERLOAD_OPTIONS, kernel
from .stages import set_mid_stage
from .switching import (
    LOCATED_STOP_HORIZON,
    STOP_HORIZON,
    any_slipping,
    flag_switches,
    keep_directions,
)
from .workspace import (
    COUPLES,
    ROLLING,
    SLIDING,
    STAGE_4,
    STAGE_FIRST,
    STAGE_MID,
    STAGE_START,
)

__all__ = ["evaluate_state", "inner_stages", "rk4_step", "switch_modes"]


def _literal(value, what):
    if not isinstance(value, types.IntegerLiteral):
        raise TypingError(f"the {what} must be a literal integer (numba.literally)")
    return value.literal_value


def evaluate_state(W, model, level, slipping, forces):
    """First RK stage at the step-start state, with the normal force in region X and,
    when ``forces`` or ``slipping``, the friction force and slip velocity too.
    ``slipping``, the friction level of the evaluation decided at run time, is
    ``COUPLES`` for a block with spin or rolling friction, else ``ROLLING`` only when no
    lane that is still stepped slips; ``level`` (a literal) is the highest it can be: only
    the variants of the right-hand side up to it are compiled."""


@overload(evaluate_state, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _evaluate_state(W, model, level, slipping, forces):
    top = _literal(level, "friction level")

    # each level handles its own variant and leaves the rest to the level below, by the
    # same overload at that level's literal
    def rolling(W, model, level, slipping, forces):
        if forces:
            models.evaluate(W, model, ROLLING, STAGE_START, False, 0)
        else:
            models.evaluate(W, model, ROLLING, STAGE_FIRST, False, 0)

    def sliding(W, model, level, slipping, forces):
        if slipping != ROLLING:
            models.evaluate(W, model, SLIDING, STAGE_START, False, 0)
            keep_directions(W)
        else:
            evaluate_state(W, model, ROLLING, slipping, forces)

    def couples(W, model, level, slipping, forces):
        if slipping == COUPLES:
            models.evaluate(W, model, COUPLES, STAGE_START, False, 0)
            keep_directions(W)
        else:
            evaluate_state(W, model, SLIDING, slipping, forces)

    return (rolling, sliding, couples)[top]


def rk4_step(W, model, level, slipping):
    """The three inner stages of classic RK4 (the first ran in :func:`evaluate_state`),
    leaving the new state in region Y and the old one in region B, at the friction
    level ``slipping`` (``ROLLING``: every lane sticks, no slip-only work), at most the
    literal ``level``."""


@overload(rk4_step, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _rk4_step(W, model, level, slipping):
    top = _literal(level, "friction level")

    def rolling(W, model, level, slipping):
        inner_stages(W, model, ROLLING)

    def sliding(W, model, level, slipping):
        if slipping != ROLLING:
            inner_stages(W, model, SLIDING)
        else:
            rk4_step(W, model, ROLLING, slipping)

    def couples(W, model, level, slipping):
        if slipping == COUPLES:
            inner_stages(W, model, COUPLES)
        else:
            rk4_step(W, model, SLIDING, slipping)

    return (rolling, sliding, couples)[top]


@kernel
def inner_stages(W, model, slipping):
    """The second, third and fourth stages of RK4 at the friction level ``slipping`` (a
    literal). The second and third share one compiled variant of the right-hand side."""
    numba.literally(model)
    numba.literally(slipping)
    set_mid_stage(W, False, False, 0)
    models.evaluate(W, model, slipping, STAGE_MID, False, 0)
    set_mid_stage(W, True, False, 0)
    models.evaluate(W, model, slipping, STAGE_MID, False, 0)
    models.evaluate(W, model, slipping, STAGE_4, False, 0)


@kernel
def _switch_modes(W, model, level, buf, couples, can_slip, locating, slipping):
    """Change the contact modes of the lanes whose mode changed over the last step (none
    when no lane ``can_slip``): with ``locating``, each redoes its last step with the
    switch located; otherwise the mode changes at the step start, and the block is
    evaluated again. Returns the friction level of the next step's evaluations."""
    numba.literally(model)
    numba.literally(level)
    if not can_slip:
        return slipping
    if locating:
        if flag_switches(W, True, LOCATED_STOP_HORIZON, couples) > 0:
            locate_where_located(W, model, level, buf)
    elif flag_switches(W, True, STOP_HORIZON, couples) > 0:  # modes change now
        again = COUPLES if couples else SLIDING
        switch_marked(W, model)
        evaluate_state(W, model, level, again, True)
        # re-stuck outside the cone, or a couple stuck beyond its bound
        if flag_switches(W, False, STOP_HORIZON, couples) > 0:
            switch_marked(W, model)
            evaluate_state(W, model, level, again, True)
    return COUPLES if couples else (SLIDING if any_slipping(W) else ROLLING)


def switch_modes(W, model, level, buf, couples, can_slip, locating, slipping):
    """:func:`_switch_modes` at a friction level (a literal) where lanes can slip; at
    ``ROLLING`` nothing, and none of the switching is compiled."""


@overload(switch_modes, prefer_literal=True, jit_options=OVERLOAD_OPTIONS)
def _switch_modes_at(W, model, level, buf, couples, can_slip, locating, slipping):
    if _literal(level, "friction level") == ROLLING:
        return lambda W, model, level, buf, couples, can_slip, locating, slipping: slipping
    return lambda W, model, level, buf, couples, can_slip, locating, slipping: (
        _switch_modes(W, model, level, buf, couples, can_slip, locating, slipping)
    )
