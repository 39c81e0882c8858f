"""A fit's files: ``fit.toml`` (the fitted inputs with their intervals, the fixed ones,
the quality, and the fitted body as a ``[body]`` table, so that ``rattlesweep simulate
--body fit.toml`` runs the fitted rattleback), ``fit.nc`` (data, best model, residuals)
and ``fit.png`` (data over model, residuals and the intervals)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..io import write_netcdf, write_text_atomic
from ..sweep._config.schema import body_table
from ..sweep._config.toml_io import format_toml, plain
from .api import FitResult
from .sensor import SENSOR_NAMES

__all__ = ["plain_record", "simulate_command", "write_fit"]

NAMES = ("fit.toml", "fit.nc", "fit.png")


def plain_record(value: Any) -> Any:
    """A fit's record as TOML data, to 8 significant digits (its intervals are good to
    far fewer)."""
    return plain(value, digits=8)


def simulate_command(result: FitResult, toml: str = "fit.toml") -> str:
    """The command line that runs the fitted rattleback: its body from ``toml`` (with
    the sensor's mass, if any) and its fitted and fixed inputs as options."""
    values = {**result.fixed, **{f.name: f.value for f in result.fitted.values()}}
    options = " ".join(
        f"--{name.replace('_', '-')} {value:.6g}"
        for name, value in values.items()
        if name not in ("delta", "delta_deg", "t_end", *SENSOR_NAMES)
    )
    duration = float(result.dataset["time"][-1])
    return f"rattlesweep simulate --body {toml} {options} --t-end {duration:.6g}"


def document(result: FitResult) -> dict[str, Any]:
    """fit.toml's contents."""
    fitted = {
        f.name: {
            "value": f.value,
            "low": f.low,
            "high": f.high,
            "units": f.units,
            "determined": f.determined,
        }
        for f in result.fitted.values()
    }
    return plain_record(
        {
            "rattlesweep_version": __version__,
            "body": body_table(result.body),
            "fitted": fitted,
            "offsets": result.offsets,
            "fixed": result.fixed,
            "defaults": result.defaults,
            "simulate": simulate_command(result),
            "quality": {
                "chi2": result.chi2,
                "reduced_chi2": result.reduced_chi2,
                "residual_rms": result.residual_rms,
                "model_runs": result.evaluations,
                "seconds": result.seconds,
            },
            "notes": {"text": result.notes},
        }
    )


def write_fit(
    result: FitResult, out: str | os.PathLike, overwrite: bool = False
) -> list[Path]:
    """Write the fit's three files into ``out`` (created), each through a temporary
    file; refuses to replace them unless ``overwrite``, and never replaces another
    tool's files."""
    directory = Path(out)
    if directory.exists() and not directory.is_dir():
        raise ValueError(f"{directory}: exists and is not a directory")
    taken = [directory / n for n in NAMES if (directory / n).exists()]
    if taken and not overwrite:
        raise ValueError(
            f"{directory} holds a fit already ({', '.join(p.name for p in taken)}): "
            "choose another --out, or --force to replace it"
        )
    directory.mkdir(parents=True, exist_ok=True)
    toml = directory / "fit.toml"
    write_text_atomic(
        toml,
        format_toml(
            document(result),
            comment="rattlesweep fit: each fitted input with its 95 % interval (low, high)",
        ),
    )
    ds = result.dataset.copy()
    ds.attrs.update(
        title="rattlesweep fit: measured against best model",
        Conventions="CF-1.8",
        source=f"rattlesweep {__version__}",
        fit=format_toml(document(result)),
    )
    nc = write_netcdf(ds, directory / "fit.nc")
    png = _figure(result, directory / "fit.png")
    return [toml, nc, png]


def _units(units: str) -> str:
    return "" if units == "1" else f" {units}"


def _interval(f: Any) -> str:
    """The interval as a reader takes it: both ends, one end and a bound, or none."""
    if f.determined:
        return f"[{f.low:.4g} … {f.high:.4g}]"
    if f.low_determined:
        return f"[≥ {f.low:.4g}; not bounded above within {f.high:.4g}]"
    if f.high_determined:
        return f"[≤ {f.high:.4g}; not bounded below within {f.low:.4g}]"
    return f"[not determined within its bounds {f.low:.4g} … {f.high:.4g}]"


def _figure(result: FitResult, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    ds = result.dataset
    t = ds["time"].values
    fig, axes = plt.subplots(
        3,
        1,
        figsize=(9, 8),
        gridspec_kw={"height_ratios": [3, 1, 1.4]},
        constrained_layout=True,
    )
    top, res, text = axes
    if "measured_heading" in ds:
        top.plot(t, np.degrees(ds["measured_heading"]), ".", ms=2, label="measured")
        top.plot(t, np.degrees(ds["model_heading"]), "-", lw=1.2, label="best model")
        top.set_ylabel("heading (°)")
        res.plot(t, np.degrees(ds["residual_heading"]), ".", ms=2)
        res.set_ylabel("measured − model (°)")
    else:
        for k, axis in enumerate("xyz"):
            line = top.plot(t, ds["measured_rate"][:, k], ".", ms=1.5, alpha=0.5)[0]
            top.plot(
                t,
                ds["model_rate"][:, k],
                "-",
                lw=1.0,
                color=line.get_color(),
                label=f"ω{axis}",
            )
            res.plot(t, ds["residual_rate"][:, k], ".", ms=1.5, color=line.get_color())
        top.set_ylabel("rate (rad/s)")
        res.set_ylabel("measured − model (rad/s)")
    top.set_title("measured (dots) and the best model (lines)")
    top.legend(loc="upper right", fontsize=8)
    res.set_xlabel("time from the release (s)")
    for ax in (top, res):
        ax.grid(alpha=0.3)
    text.axis("off")
    lines = ["Fitted (95 % interval):"]
    for f in result.fitted.values():
        lines.append(f"  {f.name} = {f.value:.4g}{_units(f.units)}   {_interval(f)}")
    lines.append(f"reduced χ² {result.reduced_chi2:.3g}")
    lines += [f"note: {n}" for n in result.notes[:3]]
    text.text(
        0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=9, wrap=True
    )
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path
