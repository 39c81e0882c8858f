"""A body read from a TOML file: the ``[body]`` table (``rattlesweep simulate --body``),
in the format a sweep file's ``body`` entry takes, so one file serves both."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from ...rattleback.body import Body
from .schema import body_from_table
from .toml_io import read_toml

__all__ = ["body_from_argument", "body_from_toml"]


def body_from_argument(text: str) -> Body:
    """The body a ``--body`` option names: a preset name, or a TOML file
    (:func:`body_from_toml`). ValueError naming the argument when it is neither."""
    from ...rattleback.body import PRESETS

    path = Path(text)
    looks_like_a_file = path.suffix != "" or len(path.parts) > 1
    if not path.exists() and not looks_like_a_file:
        if text in PRESETS:
            return Body.preset(text)
        raise ValueError(
            f"--body {text}: neither a preset ({', '.join(sorted(PRESETS))}) nor a "
            "TOML file with a [body] table"
        )
    return body_from_toml(path)


def body_from_toml(path: str | Path) -> Body:
    """The body of the file's ``[body]`` table, or of ``[fixed] body`` in a sweep file:
    a table ``{a, b, c, mass, com, inertia[, full_ellipsoid, name]}`` (SI, as
    :class:`rattlesweep.Body`) or a preset name. ValueError naming the file and the key
    when there is none or it is not a valid body."""
    data = read_toml(Path(path))
    entry: Any = data.get("body")
    where = f"{path}: body"
    fixed = data.get("fixed")
    if entry is None and isinstance(fixed, Mapping) and "body" in fixed:
        entry, where = fixed["body"], f"{path}: fixed.body"
    if entry is None:
        raise ValueError(
            f"{path} has no [body] table (a, b, c, mass, com, inertia"
            "[, full_ellipsoid, name], SI units), nor a sweep's fixed.body"
        )
    if isinstance(entry, str):
        try:
            return Body.preset(entry)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    if not isinstance(entry, Mapping):
        raise ValueError(f"{where}: expected a table or a preset name; got {entry!r}")
    return body_from_table(entry, where)
