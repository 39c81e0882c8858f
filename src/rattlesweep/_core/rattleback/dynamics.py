"""Right-hand side of the rattleback with Coulomb stick/slip contact (docs/model.md:
dynamics).

One function, :func:`eval_block`, evaluates the time derivative of every lane of a block
in a few short straight loops over the lanes. The contact mode of each lane (stick or
slip) is an input, held through the stages of a step; stick and slip share one 3×3
solve, with the matrix and right-hand side chosen per lane, so the loops have no
data-dependent branches and LLVM vectorises them across lanes. Only the friction
direction of slow slips (:func:`.slip.slip_direction`) is scalar work, per slipping lane.

The phases live in their own modules: the contact kinematics (:mod:`.contact`), the
friction direction (:mod:`.slip`), the accelerations with the couples
(:mod:`.accelerations`) and the derivative with the friction force (:mod:`.derivative`).
"""

from __future__ import annotations

import numba

from ..jit import kernel
from ..stages import first_stage
from ..workspace import STAGE_FIRST, STAGE_MID, STAGE_START
from .accelerations import accelerations, divide_out
from .contact import contact_kinematics
from .derivative import store_derivative
from .slip import steer
from .layout import (
    OFF_T,
    OFF_Y,
)

__all__ = ["eval_block"]


@kernel
def eval_block(W, slip_possible, stage, one_lane, lane):
    """Time derivative of every lane of a block, plus its contact forces.

    W is the block workspace (see :mod:`.layout`). Reads the parameters (regions P and
    E), the state (region Y in the first stage, the stage state T in the others) and,
    from the switching state (region S), each lane's contact mode and stored slip
    direction. ``stage`` says what becomes of the derivative d, fused with the classic
    RK4 stage arithmetic so that d never goes to memory on its own (Y is the state at
    the start of the step, h the time step):

    * ``STAGE_START``: A = d and T = Y + (h/2) d (but for the position of G, which no
      stage reads: T has none), and the normal force, friction force and slip velocity
      go to region X (the semi-implicit Euler step also starts from A = d);
    * ``STAGE_FIRST``: the same with the normal force as the only output, for steps
      where nothing reads the others;
    * ``STAGE_MID``: A += 2d and T = Y + c d (c = h/2 in the second stage, h in the
      third: :func:`.stages.set_mid_stage`);
    * ``STAGE_4``: Y = Y + (h/6)(A + d), the new state, in place, and B = the old Y,
      for a lane whose step fails or whose contact mode changed inside it. Forces, which
      nobody reads in these inner stages, are not written.

    ``one_lane`` (a literal) restricts the evaluation to lane ``lane``.

    The flags must be literals, so each combination compiles to its own variant;
    ``slip_possible=False`` promises that every lane sticks and drops the slip-only work.
    A lane's derivative is computed by the same operations in every variant, so it does
    not depend on which one ran.

    Stick (material contact point at rest):
        (I + m(|ρ|²𝟙 − ρρᵀ)) ω̇ = −ω × Iω − c_v ω + m ρ × (g n̂ − w)
    Slip (friction −μ_k N û opposite the slip velocity u):
        (I + m k lᵀ) ω̇ = −ω × Iω − c_v ω + N₀ k,  l = ρ × n̂,  k = ρ × (n̂ − μ_k û)
    with w = ω × (ω × ρ + ṡ_P), N₀ = m(g − n̂·w) and, in both modes, N = N₀ − m l·ω̇.
    """
    numba.literally(slip_possible)
    numba.literally(stage)
    numba.literally(one_lane)
    if stage == STAGE_START:
        contact_kinematics(W, True, OFF_Y, one_lane, lane)  # the slip velocity is an output
        if one_lane:
            steer(W, slip_possible, OFF_Y, True, lane, False, 0.0)
        else:  # once per step: measure φ̇*
            steer(W, slip_possible, OFF_Y, False, lane, True, 1.0)
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    elif stage == STAGE_FIRST:
        contact_kinematics(W, slip_possible, OFF_Y, one_lane, lane)
        steer(W, slip_possible, OFF_Y, one_lane, lane, False, 0.0)
        accelerations(W, slip_possible, OFF_Y, one_lane, lane)
    else:
        contact_kinematics(W, slip_possible, OFF_T, one_lane, lane)
        steer(
            W,
            slip_possible,
            OFF_T,
            one_lane,
            lane,
            False,
            0.0 if one_lane else (0.5 if stage == STAGE_MID else 1.0),
        )
        accelerations(W, slip_possible, OFF_T, one_lane, lane)
    if slip_possible or first_stage(stage):
        divide_out(W, True, one_lane, lane)
    else:
        divide_out(W, False, one_lane, lane)  # the normal force, which no lane needs
    store_derivative(W, slip_possible, stage, one_lane, lane)
