"""Running a prepared batch through the kernel: the call into numba (its compiled
specialisations looked up once), the number of threads, the memory a record needs, and
the friction level the batch's coefficients need."""

from __future__ import annotations

import threading
from typing import Any

import numba
import numpy as np
from numba import types

from ._model import Model, Prepared, Raw
from ._validation import check_boolean, memory_left
from ._cold_start import announce, compiling
from ._core import specialisations, stepper
from ._core.jit import on_disk
from ._core.models import RATTLEBACK as RATTLEBACK_MODEL
from ._core.workspace import BLOCK, MU_ROLL, MU_S, MU_SPIN, SLIDING, friction_level

__all__ = [
    "announce_compile",
    "batch_level",
    "check_record_size",
    "contact_slip_velocity",
    "execute",
    "kernels_compiled",
    "worker_count",
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
        if on_disk(kernel, signature):
            kernel.compile(signature)  # loads it
        else:
            with compiling(_job_of(kernel, leading)):
                kernel.compile(signature)
        entry = _COMPILED[key] = kernel.get_overload(signature)
    entry(*leading, *args)


def _job_of(kernel: Any, leading: tuple[int, ...]) -> str | None:
    """The name of the job of :data:`._core.specialisations.JOBS` that compiles
    ``kernel`` at the literals ``leading``; None for a kernel outside them."""
    if kernel is stepper.integrate_serial:
        return specialisations.entry_job(*leading)
    if kernel is stepper.contact_slip_velocity:
        return specialisations.LAUNCH_JOB
    return None


def contact_slip_velocity(model: Model, P: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """(2, n_pad) slip velocity of each lane's launch state, from the kernel's own
    arithmetic (so that a rolling launch starts with u = 0 exactly)."""
    U = np.zeros((P.shape[0], 2, BLOCK))
    run_kernel(stepper.contact_slip_velocity, model.number, P, Y, U)
    return U.transpose(1, 0, 2).reshape(2, -1)


def worker_count(threads: int | None) -> int:
    """The threads a parallel batch runs on: ``threads``, or numba's thread count (every
    core unless ``NUMBA_NUM_THREADS`` or ``numba.set_num_threads`` says fewer)."""
    # numba sets its config attributes from the environment at import, out of mypy's sight
    limit = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    if threads is None:
        return int(numba.get_num_threads())
    if not (
        isinstance(threads, (int, np.integer))
        and not isinstance(threads, bool)
        and 1 <= threads <= limit
    ):
        raise ValueError(f"threads must be an integer from 1 to {limit}, got {threads!r}")
    return int(threads)


def check_record_size(prep: Prepared, n_rec: int, record_every: int) -> None:
    """Refuse, before any compute, a record that would not fit in the memory this process
    can take now (:func:`._validation.memory_left`), naming its size, what limits it and
    the arguments that set it."""
    need = n_rec * prep.model.layout.N_REC * prep.P.shape[0] * BLOCK * 8
    left = memory_left()
    if left is not None and need > left[0]:
        dt = float(prep.coords["dt"][1][0])
        t_end = float(prep.coords["t_end"][1].max())
        lanes = "trajectory" if prep.n == 1 else "trajectories"
        raise ValueError(
            f"the record would need {need / 2**30:.3g} GiB ({n_rec:,} samples of "
            f"{prep.model.layout.N_REC} series for {prep.n:,} {lanes} in blocks of "
            f"{BLOCK}), more than the {left[0] / 2**30:.3g} GiB of {left[1]}: t_end / "
            f"(dt * record_every) = {t_end:g} / ({dt:g} * {record_every}) samples each; "
            "record less often (a larger record_every), or a shorter t_end"
        )


def kernels_compiled(model: int = RATTLEBACK_MODEL, level: int = SLIDING) -> bool:
    """True when the machine code of the kernel entry that :func:`execute` calls for the
    model number ``model`` at the friction level ``level`` (:func:`friction_level`; the
    default: Coulomb friction without couples) is in numba's on-disk cache: a first call
    in this process then loads it in about a second; otherwise it compiles the kernels
    first."""
    return on_disk(stepper.integrate_serial, (types.literal(model), types.literal(level)))


def announce_compile(prep: Prepared) -> None:
    """Say, once per process, that running ``prep`` compiles kernels, when it does
    (:func:`._cold_start.announce`)."""
    names = [specialisations.entry_job(prep.model.number, batch_level(prep))]
    if prep.model.number == RATTLEBACK_MODEL:
        names.append(specialisations.LAUNCH_JOB)
    announce(names)


def batch_level(prep: Prepared) -> int:
    """The friction level the launches of ``prep`` need
    (:func:`._core.workspace.friction_level`)."""
    mu_s, mu_spin, mu_roll = prep.per_trajectory(prep.P[:, [MU_S, MU_SPIN, MU_ROLL]])
    return friction_level(mu_s, mu_spin, mu_roll)


_CHUNKS_PER_WORKER = 8
"""A parallel batch is cut into about this many pieces per thread, so that threads whose
launches end early take more pieces (launches that stop at a reversal end unevenly), and
a Ctrl-C waits for one piece per thread rather than the whole batch."""
_MAX_CHUNK = 64  # blocks: a piece of a large batch stays a fraction of a second or so


def _integrate(
    literals: tuple[int, int], blocked: tuple[np.ndarray, ...], scalars: tuple, workers: int
) -> None:
    """Run ``stepper.integrate_serial`` over the blocks of ``blocked`` (P, Y, nsteps, O,
    REC, each with a leading block axis), on ``workers`` threads taking pieces of
    consecutive blocks in turn; each block is stepped by the same machine code whatever
    thread or piece it falls in, so results do not depend on ``workers``. A Ctrl-C (or
    an error) stops the threads from starting new pieces and waits for the running ones,
    which write only their own blocks."""
    P, Y, nsteps, O, REC = blocked
    method, record_every, band = scalars

    def run(a: int, b: int) -> None:
        run_kernel(
            stepper.integrate_serial,
            literals,
            P[a:b],
            Y[a:b],
            nsteps[a:b],
            method,
            record_every,
            band,
            O[a:b],
            REC[a:b],
        )

    n_blocks = P.shape[0]
    if workers <= 1 or n_blocks <= 1:
        run(0, n_blocks)
        return
    run(0, 0)  # compiles (or loads) the entry once, on this thread, before the workers
    chunk = min(_MAX_CHUNK, max(1, -(-n_blocks // (workers * _CHUNKS_PER_WORKER))))
    pieces = iter(range(0, n_blocks, chunk))
    take = threading.Lock()
    stop = threading.Event()
    errors: list[BaseException] = []

    def work() -> None:
        while not stop.is_set():
            with take:
                a = next(pieces, None)
            if a is None:
                return
            try:
                run(a, a + chunk)
            except BaseException as error:  # re-raised on the calling thread
                errors.append(error)
                stop.set()

    pool = [
        threading.Thread(target=work, name=f"rattlesweep-batch-{i}", daemon=True)
        for i in range(min(workers, -(-n_blocks // chunk)))
    ]
    for thread in pool:
        thread.start()
    try:
        for thread in pool:
            thread.join()
    except BaseException:
        stop.set()
        for thread in pool:
            thread.join()
        raise
    if errors:
        raise errors[0]


def execute(
    prep: Prepared,
    *,
    method: int,
    record_every: int | None,
    band: float = 0.0,
    parallel: bool = True,
    threads: int | None = None,
    columns: slice | None = None,
) -> Raw:
    """Run a prepared batch through the kernel. With ``columns``, the records hold only
    those columns of the record layout (a caller reading two series out of all of them
    is spared reordering the rest)."""
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
    announce_compile(prep)
    _integrate(
        (prep.model.number, batch_level(prep)),
        (prep.P, Y, prep.nsteps, O, REC),
        (method, record_every or 1, band),
        worker_count(threads) if parallel else 1,
    )
    rec = None
    if n_rec:
        kept = REC if columns is None else REC[:, :, columns, :]
        lanes = kept.transpose(0, 3, 1, 2).reshape(n_blocks * BLOCK, n_rec, kept.shape[2])
        rec = lanes[: prep.n] if prep.lanes is None else lanes[prep.lanes]
    return Raw(prep.per_trajectory(O), rec, prep.per_trajectory(Y))
