"""Input validation: bad input becomes a ``ValueError`` naming the parameter, the value and
the rule it breaks, before any computation can turn it into a NaN or a cryptic error.

Non-numbers (strings, other objects) get the same kind of message as bad numbers, never a
``TypeError`` from deep inside numpy or ``float``.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

__all__ = [
    "as_float_array",
    "available_memory",
    "memory_left",
    "check_boolean",
    "check_memory",
    "fail_where",
    "finite_vector",
    "is_real",
    "positive",
]


def positive(name: str, value: Any) -> float:
    """``value`` as a float, which must be a real number (not a bool, a string or a
    complex number), finite and > 0.

    Raises ``ValueError("<name> must be a finite number > 0, got <value>")`` otherwise.
    """
    v = math.nan
    if is_real(value):
        try:
            v = float(value)
        except (TypeError, ValueError, OverflowError):
            pass
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def is_real(value: Any) -> bool:
    """True for a real number: a Python or NumPy int or float, or a 0-d array of one;
    False for bools, strings, complex numbers, times and dates (NumPy's ``timedelta64``
    is an integer type to NumPy), masked values and anything else."""
    if isinstance(value, np.ma.MaskedArray):
        return False
    if isinstance(value, np.ndarray):
        return value.ndim == 0 and value.dtype.kind in "iuf"
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_, np.timedelta64)
    )


def check_boolean(name: str, value: Any) -> bool:
    """``value``, which must be a boolean (Python's or NumPy's): ``"false"``, 0 or 1 are
    refused, as their meaning would be a guess."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a boolean (true or false), got {value!r}")
    return bool(value)


def finite_vector(name: str, value: Any, n: int) -> np.ndarray:
    """``value`` as a new float array of shape ``(n,)`` with finite entries.

    Raises ``ValueError`` naming ``name`` when it is not numbers, has another shape or
    holds a NaN or an infinity.
    """
    arr = as_float_array(name, value).copy()  # never the caller's array, which may change
    if arr.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def as_float_array(name: str, value: Any) -> np.ndarray:
    """``value`` as a float array (0-d for a scalar; no copy when it already is one).

    Only real numbers are accepted: ints and floats of Python or NumPy, arrays and
    (nested) lists of them, array-likes of them (a pandas Series or nullable array, an
    xarray DataArray; a missing value becomes NaN), and ``None`` (which becomes NaN,
    for a finiteness rule to refuse). Raises ``ValueError("<name> must be a number or
    an array of numbers (real numbers: ...), got <value>")`` for anything else:
    strings (numeric or not), booleans, complex numbers, ragged lists, times and dates
    (``timedelta64``, ``datetime64``), masked arrays (their masked entries would be
    simulated all the same), other objects.
    """
    value = _from_array_like(value)
    if isinstance(value, np.ma.MaskedArray):
        raise ValueError(
            f"{name} must be a plain array of numbers, not a masked array (its masked "
            f"entries would be simulated too): pass only the values to simulate, e.g. "
            f"the array's .compressed(); got {_shown(value)}"
        )
    if _is_time(value):
        raise ValueError(
            f"{name} {_RULE}; a time or a date (timedelta64, datetime64) is not a plain "
            f"number: give it in the parameter's own unit, got {_shown(value)}"
        )
    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        return value.astype(float, copy=False)
    if not _real_entries(value):
        raise ValueError(f"{name} {_RULE}, got {_shown(value)}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} {_RULE}, got {_shown(value)}") from None
    return arr


def _from_array_like(value: Any) -> Any:
    """A NumPy array of an array-like of numbers that is not one (a pandas Series or
    nullable array, an xarray DataArray): its values, a missing value (pandas' NA) as
    NaN. Anything else is returned as it is, for the checks to judge."""
    if isinstance(value, (np.ndarray, list, tuple, str, bytes)) or not hasattr(
        value, "__array__"
    ):
        return value
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    if kind in ("i", "u", "f"):
        to_numpy = getattr(value, "to_numpy", None)
        try:
            if to_numpy is not None:
                return np.asarray(to_numpy(dtype=float, na_value=np.nan))
        except TypeError:  # a to_numpy without those arguments (xarray's)
            pass
        return np.asarray(value, dtype=float)
    return np.asarray(value)


_RULE = (
    "must be a number or an array of numbers (real numbers: not booleans, strings "
    "or complex numbers)"
)


def _is_time(value: Any) -> bool:
    """True for a NumPy time or date, or an array of them."""
    if isinstance(value, (np.timedelta64, np.datetime64)):
        return True
    return isinstance(value, np.ndarray) and value.dtype.kind in "mM"


def _real_entries(value: Any) -> bool:
    """True when every entry of ``value`` (a scalar, an array or nested lists) is a real
    number or None."""
    if value is None or is_real(value):
        return True
    if isinstance(value, np.ma.MaskedArray):
        return False
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "iuf":
            return True
        if value.dtype.kind != "O":
            return False
        return all(_real_entries(v) for v in value.ravel().tolist())
    if isinstance(value, (list, tuple)):
        return all(_real_entries(v) for v in value)
    return False


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 200 else text[:200] + "..."


def fail_where(name: str, arr: np.ndarray, bad: np.ndarray, rule: str) -> None:
    """Raise ``ValueError("<name> <rule>; got <value> at index <idx>")`` for the first
    entry of ``arr`` where the boolean mask ``bad`` (same shape) is true; do nothing when
    it is false everywhere. A 0-d ``arr`` gives no index.

    ``rule`` reads after the name, e.g. ``"must be finite and > 0"``.
    """
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f" at index {idx}" if arr.ndim else ""
        value = arr[idx]
        # a plain number, as the user wrote it (-1.0, not numpy's np.float64(-1.0))
        shown = (
            repr(float(value)) if np.ndim(value) == 0 else repr(np.asarray(value).tolist())
        )
        raise ValueError(f"{name} {rule}; got {shown}{where}")


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def _address_space_left() -> int | None:
    """What the process's address-space limit (``ulimit -v``, RLIMIT_AS) leaves of its
    virtual size now; None when unlimited."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/status") as f:
            size = next(int(x.split()[1]) * 1024 for x in f if x.startswith("VmSize:"))
        return max(0, soft - size)
    except (ImportError, OSError, ValueError, StopIteration):
        return None


def _cgroup_left() -> int | None:
    """What the memory limit of this process's cgroup (v2 ``memory.max``, a
    container's limit) leaves; None without one."""
    try:
        with open("/proc/self/cgroup") as f:
            path = next(
                line.split(":", 2)[2].strip() for line in f if line.startswith("0::")
            )
        base = f"/sys/fs/cgroup{path}"
        with open(f"{base}/memory.max") as f:
            limit = f.read().strip()
        if limit == "max":
            return None
        with open(f"{base}/memory.current") as f:
            used = int(f.read().strip())
        return max(0, int(limit) - used)
    except (OSError, ValueError, StopIteration, IndexError):
        return None


def memory_left() -> tuple[int, str] | None:
    """The bytes a new allocation can take now and what sets that: the smallest of the
    memory available (Linux ``MemAvailable``, elsewhere the physical memory), what
    the process's address-space limit (``ulimit -v``) leaves and what its container's
    memory limit (cgroup) leaves; None where the system says none of them."""
    probes = [
        (_meminfo_available(), "memory available"),
        (
            _address_space_left(),
            "address space left under this process's limit (ulimit -v)",
        ),
        (_cgroup_left(), "memory left under this container's limit (cgroup memory.max)"),
    ]
    known = [(n, what) for n, what in probes if n is not None]
    return min(known, key=lambda p: p[0]) if known else None


def available_memory() -> int | None:
    """Bytes a new allocation can take now (:func:`memory_left`), None where unknown."""
    left = memory_left()
    return None if left is None else left[0]


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


def check_memory(name: str, value: Any, need: float, what: str, advice: str = "") -> None:
    """Refuse, before anything is allocated, what would need ``need`` bytes when that is
    more than the memory available now: ``ValueError("<name> = <value>: <what> would
    need about N GiB, more than the M GiB of memory available; <advice>")``."""
    left = memory_left()
    if left is not None and need > left[0]:
        tail = f"; {advice}" if advice else ""
        raise ValueError(
            f"{name} = {value}: {what} would need about {_gib(need)}, more "
            f"than the {_gib(left[0])} of {left[1]}{tail}"
        )
