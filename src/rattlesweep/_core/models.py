"""The one place that knows every model: the hooks the shared stepper calls, each chosen
at compile time from the literal model number.

The stepper's kernels take the model as a literal integer argument (:data:`RATTLEBACK`
or :data:`PLANAR`, ``numba.literally``), so each model gets its own compiled copy of
the one stepper source. The functions below are numba overloads that pick the model's
implementation while typing: only the chosen model's code is compiled into a copy (an
``if model == ...`` inside a kernel would compile both branches), and the call inlines
as a direct call. Each hook's contract is its stub's docstring; each model implements
it in its ``model`` and ``dynamics`` modules.
"""

from __future__ import annotations

from numba import types
from numba.core.errors import TypingError
from numba.extending import overload

from .jit import OVERLOAD_OPTIONS
from .planar import dynamics as planar_dynamics
from .planar import layout as planar_layout
from .planar import model as planar_model
from .rattleback import dynamics as rattleback_dynamics
from .rattleback import layout as rattleback_layout
from .rattleback import model as rattleback_model

__all__ = ["MODEL_NAMES", "PLANAR", "RATTLEBACK"]

RATTLEBACK = 0
PLANAR = 1
MODEL_NAMES = ("rattleback", "planar")


def _pick(model, rattleback, planar):
    if not isinstance(model, types.IntegerLiteral):
        raise TypingError("the model must be a literal integer (numba.literally)")
    if model.literal_value == RATTLEBACK:
        return rattleback
    if model.literal_value == PLANAR:
        return planar
    raise TypingError(f"unknown model {model.literal_value}")


def _hook(stub, inline="never"):
    """Register ``stub`` as an overloaded hook; its typer is the decorated function."""
    return lambda typer: overload(
        stub, prefer_literal=True, inline=inline, jit_options=OVERLOAD_OPTIONS
    )(typer)


# --- layout constants -------------------------------------------------------------------
def state_regions(model):
    """(OFF_Y, OFF_T, OFF_A, OFF_B, N_STATE, N_WORK) of the model's workspace."""


@_hook(state_regions, inline="always")
def _state_regions(model):
    rb, pl = rattleback_layout, planar_layout
    return _pick(
        model,
        lambda model: (rb.OFF_Y, rb.OFF_T, rb.OFF_A, rb.OFF_B, rb.N_STATE, rb.N_WORK),
        lambda model: (pl.OFF_Y, pl.OFF_T, pl.OFF_A, pl.OFF_B, pl.N_STATE, pl.N_WORK),
    )


def locates_switches(model):
    """True when the model's RK4 steps locate stick/slip switches inside the step
    (:mod:`.events`); False when its modes change at step starts. A plain function of
    the model number, for typing time."""
    return {
        RATTLEBACK: rattleback_model.LOCATES_SWITCHES,
        PLANAR: planar_model.LOCATES_SWITCHES,
    }[model]


# --- the right-hand side and the Euler step -------------------------------------------
def evaluate(W, model, slip_possible, stage, one_lane, lane):
    """The right-hand side of every lane (or, when ``one_lane``, of lane ``lane`` alone)
    used as ``stage`` asks (:mod:`.stages`), with the contact outputs (region X) at the
    first stages. The flags are literals; ``slip_possible=False`` promises that every
    lane sticks."""


@_hook(evaluate)
def _evaluate(W, model, slip_possible, stage, one_lane, lane):
    return _pick(
        model,
        lambda W, model, slip_possible, stage, one_lane, lane: (
            rattleback_dynamics.eval_block(W, slip_possible, stage, one_lane, lane)
        ),
        lambda W, model, slip_possible, stage, one_lane, lane: planar_dynamics.eval_block(
            W, slip_possible, stage, one_lane, lane
        ),
    )


def euler_step(W, model):
    """Semi-implicit Euler from region Y with the derivative in A, in place; the old
    state left in B."""


@_hook(euler_step)
def _euler_step(W, model):
    return _pick(
        model,
        lambda W, model: rattleback_model.euler_step(W),
        lambda W, model: planar_model.euler_step(W),
    )


# --- per-lane hooks: stub(W, model, j) calls the model's fn(W, j) -----------------------
def _lane_hook(stub, rattleback, planar, inline="never"):
    def typer(W, model, j):
        return _pick(
            model, lambda W, model, j: rattleback(W, j), lambda W, model, j: planar(W, j)
        )

    _hook(stub, inline)(typer)


def derive(W, model, j):
    """Fill lane j's derived parameters from its parameters."""


def start_lane(W, model, j):
    """Prepare a finite launch state; True when it starts capsized."""


def check_step(W, model, j):
    """(non-finite, capsized) of lane j's new state, after any renormalisation."""


def spin_and_watch(W, model, j):
    """(spin about the vertical (rad/s), 0 where there is none; the watched quantity,
    whose smallest value is an observable) of lane j's state."""


def heading(W, model, j):
    """(X, Y) world components of the long (body x) axis of lane j's state Y, whose
    direction seen from above is the heading; (1, 0) where the model has none."""


def energy(W, model, j):
    """Mechanical energy of lane j's state, J."""


def roll_start(W, model, j):
    """Set the velocity of lane j so that its contact point is at rest."""


def stick_impulse(W, model, j):
    """Apply the plastic impulse that stops lane j's slipping contact point; returns its
    horizontal components (N s)."""


def park(W, model, j):
    """Give a lane that is no longer stepped a harmless state."""


def couple_rates(W, model, j):
    """(spin about the contact normal, rate the rolling couple opposes: the planar
    rocking rate, |ω_h| in 3-D) of lane j's state, rad/s."""


def stick_couples(W, model, j):
    """Lane j's couples have just switched: apply what a couple that now sticks needs."""


_lane_hook(derive, rattleback_model.derive, planar_model.derive)
_lane_hook(start_lane, rattleback_model.start_lane, planar_model.start_lane)
_lane_hook(check_step, rattleback_model.check_step, planar_model.check_step, "always")
_lane_hook(
    spin_and_watch, rattleback_model.spin_and_watch, planar_model.spin_and_watch, "always"
)
_lane_hook(heading, rattleback_model.heading, planar_model.heading, "always")
_lane_hook(energy, rattleback_model.energy, planar_model.energy)
_lane_hook(roll_start, rattleback_model.roll_start, planar_model.roll_start)
_lane_hook(stick_impulse, rattleback_model.stick_impulse, planar_model.stick_impulse)
_lane_hook(park, rattleback_model.park, planar_model.park)
_lane_hook(couple_rates, rattleback_model.couple_rates, planar_model.couple_rates)
_lane_hook(stick_couples, rattleback_model.stick_couples, planar_model.stick_couples)


# --- hooks with more arguments --------------------------------------------------------
def separation(W, model, j, k):
    """Distance between the states of lanes j and k in the model's phase-space metric
    (dimensionless), from lane j's parameters (:mod:`.lyapunov`)."""


@_hook(separation)
def _separation(W, model, j, k):
    return _pick(
        model,
        lambda W, model, j, k: rattleback_model.separation(W, j, k),
        lambda W, model, j, k: planar_model.separation(W, j, k),
    )


def finish(W, model, j, O, launched):
    """Write the model's own observables of lane j into O."""


@_hook(finish)
def _finish(W, model, j, O, launched):
    return _pick(
        model,
        lambda W, model, j, O, launched: rattleback_model.finish(W, j, O, launched),
        lambda W, model, j, O, launched: planar_model.finish(W, j, O, launched),
    )


def record(W, model, j, out):
    """Write lane j's recorded series into out."""


@_hook(record)
def _record(W, model, j, out):
    return _pick(
        model,
        lambda W, model, j, out: rattleback_model.record(W, j, out),
        lambda W, model, j, out: planar_model.record(W, j, out),
    )
