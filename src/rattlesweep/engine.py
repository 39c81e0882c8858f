"""The batch layer every model shares: inputs broadcast and checked, packed into kernel
blocks and run (:mod:`rattlesweep.results` labels what comes back).

A model is described once by a :class:`Model`: its kernel number, its row tables
(:mod:`rattlesweep.core.rattleback.layout`, :mod:`rattlesweep.core.planar.layout`) and
which observables and series its results carry. The model's own batch module
(:mod:`rattlesweep.batch`, :mod:`rattlesweep.planar.batch`) turns its launch arguments
into flat per-trajectory inputs and a launch state, and hands them here.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import warnings
from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING, Any, Callable, Iterator, Mapping, Sequence

import numba
import numpy as np
from numba import types

from .core import stepper
from .core.jit import on_disk
from .core.rows import Rows
from .core.models import RATTLEBACK as RATTLEBACK_MODEL
from .core.workspace import (
    BLOCK, METHODS, MU_ROLL, MU_S, MU_SPIN, OBSERVABLES, SLIDING, STOP_RULES, friction_level,
)
from .inputs import RATTLEBACK, Input, check_rules
from .validation import (as_float_array, check_boolean, check_memory, fail_where,
                         is_real)

if TYPE_CHECKING:
    from .body import Body
    from .planar.body import PlanarBody

__all__ = [
    "COARSE_DT", "LONG_RUN_STEPS", "MAX_STEPS", "RK4_LIMIT", "CoarseStepWarning",
    "LongRunWarning", "Model", "Prepared", "Raw", "announce_long_run", "as_bodies",
    "blocked", "broadcast_inputs", "check_band", "check_common", "check_method",
    "check_record_every", "check_record_size", "check_single_step", "check_stop",
    "contact_slip_velocity",
    "batch_level", "default_dts", "execute", "kernels_compiled", "numba_threads", "pack",
    "physical_memory", "prepared",
    "run_kernel", "steps_for", "unblock", "warn_coarse_dt",
]

@dataclass(frozen=True)
class Model:
    """What the batch layer needs to know of a model.

    ``number`` is the kernel's model number (:mod:`rattlesweep.core.models`); ``layout``
    the model's layout module (``PARAMS``, ``STATE``, ``RECORD``, ``OBSERVABLES``,
    ``N_OBS``); ``observables`` the names of the per-run results, in order, each a row
    of the shared or the model's observables or a key of ``derived``: (function of the
    observables before it by name, units, long name); ``status_attrs`` are the CF
    attributes of the status flags (their comment says what each status means for the
    model).
    """

    number: int
    layout: ModuleType
    observables: tuple[str, ...]
    status_attrs: Mapping[str, Any]
    derived: Mapping[str, tuple[Callable[[Mapping[str, np.ndarray]], np.ndarray], str, str]
                     ] = field(default_factory=dict)

    def observable_row(self, name: str) -> int:
        if name in OBSERVABLES:
            return OBSERVABLES.start(name)
        return OBSERVABLES.size + self.layout.OBSERVABLES.start(name)

    def attrs(self, name: str) -> dict[str, Any]:
        """CF attributes of a result variable of this model."""
        if name == "status":
            return dict(self.status_attrs)
        if name in self.derived:
            return {"units": self.derived[name][1], "long_name": self.derived[name][2]}
        for rows in (self.layout.OBSERVABLES, OBSERVABLES, self.layout.RECORD):
            if name in rows:
                row = rows[name]
                return {"units": row.units, "long_name": row.long_name}
        raise KeyError(name)


@dataclass(frozen=True)
class Prepared:
    """A validated batch packed into kernel blocks."""

    model: Model
    P: np.ndarray  # (n_blocks, n_param, BLOCK)
    Y: np.ndarray  # (n_blocks, n_state, BLOCK)
    nsteps: np.ndarray  # (n_blocks, BLOCK) int64; 0 for padding lanes
    n: int  # trajectories
    shape: tuple[int, ...]  # broadcast shape of the inputs
    coords: dict[str, Any]  # name -> (dims, flat values), every input per trajectory


@dataclass(frozen=True)
class Raw:
    """What a kernel run returns, per trajectory: observables (n_obs, n), records
    (n, n_rec, n_record) or None, final state (n_state, n)."""

    observables: np.ndarray
    records: np.ndarray | None
    final_state: np.ndarray


# --- inputs ---------------------------------------------------------------------------
def as_bodies(body: object, cls: type) -> np.ndarray:
    """``body`` as an object array of ``cls`` instances (0-d for a single body)."""
    name = cls.__name__
    if isinstance(body, cls):
        arr = np.empty((), dtype=object)
        arr[()] = body
        return arr
    arr = np.asarray(body, dtype=object)
    if arr.size == 0:
        raise ValueError(f"body must be a {name} or a non-empty array of {name} objects")
    for item in arr.flat:
        if not isinstance(item, cls):
            raise ValueError(f"body must be a {name} or an array of {name} objects, "
                             f"got {item!r}")
    return arr


def broadcast_inputs(bodies: np.ndarray, scalars: Mapping[str, Any],
                     vectors: Mapping[str, np.ndarray] | None = None
                     ) -> tuple[tuple[int, ...], int, np.ndarray, dict[str, np.ndarray],
                                dict[str, np.ndarray]]:
    """Broadcast bodies (object array), scalar inputs and vector inputs (broadcast on
    their leading axes) together. Returns (shape, n, flat bodies, flat scalars, flat
    vectors)."""
    vectors = vectors or {}
    arrays = {k: as_float_array(k, v) for k, v in scalars.items()}
    try:
        shape = np.broadcast_shapes(bodies.shape, *(v.shape for v in arrays.values()),
                                    *(v.shape[:-1] for v in vectors.values()))
    except ValueError:
        shapes = {k: v.shape for k, v in {**arrays, **vectors}.items()}
        raise ValueError(f"inputs cannot be broadcast together: shapes {shapes}, "
                         f"body {bodies.shape}") from None
    n = math.prod(shape)
    check_launches(n, {**{k: v.shape for k, v in arrays.items()},
                       **{k: v.shape[:-1] for k, v in vectors.items()}, "body": bodies.shape})
    flat = {k: np.broadcast_to(v, shape).reshape(n) for k, v in arrays.items()}
    flat_vec = {k: np.broadcast_to(v, shape + v.shape[-1:]).reshape(n, v.shape[-1])
                for k, v in vectors.items()}
    return tuple(shape), n, np.broadcast_to(bodies, shape).reshape(n), flat, flat_vec


def check_common(arrays: Mapping[str, np.ndarray], inputs: Mapping[str, Input]) -> None:
    """The rules of a model's inputs (``inputs``, its descriptions in
    :mod:`rattlesweep.inputs`) for the values in ``arrays`` (name -> values), and
    ``mu_static >= mu``: friction, damping, g, dt (when given) and t_end."""
    check_rules(arrays, inputs)
    mu_k, mu_s = arrays["mu"], arrays["mu_static"]
    bad = np.broadcast_to(mu_s, np.broadcast_shapes(mu_s.shape, mu_k.shape)) < mu_k
    fail_where("mu_static", np.broadcast_to(mu_s, bad.shape), bad, "must be >= mu")


COARSE_DT = 4.0
"""A time step above this many times the body's default draws a :class:`CoarseStepWarning`."""

RK4_LIMIT = 2.0 * 2.0 ** 0.5 * 64.0 / (2.0 * np.pi)
"""RK4 is unstable for an oscillation of angular frequency ω when ω dt > 2√2: at about
this many times the default step (1/64 of the shortest small-oscillation period)."""


class CoarseStepWarning(RuntimeWarning):
    """A time step so coarse that a result, statuses included, may be a numerical
    artefact."""


def warn_coarse_dt(table: Sequence[Body | PlanarBody], index: np.ndarray, g: np.ndarray,
                   dt: np.ndarray,
                   stacklevel: int, default: np.ndarray | None = None) -> None:
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
    why = ("1/64 of its shortest small-oscillation period"
           if default[worst] == body_default[worst] else
           "the longest that follows its damping, smallest principal moment / damping")
    if ratio > COARSE_DT:
        warnings.warn(
            f"dt = {dt[worst]:.3g} s is {ratio:.3g} times the default step of body "
            f"{table[index[worst]].name!r} ({default[worst]:.3g} s, {why}): RK4 loses "
            f"accuracy beyond a few times the default "
            f"and is unstable from about {RK4_LIMIT:.0f} times it (semi-implicit Euler "
            f"sooner); statuses such as capsized or lifted_off of such a run may be "
            f"numerical artefacts", CoarseStepWarning, stacklevel=stacklevel + 1)


LONG_RUN_STEPS = 10**9
"""Steps in a batch (over all its launches) beyond which :func:`announce_long_run` warns
before the run: at about 10**6 steps per second on a core, a quarter of an hour of one
core or more."""


class LongRunWarning(UserWarning):
    """A batch about to take a very large number of steps (minutes or more)."""


def announce_long_run(steps: np.ndarray, t_end: np.ndarray, dt: np.ndarray,
                      default_from: Mapping[str, np.ndarray] | None, stacklevel: int
                      ) -> None:
    """Warn before a batch of more than LONG_RUN_STEPS steps, with the count, the
    longest launch's t_end and dt, and the inputs a default dt came from."""
    total = float(np.sum(steps, dtype=float))
    if total <= LONG_RUN_STEPS:
        return
    i = int(np.argmax(steps))
    source = "" if default_from is None else " (the body's default step at " + ", ".join(
        f"{k} = {float(v.flat[i]):g}" for k, v in default_from.items()) + ")"
    warnings.warn(
        f"this batch takes {total:.3g} steps in all ({len(steps):,} launch{'es' if len(steps) != 1 else ''}; the longest "
        f"t_end = {float(t_end.flat[i]):g} s / dt = {float(dt.flat[i]):.3g} s{source} = "
        f"{int(steps.flat[i]):,} steps): at about 1e6 steps per second on a core, "
        f"roughly {total / 1e6 / 60:.3g} core-minutes", LongRunWarning,
        stacklevel=stacklevel + 1)


MAX_STEPS = 2**53
"""The most steps a trajectory can take: the kernel counts steps in float64, which
counts integers exactly up to 2**53."""


def _show_body(body: Body | PlanarBody) -> str:
    """A body for an error message: its name and semi-axes, the parameters its default
    step depends on most."""
    axes = ", ".join(f"{k} = {getattr(body, k)!r}" for k in ("a", "b", "c")
                     if hasattr(body, k))
    return f"body = {body.name!r} with {axes} m"


def steps_for(t_end: np.ndarray, dt: np.ndarray,
              default_from: Mapping[str, np.ndarray] | None = None,
              bodies: tuple[Sequence[Body | PlanarBody], np.ndarray] | None = None
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
        shown = [] if default_from is None else [
            f"{k} = {float(v.flat[i])!r}" for k, v in default_from.items()]
        if default_from is not None and bodies is not None:
            shown.append(_show_body(bodies[0][int(bodies[1].flat[i])]))
        source = "" if not shown else " (the body's default step at " + ", ".join(shown) + ")"
        raise ValueError(
            f"t_end / dt must be at most 2**53 steps (the kernel counts steps in float64); "
            f"got t_end = {float(t_end.flat[i])!r} s and dt = {float(dt.flat[i])!r} s"
            f"{source}, {float(steps.flat[i]):.3g} steps{where}")
    return steps.astype(np.int64)


def default_dts(table: Sequence[Body | PlanarBody], index: np.ndarray, g: np.ndarray
                ) -> np.ndarray:
    """Each trajectory's default time step, computed once per distinct (body, g)."""
    keys, inverse = np.unique(np.stack([index.astype(float), g]), axis=1, return_inverse=True)
    per_key = np.array([table[int(i)].default_dt(float(gv)) for i, gv in keys.T])
    return per_key[inverse.reshape(-1)]


# --- packing --------------------------------------------------------------------------
def blocked(rows: np.ndarray, n: int) -> np.ndarray:
    """(n_rows, n) → (n_blocks, n_rows, BLOCK); padding lanes copy the first
    trajectory (they take no steps)."""
    n_blocks = -(-n // BLOCK)
    out = np.empty((rows.shape[0], n_blocks * BLOCK))
    out[:, :n] = rows
    out[:, n:] = rows[:, :1]
    return np.ascontiguousarray(out.reshape(rows.shape[0], n_blocks, BLOCK).transpose(1, 0, 2))


def pack(table: Rows, columns: Mapping[str, np.ndarray], n: int) -> np.ndarray:
    """The rows of a parameter or state table as kernel blocks: each row from its
    ``pack`` function of the flat per-trajectory ``columns``, or, without one, the
    column of its name."""
    rows = np.empty((table.size, n))
    for row in table:
        values = np.asarray(row.pack(columns) if row.pack else columns[row.name], dtype=float)
        rows[table.slice(row.name)] = values.reshape(n, row.width).T
    return blocked(rows, n)


def unblock(arr: np.ndarray, n: int) -> np.ndarray:
    """(n_blocks, n_rows, BLOCK) → (n_rows, n)."""
    return arr.transpose(1, 0, 2).reshape(arr.shape[1], -1)[:, :n]


def prepared(model: Model, columns: Mapping[str, np.ndarray], Y: np.ndarray,
             nsteps: np.ndarray, n: int, shape: Sequence[int], coords: dict[str, Any]
             ) -> Prepared:
    """A :class:`Prepared` batch: parameters packed from ``columns``, the launch state Y
    already in blocks."""
    steps = np.zeros(Y.shape[0] * BLOCK, dtype=np.int64)
    steps[:n] = nsteps
    return Prepared(model, pack(model.layout.PARAMS, columns, n), Y,
                    steps.reshape(-1, BLOCK), n, tuple(shape), coords)


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


# --- running --------------------------------------------------------------------------
@contextlib.contextmanager
def numba_threads(threads: int | None) -> Iterator[None]:
    """Run the block with numba's thread count set to ``threads`` (None: unchanged)."""
    if threads is None:
        yield
        return
    # numba sets its config attributes from the environment at import, out of mypy's sight
    limit = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    if not (isinstance(threads, (int, np.integer)) and not isinstance(threads, bool)
            and 1 <= threads <= limit):
        raise ValueError(f"threads must be an integer from 1 to {limit}, got {threads!r}")
    old = numba.get_num_threads()
    numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def check_method(method: str) -> int:
    try:
        return METHODS.index(method)
    except (ValueError, TypeError):
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}") from None


def check_record_every(record_every: int | None) -> int | None:
    if record_every is None:
        return None
    if not (isinstance(record_every, (int, np.integer)) and not isinstance(record_every, bool)
            and record_every >= 1):
        raise ValueError(f"record_every must be a positive integer or None, got {record_every!r}")
    return int(record_every)


def check_single_step(prep: Prepared) -> None:
    """Records need one time step and one end time for the whole batch."""
    for name in ("dt", "t_end"):
        values = prep.coords[name][1]
        if values.size and np.any(values != values[0]):
            raise ValueError(f"record_every needs a single {name} for the whole batch")


def check_band(reversal_band: float) -> float:
    band = float(reversal_band) if is_real(reversal_band) else np.nan  # else refused below
    rule = RATTLEBACK["reversal_band"].rule
    assert rule is not None
    if rule.bad(band):
        raise ValueError(f"reversal_band {rule.message}, got {reversal_band!r}")
    return band


def check_stop(stop: str | None) -> float:
    """The ``stop_rule`` row value of a ``stop`` argument: None (run to ``t_end``) or
    ``"first_reversal"``."""
    try:
        return STOP_RULES[stop]
    except (KeyError, TypeError):
        raise ValueError(f"stop must be None (run to t_end) or 'first_reversal', got "
                         f"{stop!r}") from None


LAUNCH_BYTES = 1024
"""Memory a batch holds per launch, at its peak (inputs, packed rows, state, results;
measured: 832 bytes for run_batch), for the check before anything is allocated."""


def check_launches(n: int, shapes: Mapping[str, tuple[int, ...]]) -> None:
    """Refuse a batch of ``n`` launches (the broadcast of inputs of ``shapes``) that would
    not fit in the memory available, naming the inputs that set its size."""
    big = {k: v for k, v in shapes.items() if math.prod(v) > 1}
    named = ", ".join(f"{k} {v}" for k, v in big.items()) or "the inputs"
    check_memory("launches", f"{n:,} (the broadcast of {named})", n * LAUNCH_BYTES,
                 f"a batch of {n:,} launches",
                 "run fewer at once (a sweep runs them in tiles: rattlesweep.Sweep)")


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
            f"less often (a larger record_every), or a shorter t_end")


def kernels_compiled(parallel: bool = True, model: int = RATTLEBACK_MODEL,
                     level: int = SLIDING) -> bool:
    """True when the machine code of the kernel entry that :func:`execute` calls
    (``parallel`` or serial) for the model number ``model`` at the friction level
    ``level`` (:func:`friction_level`; the default: Coulomb friction without couples) is
    in numba's on-disk cache: a first call in this process then loads it in about a
    second; otherwise it compiles the kernels first."""
    return on_disk(stepper.integrate_parallel if parallel else stepper.integrate_serial,
                   model, level)


def batch_level(prep: Prepared) -> int:
    """The friction level the launches of ``prep`` need
    (:func:`.core.workspace.friction_level`)."""
    P = unblock(prep.P, prep.n)
    return friction_level(P[MU_S], P[MU_SPIN], P[MU_ROLL])


_PARALLEL = threading.Lock()
"""Held by a parallel kernel call. numba's ``workqueue`` threading layer (the one it uses
where neither TBB nor OpenMP is available) aborts the interpreter when two threads
launch parallel regions at once; a parallel call already occupies every core, so calls
from several threads take turns at no cost in throughput."""


def execute(prep: Prepared, *, method: int, record_every: int | None, band: float = 0.0,
            parallel: bool = True, threads: int | None = None) -> Raw:
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
        run_kernel(entry, (prep.model.number, batch_level(prep)), prep.P, Y, prep.nsteps,
                   method, record_every or 1, band, O, REC)
    rec = None
    if n_rec:
        rec = REC.transpose(0, 3, 1, 2).reshape(n_blocks * BLOCK, n_rec, layout.N_REC)[:prep.n]
    return Raw(unblock(O, prep.n), rec, unblock(Y, prep.n))
