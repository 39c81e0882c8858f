"""The inputs of a batch, checked and broadcast: bodies and per-launch values of either
model become flat per-trajectory arrays over one ``trajectory`` axis. Refusals name the
input, the value and the rule (:mod:`rattlesweep.inputs` describes each input), before
anything is computed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ._validation import as_float_array, check_memory, fail_where
from .inputs import Input, check_rules

__all__ = [
    "LAUNCH_BYTES",
    "Launches",
    "as_bodies",
    "broadcast_inputs",
    "check_common",
    "check_launches",
    "distinct_bodies",
    "launches",
]


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
            raise ValueError(
                f"body must be a {name} or an array of {name} objects, got {item!r}"
            )
    return arr


def distinct_bodies(bodies: Sequence[Any] | np.ndarray) -> tuple[list[Any], np.ndarray]:
    """The distinct bodies of a flat sequence, in first-seen order, and each item's index
    into them (an int array of the sequence's length).

    Bodies are told apart by value and by name: results label each trajectory with the
    name from this table, so equal bodies with different names stay apart. The table
    holds the first item seen of each.
    """
    seen: dict[tuple[Any, str], int] = {}
    index = np.fromiter(
        (seen.setdefault((b, b.name), len(seen)) for b in bodies),
        dtype=np.intp,
        count=len(bodies),
    )
    return [body for body, _ in seen], index


LAUNCH_BYTES = 1024
"""Memory a batch holds per launch, at its peak (inputs, packed rows, state, results;
measured: 832 bytes for run_batch), for the check before anything is allocated."""


def check_launches(n: int, shapes: Mapping[str, tuple[int, ...]]) -> None:
    """Refuse a batch of ``n`` launches (the broadcast of inputs of ``shapes``) that would
    not fit in the memory available, naming the inputs that set its size."""
    big = {k: v for k, v in shapes.items() if math.prod(v) > 1}
    named = ", ".join(f"{k} {v}" for k, v in big.items()) or "the inputs"
    check_memory(
        "launches",
        f"{n:,} (the broadcast of {named})",
        n * LAUNCH_BYTES,
        f"a batch of {n:,} launches",
        "run fewer at once (a sweep runs them in tiles: rattlesweep.Sweep)",
    )


def broadcast_inputs(
    bodies: np.ndarray,
    scalars: Mapping[str, Any],
    vectors: Mapping[str, np.ndarray] | None = None,
) -> tuple[tuple[int, ...], int, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Broadcast bodies (object array), scalar inputs and vector inputs (broadcast on
    their leading axes) together. Returns (shape, n, flat bodies, flat scalars, flat
    vectors)."""
    vectors = vectors or {}
    arrays = {k: as_float_array(k, v) for k, v in scalars.items()}
    try:
        shape = np.broadcast_shapes(
            bodies.shape,
            *(v.shape for v in arrays.values()),
            *(v.shape[:-1] for v in vectors.values()),
        )
    except ValueError:
        shapes = {k: v.shape for k, v in {**arrays, **vectors}.items()}
        raise ValueError(
            f"inputs cannot be broadcast together: shapes {shapes}, body {bodies.shape}"
        ) from None
    n = math.prod(shape)
    check_launches(
        n,
        {
            **{k: v.shape for k, v in arrays.items()},
            **{k: v.shape[:-1] for k, v in vectors.items()},
            "body": bodies.shape,
        },
    )
    flat = {k: np.broadcast_to(v, shape).reshape(n) for k, v in arrays.items()}
    flat_vec = {
        k: np.broadcast_to(v, shape + v.shape[-1:]).reshape(n, v.shape[-1])
        for k, v in vectors.items()
    }
    return tuple(shape), n, np.broadcast_to(bodies, shape).reshape(n), flat, flat_vec


def check_common(arrays: Mapping[str, np.ndarray], inputs: Mapping[str, Input]) -> None:
    """The rules of a model's inputs (``inputs``, its descriptions in
    :mod:`rattlesweep.inputs`) for the values in ``arrays`` (name -> values), and
    ``mu_static >= mu``: friction, damping, g, dt (when given) and t_end."""
    check_rules(arrays, inputs)
    mu_k, mu_s = arrays["mu"], arrays["mu_static"]
    bad = np.broadcast_to(mu_s, np.broadcast_shapes(mu_s.shape, mu_k.shape)) < mu_k
    fail_where("mu_static", np.broadcast_to(mu_s, bad.shape), bad, "must be >= mu")


@dataclass(frozen=True)
class Launches:
    """Checked launch inputs of one model, broadcast and flattened over n trajectories."""

    shape: tuple[int, ...]
    n: int
    bodies: list[Any]  # the distinct bodies
    index: np.ndarray  # (n,) index of each trajectory's body into ``bodies``
    flat: dict[str, np.ndarray]  # scalar inputs, (n,) each
    vectors: dict[str, np.ndarray]  # vector inputs, (n, width) each


def launches(
    body: object,
    cls: type,
    scalars: Mapping[str, Any],
    inputs: Mapping[str, Input],
    vectors: Mapping[str, np.ndarray] | None = None,
) -> Launches:
    """Check (by the rules of ``inputs``, a model's descriptions) and broadcast a model's
    launches: ``body`` one or an array of ``cls``, ``scalars`` and ``vectors`` its
    per-launch inputs by name."""
    arrays = {k: as_float_array(k, v) for k, v in scalars.items()}
    check_common(arrays, inputs)
    shape, n, flat_bodies, flat, flat_vec = broadcast_inputs(
        as_bodies(body, cls), arrays, vectors
    )
    table, index = distinct_bodies(flat_bodies)
    return Launches(shape, n, table, index, flat, flat_vec)
