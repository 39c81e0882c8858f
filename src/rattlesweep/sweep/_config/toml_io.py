"""Reading and writing the TOML form of a configuration.

Reading is :mod:`tomllib`. Writing is a small writer for the plain data a configuration
holds (strings, booleans, integers, floats including ``inf`` and ``nan``, lists, and
mappings): top-level values first, then one ``[table]`` per top-level mapping with one
``key = value`` line per entry, deeper mappings as inline tables. It keeps every table's
key order (a sweep's axis order is its dimension order), so the file reads like the one a
user writes and reads back to the same data. The text is ASCII (other characters in
strings are written as ``\\uXXXX`` escapes), so it passes unchanged through terminals,
files and netCDF attributes whatever their encoding.

The writer is written here rather than taken from ``tomli-w``, which writes a mapping
inside a table as a ``[table.key]`` sub-table placed after the table's other keys (that
would change the order of the axes, which is the order of the result's dimensions).
"""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path
from typing import Any, Mapping

__all__ = ["format_toml", "plain", "read_toml"]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_SHORT_ESCAPES = {
    '"': '\\"',
    "\\": "\\\\",
    "\b": "\\b",
    "\t": "\\t",
    "\n": "\\n",
    "\f": "\\f",
    "\r": "\\r",
}


def read_toml(path_or_text: str | Path) -> dict[str, Any]:
    """The data of a TOML file (a :class:`~pathlib.Path`, or a one-line string ending in
    ``.toml``) or of TOML text. A file that cannot be read or parsed is a ValueError
    naming it."""
    text, label = str(path_or_text), "configuration"
    if isinstance(path_or_text, Path) or "\n" not in text and text.endswith(".toml"):
        label = str(path_or_text)
        try:
            # utf-8-sig: a byte-order mark, as some Windows editors write, is dropped
            text = Path(path_or_text).read_text(encoding="utf-8-sig")
        except OSError as exc:
            raise ValueError(f"cannot read {label}: {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise ValueError(
                f"cannot parse {label} as TOML: it is not UTF-8 "
                f"({exc.reason} at byte {exc.start})"
            ) from None
    text = text.removeprefix("\ufeff")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"cannot parse {label} as TOML: {exc}") from None


def format_toml(document: Mapping[str, Any], comment: str | None = None) -> str:
    """``document`` as TOML text that :func:`tomllib.loads` reads back to equal data.

    Top-level mappings become ``[tables]`` after the other top-level keys; everything
    else keeps its order. ``comment`` (one line) heads the text. Values TOML has no
    form for (None, other types, strings with lone surrogates) are a TypeError or
    ValueError.
    """
    lines = [] if comment is None else [f"# {comment}"]
    tables = []
    for key, value in document.items():
        if isinstance(value, Mapping):
            tables.append((key, value))
        else:
            lines.append(f"{_key(key)} = {_value(value)}")
    for key, table in tables:
        if lines:
            lines.append("")
        lines.append(f"[{_key(key)}]")
        lines += [f"{_key(k)} = {_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def plain(value: Any, digits: int = 12) -> Any:
    """``value`` as the plain data :func:`format_toml` writes: NumPy numbers and arrays
    as Python ones, finite floats rounded to ``digits`` significant digits (a record
    reads as what was computed, not as its last bits), mappings and sequences
    throughout."""
    import numpy as np

    if isinstance(value, (float, np.floating)):
        value = float(value)
        return float(f"{value:.{digits}g}") if math.isfinite(value) else value
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.ndarray):
        return [plain(v, digits) for v in value.tolist()]
    if isinstance(value, Mapping):
        return {k: plain(v, digits) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v, digits) for v in value]
    return value


def _key(key: str) -> str:
    if not isinstance(key, str):
        raise TypeError(f"a TOML key is a string, got {key!r}")
    return key if _BARE_KEY.fullmatch(key) else _string(key)


def _string(s: str) -> str:
    out = []
    for ch in s:
        if ch in _SHORT_ESCAPES:
            out.append(_SHORT_ESCAPES[ch])
        elif " " <= ch < "\x7f":
            out.append(ch)
        elif "\ud800" <= ch <= "\udfff":
            raise ValueError(f"cannot write {s!r} as TOML: it holds a lone surrogate")
        elif ch <= "\uffff":
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(f"\\U{ord(ch):08X}")
    return '"' + "".join(out) + '"'


def _value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        if not v:
            return "{}"
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")
