"""Measurements of a real rattleback, read from the files people make of them.

Two kinds of series, each against time from the release (s):

* ``heading``: the angle (rad, unwrapped, counter-clockwise seen from above positive) of
  a line on the body, seen from above: a video tracked with Tracker, or any CSV;
* ``gyro``: the three rates (rad/s) of a gyroscope fixed to the body, in the sensor's
  axes: a phyphox export, or any CSV.

:func:`read_measurement` detects the format of a file; each reader checks what it reads
and names the file, the column and the rule that a value breaks.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Mapping

import numpy as np

__all__ = ["Measurement", "read_measurement", "write_phyphox"]

Kind = Literal["heading", "gyro"]

MIN_SAMPLES = 20
"""Fewer samples than this cannot pin down four parameters and their intervals."""


@dataclass(frozen=True)
class Measurement:
    """A measured series: ``time`` (s from the release, increasing), ``values`` (the
    heading, rad, shape (n,); or the gyroscope's rates, rad/s, shape (n, 3), in the
    sensor's x, y, z), its ``kind`` and where it came from (``source``)."""

    kind: Kind
    time: np.ndarray
    values: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        _check(self)

    @property
    def duration(self) -> float:
        """Seconds from the release to the last sample."""
        return float(self.time[-1])

    def trimmed(self, start: float) -> Measurement:
        """The samples from ``start`` (s) on, with time counted from there: the release
        when the recording began before it."""
        if not (math.isfinite(start) and start >= 0.0):
            raise ValueError(
                f"trim_start must be a finite number of seconds >= 0, got {start!r}"
            )
        keep = self.time >= start
        if keep.sum() < MIN_SAMPLES:
            raise ValueError(
                f"trim_start {start:g} s leaves {int(keep.sum())} samples of "
                f"{self.source or 'the measurement'} (it lasts {self.duration:g} s); a fit "
                f"needs at least {MIN_SAMPLES}"
            )
        return Measurement(
            self.kind, self.time[keep] - start, self.values[keep], self.source
        )


def _check(m: Measurement) -> None:
    where = m.source or "the measurement"
    t = np.asarray(m.time, dtype=float)
    v = np.asarray(m.values, dtype=float)
    if m.kind not in ("heading", "gyro"):
        raise ValueError(f"{where}: kind must be 'heading' or 'gyro', got {m.kind!r}")
    want = (t.size,) if m.kind == "heading" else (t.size, 3)
    if t.ndim != 1 or v.shape != want:
        raise ValueError(
            f"{where}: {m.kind} values must have shape {want} for {t.size} times, got "
            f"{v.shape}"
        )
    bad = ~np.isfinite(t) | ~np.isfinite(v.reshape(t.size, -1)).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)[:5] + 1
        count = int(bad.sum())
        raise ValueError(
            f"{where}: {count} sample{' is' if count == 1 else 's are'} not a number (NaN "
            f"or empty) in the time or the values: sample {', '.join(map(str, rows))}"
            f"{' ...' if count > 5 else ''} (counted from 1 after the header); remove "
            f"{'it' if count == 1 else 'them'}"
        )
    if t.size < MIN_SAMPLES:
        raise ValueError(f"{where}: {t.size} samples; a fit needs at least {MIN_SAMPLES}")
    steps = np.diff(t)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(
            f"{where}: time must increase from sample to sample; sample {k + 2} "
            f"({t[k + 1]:g} s) follows {t[k]:g} s"
            + (" (a duplicated time)" if steps[k] == 0 else "")
        )
    if t[0] < 0:
        raise ValueError(
            f"{where}: time starts at {t[0]:g} s; time zero is the release, so times "
            "must be >= 0 (trim_start moves the zero)"
        )
    object.__setattr__(m, "time", t)
    object.__setattr__(m, "values", v)


# --- readers ----------------------------------------------------------------------------
def read_measurement(
    path: str | Path,
    *,
    format: str | None = None,
    columns: Mapping[str, str] | None = None,
    angle_units: str | None = None,
    trim_start: float = 0.0,
) -> Measurement:
    """Read a measurement file.

    ``format`` is ``"phyphox"`` (a phyphox gyroscope export: ``Time (s)``,
    ``Gyroscope x (rad/s)``, ... columns), ``"tracker"`` (a Tracker data export: the
    track's name on the first line, then tab-separated columns with ``t`` and an angle
    ``θ`` in degrees, wrapped to (−180°, 180°]), ``"csv"`` (columns named by
    ``columns``: ``time`` and either ``heading`` or ``x``, ``y``, ``z``), or
    ``"netcdf"`` (a dataset with a ``time`` coordinate and a ``heading`` or ``omega``
    variable, as rattlesweep writes them); None detects it. ``angle_units`` (``"deg"``
    or ``"rad"``) says the heading's units where the file does not. ``trim_start``
    (s) drops what was recorded before the release and counts time from it.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{p}: no such file")
    fmt = format or _detect(p)
    if fmt == "netcdf":
        m = _read_netcdf(p)
    else:
        header, rows = _table(p, fmt)
        if fmt == "phyphox":
            m = _phyphox(p, header, rows)
        elif fmt == "tracker":
            m = _tracker(p, header, rows, angle_units)
        elif fmt == "csv":
            m = _generic(p, header, rows, columns or {}, angle_units)
        else:
            raise ValueError(
                f"format must be one of phyphox, tracker, csv, netcdf (or None to "
                f"detect it), got {fmt!r}"
            )
    return m.trimmed(trim_start) if trim_start else m


def _detect(p: Path) -> str:
    with open(p, "rb") as f:
        head = f.read(4096)
    if not head.strip():
        raise ValueError(f"{p}: the file is empty")
    if head.startswith((b"CDF", b"\x89HDF")):
        return "netcdf"
    text = head.decode("utf-8", errors="replace")
    lines = text.splitlines()
    if lines and "Gyroscope x" in lines[0]:
        return "phyphox"
    if len(lines) > 1 and "\t" in lines[1] and lines[1].split("\t")[0].strip() == "t":
        return "tracker"
    if lines and ("," in lines[0] or ";" in lines[0] or "\t" in lines[0]):
        first = lines[0] if len(lines[0]) <= 160 else lines[0][:157] + "..."
        raise ValueError(
            f"{p}: a table whose layout is not known (its first line: {first}). A "
            "phyphox gyroscope export has the columns 'Time (s)' and 'Gyroscope x "
            "(rad/s)' (y, z); a Tracker export has the track's name on its first line, "
            "then tab-separated columns 't' and 'θ'. Other tables: name the columns, on "
            "the command line --format csv --time-column T and --heading-column H (with "
            "--angle-units) or --rate-columns X Y Z; in Python format='csv', "
            "columns={'time': ..., 'heading': ...} or {'time': ..., 'x': ..., 'y': ..., "
            "'z': ...}"
        )
    raise ValueError(
        f"{p}: not a measurement file rattlesweep knows (phyphox or Tracker export, "
        "CSV, netCDF)"
    )


def _table(p: Path, fmt: str) -> tuple[list[str], list[list[str]]]:
    """(header, rows) of a delimited text file; Tracker's first line (the track's
    name) skipped."""
    text = p.read_text(encoding="utf-8-sig", errors="replace")
    lines = [line for line in text.splitlines() if line.strip()]
    if fmt == "tracker":
        lines = lines[1:]
    if not lines:
        raise ValueError(f"{p}: no columns")
    delimiter = "\t" if "\t" in lines[0] else (";" if ";" in lines[0] else ",")
    table = list(csv.reader(lines, delimiter=delimiter))
    if len(table) < 2:
        raise ValueError(f"{p}: a header and no rows of data")
    return [h.strip() for h in table[0]], table[1:]


def _column(p: Path, header: list[str], rows: list[list[str]], name: str) -> np.ndarray:
    try:
        k = header.index(name)
    except ValueError:
        raise ValueError(
            f"{p}: no column {name!r}; its columns are {', '.join(map(repr, header))}"
        ) from None
    out = np.empty(len(rows))
    for i, row in enumerate(rows):
        cell = row[k].strip() if k < len(row) else ""
        try:
            out[i] = float(cell.replace(",", ".")) if cell else math.nan
        except ValueError:
            raise ValueError(
                f"{p}: column {name!r}, row {i + 2}: {cell!r} is not a number"
            ) from None
    return out


def _complete(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tracker leaves rows of frames it did not mark empty: drop rows with no value at
    all (a value missing in a row that has others is an error, named by the check)."""
    empty = np.isnan(v.reshape(len(t), -1)).all(axis=1) & np.isfinite(t)
    return t[~empty], v[~empty]


PHYPHOX_HEADER = (
    '"Time (s)","Gyroscope x (rad/s)","Gyroscope y (rad/s)","Gyroscope z (rad/s)",'
    '"Absolute (rad/s)"'
)


def write_phyphox(path: str | Path, time: np.ndarray, rates: np.ndarray) -> Path:
    """Write gyroscope rates (n, 3) (rad/s) at ``time`` (s) as phyphox exports them (a
    simulated recording to try a fit on, or to share)."""
    lines = [PHYPHOX_HEADER] + [
        f"{t:.9E},{r[0]:.9E},{r[1]:.9E},{r[2]:.9E},{np.linalg.norm(r):.9E}"
        for t, r in zip(np.asarray(time, float), np.asarray(rates, float))
    ]
    out = Path(path)
    out.write_text("\n".join(lines) + "\n")
    return out


def _phyphox(p: Path, header: list[str], rows: list[list[str]]) -> Measurement:
    t = _column(p, header, rows, "Time (s)")
    rates = np.stack(
        [_column(p, header, rows, f"Gyroscope {a} (rad/s)") for a in "xyz"], axis=1
    )
    return Measurement("gyro", t, rates, str(p))


_DEGREE_HEADER = re.compile(r"(deg|°)", re.I)


def _tracker(
    p: Path, header: list[str], rows: list[list[str]], units: str | None
) -> Measurement:
    name = next((h for h in header if h in ("θ", "theta")), None)
    if name is None:
        raise ValueError(
            f"{p}: a Tracker export with no angle column θ; its columns are "
            f"{', '.join(map(repr, header))}"
        )
    t, angle = _complete(_column(p, header, rows, "t"), _column(p, header, rows, name))
    return Measurement("heading", t, _heading(p, angle, units or "deg"), str(p))


def _generic(
    p: Path,
    header: list[str],
    rows: list[list[str]],
    columns: Mapping[str, str],
    units: str | None,
) -> Measurement:
    if "time" not in columns:
        raise ValueError(
            f"{p}: a csv file needs its time column named (--time-column; in Python "
            "columns={'time': ...}), and either its heading column (--heading-column) "
            "or its three rate columns (--rate-columns X Y Z); its columns are "
            f"{', '.join(map(repr, header))}"
        )
    if "heading" in columns and any(a in columns for a in "xyz"):
        raise ValueError(
            f"{p}: name either a heading column or three rate columns, not both"
        )
    t = _column(p, header, rows, columns["time"])
    if "heading" in columns:
        name = columns["heading"]
        if units is None:
            units = "deg" if _DEGREE_HEADER.search(name) else None
        if units is None:
            raise ValueError(
                f"{p}: say the units of the heading column {name!r}: angle_units='deg' "
                "or 'rad' (--angle-units)"
            )
        angle = _column(p, header, rows, name)
        return Measurement("heading", t, _heading(p, angle, units), str(p))
    missing = [a for a in "xyz" if a not in columns]
    if missing:
        raise ValueError(
            f"{p}: columns must name 'heading', or all of 'x', 'y', 'z' (the rates in "
            f"rad/s); {', '.join(missing)} missing"
        )
    rates = np.stack([_column(p, header, rows, columns[a]) for a in "xyz"], axis=1)
    return Measurement("gyro", t, rates, str(p))


def _heading(p: Path, angle: np.ndarray, units: str) -> np.ndarray:
    """The heading in radians, unwrapped; refuses radians that look like degrees."""
    if units not in ("deg", "rad"):
        raise ValueError(f"angle_units must be 'deg' or 'rad', got {units!r}")
    finite = angle[np.isfinite(angle)]
    if units == "rad" and finite.size and np.abs(finite).max() > 2 * math.pi + 1e-9:
        jumps = np.abs(np.diff(finite))
        if np.abs(finite).max() <= 180.0 + 1e-9 and jumps.size and jumps.max() > 180.0:
            raise ValueError(
                f"{p}: the heading was given in radians but lies within ±180 and jumps "
                f"by {jumps.max():.0f}: degrees wrapped to (-180, 180]; give "
                "angle_units='deg'"
            )
    radians = np.radians(angle) if units == "deg" else angle
    out = radians.copy()
    ok = np.isfinite(radians)
    out[ok] = np.unwrap(radians[ok])
    return out


def _read_netcdf(p: Path) -> Measurement:
    import xarray as xr

    try:
        ds = xr.open_dataset(p)
    except (OSError, ValueError) as exc:
        raise ValueError(
            f"{p}: cannot be read as netCDF ({type(exc).__name__}); name the file's own "
            "format (--format, format=), or leave it out to have it detected"
        ) from None
    with ds:
        return from_dataset(ds, str(p))


def from_dataset(ds: Any, source: str = "dataset") -> Measurement:
    """A measurement from an xarray dataset with a ``time`` coordinate and a
    ``heading`` (rad) or ``omega`` (rad/s, over ``body_axis``) variable: a measured
    series saved with xarray, or a rattlesweep run."""
    if "time" not in ds.coords:
        raise ValueError(f"{source}: no 'time' coordinate")
    t = np.asarray(ds["time"].values, dtype=float)
    if "omega" in ds:
        omega = ds["omega"]
        if "trajectory" in omega.dims:
            raise ValueError(f"{source}: holds several trajectories; select one")
        return Measurement(
            "gyro", t, np.asarray(omega.transpose("time", ...).values), source
        )
    if "heading" in ds:
        return Measurement(
            "heading", t, np.asarray(ds["heading"].values, dtype=float), source
        )
    raise ValueError(f"{source}: no 'heading' or 'omega' variable")
