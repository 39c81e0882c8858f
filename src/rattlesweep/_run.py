"""Running a prepared batch through the kernel: the call into numba (its compiled
specialisations looked up once), the number of threads, the memory a record needs, and
the friction level the batch's coefficients need."""

from __future__ import annotations

import contextlib
import os
import threading
from typing import Any, Iterator

import numba
import numpy as np
from numba import types

from ._model import Model, Prepared, Raw
from ._pack import unblock
from ._validation import check_boolean
from ._core import stepper
from ._core.jit import on_disk
from ._core.models import RATTLEBACK as RATTLEBACK_MODEL
from ._core.workspace import BLOCK, MU_ROLL, MU_S, MU_SPIN, SLIDING, friction_level

__all__ = [
    "batch_level",
    "check_record_size",
    "contact_slip_velocity",
    "execute",
    "kernels_compiled",
    "numba_threads",
    "physical_memory",
    "run_kernel",
]


_COMPILED: dict[tuple[Any, ...], Any] = {}


# ``kernel`` is a numba dispatcher, typed Any: through the jit.py decorators (partials of
# numba.njit) numba's stubs give a kernel the type of the decorator instead
def run_kernel(kernel: Any, literals: int | tuple[int, ...], *args: Any) -> None:
    """Call a stepper kernel with its literal leading arguments (the model number, and
    for the integrators the friction level). The kernels take them as literals
    (``numba.literally``); called from Python with plain ints, numba would type the call
    afresh every time (milliseconds), so the compiled specialisation is looked up once
    per argument types (compiled for the literals at once, which also spares numba a
    first attempt with plain ints) and called directly (microseconds)."""
    leading = literals if isinstance(literals, tuple) else (literals,)
    key = (kernel, leading, *(numba.typeof(a) for a in args))
    entry = _COMPILED.get(key)
    if entry is None:
        signature = (*(types.literal(value) for value in leading), *key[2:])
        kernel.compile(signature)  # or loads it from the cache
        entry = _COMPILED[key] = kernel.get_overload(signature)
    entry(*leading, *args)


def contact_slip_velocity(model: Model, P: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """(2, n_pad) slip velocity of each lane's launch state, from the kernel's own
    arithmetic (so that a rolling launch starts with u = 0 exactly)."""
    U = np.zeros((P.shape[0], 2, BLOCK))
    run_kernel(stepper.contact_slip_velocity, model.number, P, Y, U)
    return U.transpose(1, 0, 2).reshape(2, -1)


@contextlib.contextmanager
def numba_threads(threads: int | None) -> Iterator[None]:
    """Run the block with numba's thread count set to ``threads`` (None: unchanged)."""
    if threads is None:
        yield
        return
    # numba sets its config attributes from the environment at import, out of mypy's sight
    limit = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    if not (
        isinstance(threads, (int, np.integer))
        and not isinstance(threads, bool)
        and 1 <= threads <= limit
    ):
        raise ValueError(f"threads must be an integer from 1 to {limit}, got {threads!r}")
    old = numba.get_num_threads()
    numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def physical_memory() -> int | None:
    """This machine's memory in bytes, None where the system does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def check_record_size(prep: Prepared, n_rec: int, record_every: int) -> None:
    """Refuse, before any compute, a record that would not fit in this machine's memory,
    naming its size and the arguments that set it."""
    need = n_rec * prep.model.layout.N_REC * prep.P.shape[0] * BLOCK * 8
    have = physical_memory()
    if have is not None and need > have:
        dt = float(prep.coords["dt"][1][0])
        t_end = float(prep.coords["t_end"][1].max())
        lanes = "trajectory" if prep.n == 1 else "trajectories"
        raise ValueError(
            f"the record would need {need / 2**30:.3g} GiB ({n_rec:,} samples of "
            f"{prep.model.layout.N_REC} series for {prep.n:,} {lanes} in blocks of "
            f"{BLOCK}), more than this machine's {have / 2**30:.3g} GiB: t_end / (dt * "
            f"record_every) = {t_end:g} / ({dt:g} * {record_every}) samples each; record "
            f"less often (a larger record_every), or a shorter t_end"
        )


def kernels_compiled(
    parallel: bool = True, model: int = RATTLEBACK_MODEL, level: int = SLIDING
) -> bool:
    """True when the machine code of the kernel entry that :func:`execute` calls
    (``parallel`` or serial) for the model number ``model`` at the friction level
    ``level`` (:func:`friction_level`; the default: Coulomb friction without couples) is
    in numba's on-disk cache: a first call in this process then loads it in about a
    second; otherwise it compiles the kernels first."""
    return on_disk(
        stepper.integrate_parallel if parallel else stepper.integrate_serial, model, level
    )


def batch_level(prep: Prepared) -> int:
    """The friction level the launches of ``prep`` need
    (:func:`._core.workspace.friction_level`)."""
    mu_s, mu_spin, mu_roll = unblock(prep.P[:, [MU_S, MU_SPIN, MU_ROLL]], prep.n)
    return friction_level(mu_s, mu_spin, mu_roll)


_PARALLEL = threading.Lock()
"""Held by a parallel kernel call. numba's ``workqueue`` threading layer (the one it uses
where neither TBB nor OpenMP is available) aborts the interpreter when two threads
launch parallel regions at once; a parallel call already occupies every core, so calls
from several threads take turns at no cost in throughput."""


def execute(
    prep: Prepared,
    *,
    method: int,
    record_every: int | None,
    band: float = 0.0,
    parallel: bool = True,
    threads: int | None = None,
) -> Raw:
    """Run a prepared batch through the kernel."""
    check_boolean("parallel", parallel)
    layout = prep.model.layout
    n_blocks = prep.P.shape[0]
    n_rec = 0
    if record_every is not None and prep.n != 0:
        n_rec = int(prep.nsteps.max()) // record_every + 1
        check_record_size(prep, n_rec, record_every)
    REC = np.empty((n_blocks, n_rec, layout.N_REC, BLOCK))
    O = np.empty((n_blocks, layout.N_OBS, BLOCK))
    Y = prep.Y.copy()
    entry = stepper.integrate_parallel if parallel else stepper.integrate_serial
    with _PARALLEL if parallel else contextlib.nullcontext(), numba_threads(threads):
        run_kernel(
            entry,
            (prep.model.number, batch_level(prep)),
            prep.P,
            Y,
            prep.nsteps,
            method,
            record_every or 1,
            band,
            O,
            REC,
        )
    rec = None
    if n_rec:
        rec = REC.transpose(0, 3, 1, 2).reshape(n_blocks * BLOCK, n_rec, layout.N_REC)[
            : prep.n
        ]
    return Raw(unblock(O, prep.n), rec, unblock(Y, prep.n))
