"""Writing a design's files into its directory."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from .._version import __version__
from ..io import write_netcdf
from ..sweep import Sweep
from .maps import MAP_TILT, write_map
from .mesh import write_stl
from .record import design_document, write_toml
from .sheet import write_sheet

if TYPE_CHECKING:
    from .api import Design

__all__ = ["write_files"]


def _sections(d: "Design", files: dict[str, Path]) -> dict[str, dict[str, Any]]:
    p, s, coin = d.part, d.part.settings, d.part.coin
    return {
        "shell": {"a": p.a, "b": p.b, "c": p.c, "print_mass": d.prediction["print_mass"],
                  "stl": files["stl"].name, "stl_units": "mm",
                  "print_pose": "flat face down on the bed (the body turned half a turn "
                  "about x); no supports"},
        "print": s.describe(),
        "coins": {**coin.describe(), "count": 2,
                  "centres": [[x, y, -coin.thickness / 2] for x, y in p.pockets],
                  "pocket_diameter": 2 * p.pocket_radius, "pocket_depth": coin.thickness},
        "prediction": {k: v for k, v in d.prediction.items()},
        "launches": d.launches.describe(),
        "files": {k: v.name for k, v in files.items()},
    }


def map_sweep(d: "Design") -> Sweep:
    """The design's reversal map as a sweep (``rattlesweep sweep sweep.toml``)."""
    mu = d.launches.mu
    return Sweep(
        axes={"spin": {"start": -12.0, "stop": 12.0, "num": 41},
              "mu": {"start": mu[0], "stop": mu[1], "num": 9} if mu[1] > mu[0]
              else [mu[0]]},
        fixed={"body": d.body, "t_end": d.launches.t_end,
               "roll_deg": math.degrees(MAP_TILT[0]), "pitch_deg": math.degrees(MAP_TILT[1])},
        stop="first_reversal", name="rattlesweep design: reversal map")


def _write_data(ds: xr.Dataset, d: "Design", path: Path, title: str) -> Path:
    """Write a dataset of the design as netCDF with the design in its attributes."""
    ds = ds.copy()
    for name in ds.data_vars:
        if ds[name].dtype == bool:  # netCDF has no boolean type
            ds[name] = ds[name].astype(np.int8)
    ds.attrs = {**ds.attrs, "title": title, "rattlesweep_version": __version__,
                "part": json.dumps({"a": d.part.a, "b": d.part.b, "c": d.part.c,
                                    "x": d.part.x, "y": d.part.y,
                                    "coin": d.part.coin.describe(),
                                    "print": d.part.settings.describe()}),
                "launch_set": json.dumps(d.launches.describe()), "prefer": d.prefer,
                "margin": d.margin}
    return write_netcdf(ds, path)


def write_files(d: "Design", out: Path) -> dict[str, Path]:
    """Write the STL, the placement sheet, the reversal map (PNG and netCDF), the search
    (``search.nc``: every candidate and launch), ``sweep.toml`` and ``design.toml`` into
    ``out`` (made if missing); returns the paths by kind."""
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {"stl": write_stl(d.part, out / "rattleback.stl")}
    files["sheet_png"], files["sheet_pdf"] = write_sheet(d.part, d.prefer, out)
    if d.reversal_map is not None:
        spins = (min(d.launches.spins), max(d.launches.spins))
        files["reversal_map"] = write_map(d.reversal_map, d.prefer, spins,
                                          out / "reversal_map.png")
    files["search"] = _write_data(d.search.data, d, out / "search.nc",
                                  "rattlesweep design: placement search")
    if d.reversal_map is not None:
        files["reversal_map_data"] = _write_data(d.reversal_map, d, out / "reversal_map.nc",
                                                 "rattlesweep design: reversal map")
    sweep_path = out / "sweep.toml"
    tmp = sweep_path.with_name("sweep.toml.tmp")
    tmp.write_text(map_sweep(d).to_toml(), encoding="ascii")
    tmp.replace(sweep_path)
    files["sweep"] = sweep_path
    files["design"] = out / "design.toml"
    write_toml(design_document(d.body, _sections(d, files)), files["design"],
               comment="rattlesweep design: a printable rattleback with coins "
               "(rattlesweep.design.load_body reads [body])")
    return files
