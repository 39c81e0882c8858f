"""Writing a design's files into its directory."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from .._version import __version__
from ..io import write_netcdf
from ..sweep import Sweep
from .maps import map_tilt, write_map
from .mesh import write_stl
from .record import design_document, write_toml
from .sheet import write_sheet

if TYPE_CHECKING:
    from .api import Design

__all__ = ["FILE_NAMES", "check_out", "write_files"]

FILE_NAMES = (
    "rattleback.stl",
    "placement_sheet.png",
    "placement_sheet.pdf",
    "reversal_map.png",
    "search.nc",
    "reversal_map.nc",
    "sweep.toml",
    "design.toml",
)
"""The files a design writes."""


def _sections(d: "Design", files: dict[str, Path]) -> dict[str, dict[str, Any]]:
    p, s, coin = d.part, d.part.settings, d.part.coin
    return {
        "shell": {
            "a": p.a,
            "b": p.b,
            "c": p.c,
            "print_mass": d.prediction["print_mass"],
            "stl": files["stl"].name,
            "stl_units": "mm",
            "print_pose": "flat face down on the bed (the body turned half a turn "
            "about x); no supports",
        },
        "print": s.describe(),
        "coins": {
            **coin.describe(),
            "count": 2,
            "centres": [[x, y, -coin.thickness / 2] for x, y in p.pockets],
            "pocket_diameter": 2 * p.pocket_radius,
            "pocket_depth": coin.thickness,
        },
        "prediction": {k: v for k, v in d.prediction.items()},
        "launches": d.launches.describe(),
        "files": {k: v.name for k, v in files.items()},
    }


def map_sweep(d: "Design") -> Sweep:
    """The design's reversal map as a sweep (``rattlesweep sweep sweep.toml``)."""
    mu = d.launches.mu
    roll, pitch = map_tilt(d.launches)
    return Sweep(
        axes={
            "spin": {"start": -12.0, "stop": 12.0, "num": 41},
            "mu": {"start": mu[0], "stop": mu[1], "num": 9} if mu[1] > mu[0] else [mu[0]],
        },
        fixed={
            "body": d.body,
            "t_end": d.launches.t_end,
            "roll_deg": math.degrees(roll),
            "pitch_deg": math.degrees(pitch),
        },
        stop="first_reversal",
        name=map_sweep_name(),
    )


def map_sweep_name() -> str:
    """The name of a design's map sweep, by which its ``sweep.toml`` is known."""
    return "rattlesweep design: reversal map"


SWEEP_STATE = ("tiles", "sweep.nc", "sweep.zarr")
"""What a sweep keeps in its directory (and a design never writes)."""


def _another_tool(out: Path) -> str | None:
    """What in ``out`` belongs to another tool, which a design must not replace: a
    sweep's state, or a ``sweep.toml`` that is not a design's (no ``design.toml``
    beside it, and not named as a design's map)."""
    state = [name for name in SWEEP_STATE if (out / name).exists()]
    if state:
        return f"a sweep ({', '.join(state)})"
    config = out / "sweep.toml"
    if config.exists() and not (out / "design.toml").exists():
        try:
            name = Sweep.from_toml(config).name
        except (OSError, ValueError):
            name = None
        if name != map_sweep_name():
            return "a sweep's configuration (sweep.toml)"
    return None


def check_out(out: Path, overwrite: bool) -> None:
    """ValueError unless ``out`` is a directory that does not exist yet or is empty
    (with ``overwrite``: any directory that holds no other tool's files a design
    would replace), naming the path and what is there."""
    if out.exists() and not out.is_dir():
        raise ValueError(
            f"out = {str(out)!r} is invalid: it is a file, and must be a "
            "directory (new or empty)"
        )
    if not out.is_dir():
        return
    if overwrite:
        foreign = _another_tool(out)
        if foreign is not None:
            raise ValueError(
                f"out = {str(out)!r} holds {foreign}: a design never replaces another "
                "tool's files, --force (overwrite=True) included; give a new or empty "
                "directory"
            )
        return
    held = sorted(entry.name for entry in out.iterdir())
    if not held:
        return
    ours = [name for name in held if name in FILE_NAMES]
    what = (
        f"a previous design ({len(ours)} of its {len(FILE_NAMES)} files: {', '.join(ours)})"
        if ours
        else f"{len(held)} entries"
    )
    others = [name for name in held if name not in FILE_NAMES]
    shown = ", ".join(others[:6]) + (", ..." if len(others) > 6 else "")
    raise ValueError(
        f"out = {str(out)!r} already holds {what}"
        + (
            f" and other files ({shown})"
            if ours and others
            else (f": {shown}" if not ours else "")
        )
        + "; rattlesweep design does not overwrite them: give a new or empty directory, "
        "or --force (overwrite=True in Python) to replace the design's files there"
    )


def _write_data(ds: xr.Dataset, d: "Design", path: Path, title: str) -> Path:
    """Write a dataset of the design as netCDF with the design in its attributes."""
    ds = ds.copy()
    for name in ds.data_vars:
        if ds[name].dtype == bool:  # netCDF has no boolean type
            ds[name] = ds[name].astype(np.int8)
    ds.attrs = {
        **ds.attrs,
        "title": title,
        "rattlesweep_version": __version__,
        "part": json.dumps(
            {
                "a": d.part.a,
                "b": d.part.b,
                "c": d.part.c,
                "x": d.part.x,
                "y": d.part.y,
                "coin": d.part.coin.describe(),
                "print": d.part.settings.describe(),
            }
        ),
        "launch_set": json.dumps(d.launches.describe()),
        "prefer": d.prefer,
        "margin": d.margin,
    }
    return write_netcdf(ds, path)


def write_files(d: "Design", out: Path, overwrite: bool = False) -> dict[str, Path]:
    """Write the STL, the placement sheet, the reversal map (PNG and netCDF), the search
    (``search.nc``: every candidate and launch), ``sweep.toml`` and ``design.toml`` into
    ``out`` (made if missing; see :func:`check_out` for when it may hold files); returns
    the paths by kind.

    Everything is written into a temporary directory beside ``out`` first and moved in
    when complete: a new ``out`` by one rename; into an existing one, its old
    ``design.toml`` is removed first and the new one renamed in last, so a design
    directory with a ``design.toml`` always holds one complete design (an install
    interrupted between its renames leaves none, which a new ``--force`` replaces)."""
    check_out(out, overwrite)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp's 0700 would stay with ``out`` after the rename
    try:
        written = _write_all(d, tmp)
        if not out.exists():
            os.rename(tmp, out)
        else:
            check_out(out, overwrite)  # nothing appeared there meanwhile
            record = written["design"]
            (out / record.name).unlink(missing_ok=True)
            for path in written.values():
                if path != record:
                    os.replace(path, out / path.name)
            os.replace(record, out / record.name)
            tmp.rmdir()
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return {kind: out / path.name for kind, path in written.items()}


def _write_all(d: "Design", out: Path) -> dict[str, Path]:
    not_robust = None if d.robust else not_robust_banner(d)
    files: dict[str, Path] = {"stl": write_stl(d.part, out / "rattleback.stl")}
    files["sheet_png"], files["sheet_pdf"] = write_sheet(
        d.part, d.prefer, out, not_robust=not_robust
    )
    if d.reversal_map is not None:
        spins = (min(d.launches.spins), max(d.launches.spins))
        files["reversal_map"] = write_map(
            d.reversal_map, d.prefer, spins, out / "reversal_map.png", not_robust=not_robust
        )
    files["search"] = _write_data(
        d.search.data, d, out / "search.nc", "rattlesweep design: placement search"
    )
    if d.reversal_map is not None:
        files["reversal_map_data"] = _write_data(
            d.reversal_map, d, out / "reversal_map.nc", "rattlesweep design: reversal map"
        )
    files["sweep"] = out / "sweep.toml"
    files["sweep"].write_text(map_sweep(d).to_toml(), encoding="ascii")
    files["design"] = out / "design.toml"
    write_toml(
        design_document(d.body, _sections(d, files)),
        files["design"],
        comment="rattlesweep design: a printable rattleback with coins "
        "(rattlesweep simulate --body design.toml reads [body])",
    )
    return files


def not_robust_banner(d: "Design") -> str:
    """Two lines for the sheet and the map of a design that is not robust."""
    pred = d.prediction
    return (
        f"NOT ROBUST: read the summary's advice before you print\n"
        f"{pred['bad_sense_reversed_fraction']:.0%} of the wrong-way launches reversed "
        f"(all should), {pred['preferred_sense_reversed_fraction']:.0%} of the "
        f"right-way ones (none should), within {d.launches.t_end:g} s"
    )
