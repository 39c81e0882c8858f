"""``design.toml``: the shell, the coins, the print assumed and the predicted behaviour,
with the simulated body as a ``[body]`` table in the form a sweep's body table takes
(:func:`load_body` reads it back).

A sweep configuration uses it as ``[fixed.body]`` (or ``body = {...}`` under
``[fixed]``); ``sweep.toml``, written beside it, is such a sweep: the design's reversal
map."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from .._version import __version__
from ..rattleback.body import Body
from ..sweep._config.schema import body_from_table, body_table
from ..sweep._config.toml_io import format_toml, plain, read_toml

__all__ = ["body_table", "design_document", "load_body", "write_toml"]


def write_toml(document: Mapping[str, Any], path: Path, comment: str) -> Path:
    """Write ``document`` as TOML to ``path`` (through a temporary file)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(format_toml(plain(dict(document)), comment=comment), encoding="ascii")
    tmp.replace(path)
    return path


def load_body(path: str | Path) -> Body:
    """The :class:`~rattlesweep.Body` of a ``design.toml`` (its ``[body]`` table)."""
    data = read_toml(Path(path))
    if "body" not in data:
        raise ValueError(
            f"{path}: no [body] table; expected a design.toml written by rattlesweep design"
        )
    return body_from_table(data["body"], f"{path}: body")


def design_document(
    body: Body, sections: Mapping[str, Mapping[str, Any]]
) -> dict[str, Any]:
    """The design.toml document: version, the body table, then ``sections``."""
    return {
        "rattlesweep_version": __version__,
        "units": "SI (m, kg, s, rad/s)",
        "body": body_table(body),
        **sections,
    }
