"""The ``rattlesweep`` command line: sweeps, resuming, maps, file summaries, single runs
and their animations."""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._version import __version__

if TYPE_CHECKING:
    import xarray as xr

    from .rattleback.body import Body
    from .sweep import Sweep

__all__ = ["build_parser", "main"]


def _command(argv: list[str] | None) -> str:
    return "rattlesweep " + shlex.join(sys.argv[1:] if argv is None else argv)


def _save_map(ds: xr.Dataset, png: Path, var: str = "outcome") -> Path:
    from .plot import reversal_map

    dims = [d for d in ds.attrs.get("sweep_dims", list(ds.dims)) if d in ds[var].dims]
    if len(dims) < 2:
        raise ValueError(f"a map needs two sweep dimensions; this sweep has {dims}")
    facet = dims[2] if len(dims) > 2 else None
    select = {d: ds[d].values[0] for d in dims[3:]}
    fig = reversal_map(ds, x=dims[0], y=dims[1], var=var, facet=facet, select=select or None)
    fig.savefig(png, dpi=120)
    return png


def _summary(ds: xr.Dataset) -> str:
    import numpy as np

    flags = list(ds.outcome.attrs["flag_values"])
    names = ds.outcome.attrs["flag_meanings"].split()
    values, counts = np.unique(np.asarray(ds.outcome.values).ravel(), return_counts=True)
    found = dict(zip(values.tolist(), counts.tolist()))
    return ", ".join(f"{n.replace('_', ' ')} {found[f]}" for f, n in zip(flags, names)
                     if found.get(f))


def _sweep_args(args: argparse.Namespace) -> dict[str, Any]:
    if args.scheduler and args.workers:
        raise ValueError("--workers sets local threads; with --scheduler the cluster's size "
                         "is set where it was started")
    return {"scheduler": args.scheduler, "workers": args.workers,
            "progress": not args.quiet}


def _points(ds: xr.Dataset) -> str:
    """How many points a result holds, and how many of them were simulated."""
    n = int(ds.outcome.size)
    if "points_simulated" not in ds.attrs:
        return f"{n} launches"
    simulated = int(ds.attrs["points_simulated"])
    return f"{n} points ({simulated} simulated, {simulated / n:.1%})"


def _run(sweep: Sweep, out: str, args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep.run import RESULT_NAME, run_sweep

    try:
        ds = run_sweep(sweep, out, command=_command(argv), **_sweep_args(args))
    except KeyboardInterrupt:
        return 130
    written = out if sweep.output == "zarr" else Path(out) / RESULT_NAME
    print(f"wrote {written}: {_points(ds)}; {_summary(ds)}")
    return 0


def _cmd_sweep(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep import Sweep

    sweep = Sweep.from_toml(Path(args.config))
    changes = {}
    if args.output is not None and args.output != sweep.output:
        changes["output"] = args.output
    if args.stop is not None:
        changes["stop"] = None if args.stop == "t_end" else args.stop
    if args.refine is not None and args.refine < 0:
        raise ValueError(f"--refine must be an integer >= 0 (levels of refinement; 0: "
                         f"none), got {args.refine}")
    if args.refine is not None:
        changes["refine"] = {**(sweep.refine or {}), "levels": args.refine} if (
            args.refine > 0) else None
    if changes:
        sweep = Sweep(**{**sweep.to_dict(), **changes})
    if args.dry_run:
        return _dry_run(sweep, args)
    if args.out is None:
        raise ValueError("--out is required to run a sweep (only --dry-run goes without)")
    return _run(sweep, args.out, args, argv)


def _dry_run(sweep: Sweep, args: argparse.Namespace) -> int:
    from .sweep.estimate import estimate, format_estimate
    from .sweep.run import _cores

    _sweep_args(args)  # the same checks of the options as a run
    if args.scheduler:
        workers, where = 1, (f"one worker of the cluster at {args.scheduler} (divide by "
                             "its number of single-threaded workers)")
    else:
        workers = args.workers or _cores()
        where = f"{workers} local thread{'s' if workers > 1 else ''}"
    print(format_estimate(sweep, estimate(sweep, workers), where))
    return 0


def _cmd_resume(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep.run import stored_sweep

    return _run(stored_sweep(args.dir), args.dir, args, argv)


def _cmd_export(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep.run import export

    path = export(args.store, args.out)
    print(f"wrote {path}")
    return 0


def _cmd_verify(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep.verify import verify

    failed = 0
    for out in args.outputs:
        found = verify(out)
        print(found.report())
        failed += not found.ok
    return 1 if failed else 0


def _cmd_demo(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .sweep import Sweep
    from .sweep.demo import DEMO_TOML
    from .sweep.run import RESULT_NAME, run_sweep

    if args.print_config:
        print(DEMO_TOML, end="")
        return 0
    out = Path(args.out)
    t0 = time.perf_counter()
    try:
        ds = run_sweep(Sweep.from_toml(DEMO_TOML), out, command=_command(argv),
                       **_sweep_args(args))
    except KeyboardInterrupt:
        return 130
    png = _save_map(ds, out / "reversal_map.png")
    print(f"{ds.attrs['sweep_name']}: {_points(ds)} in {time.perf_counter() - t0:.1f} s; "
          f"{_summary(ds)}")
    print(f"wrote {out / RESULT_NAME} and {png}")
    return 0


def _cmd_stability(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .io import write_netcdf
    from .stability import stability_dataset
    from .sweep import Sweep

    t0 = time.perf_counter()
    ds = stability_dataset(Sweep.from_toml(Path(args.config)), command=_command(argv))
    path = write_netcdf(ds, args.out)
    unstable = float((ds.growth_rate > 0).mean())
    print(f"wrote {path}: {int(ds.growth_rate.size)} grid points in "
          f"{time.perf_counter() - t0:.2f} s; {unstable:.0%} unstable, largest growth rate "
          f"{float(ds.growth_rate.max()):.4g} s-1")
    return 0


def _open_netcdf(path: str) -> xr.Dataset:
    """A result file, or a ValueError saying it is none (not xarray's list of
    backends)."""
    import xarray as xr

    try:
        return xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc).strip() else type(exc).__name__
        if "did not find a match" in reason:
            reason = "it is not a netCDF file"
        raise ValueError(f"cannot read {path}: expected a rattlesweep result file "
                         f"(netCDF; a zarr store: `rattlesweep export` it first); "
                         f"{reason}") from None


def _cmd_plot(args: argparse.Namespace, argv: list[str] | None) -> int:
    import xarray as xr

    from .plot import reversal_map, reversal_vs_growth

    select = {}
    for item in args.select or []:
        key, _, value = item.partition("=")
        if not _:
            raise ValueError(f"--select takes DIM=VALUE, got {item!r}")
        try:
            select[key] = float(value)
        except ValueError:
            select[key] = value
    for path in (*args.files, *filter(None, (args.overlay, args.versus))):
        _warn_damaged(Path(path), "plot")
    overlay = _open_netcdf(args.overlay) if args.overlay else None
    for path in args.files:
        with _open_netcdf(path) as ds:
            if args.versus:
                with xr.open_dataset(args.versus) as sweep:
                    fig = reversal_vs_growth(ds, sweep, color_by=args.facet)
                name = "reversal_vs_growth"
            else:
                var = args.var or ("outcome" if "outcome" in ds else "growth_rate")
                dims = [d for d in ds.attrs.get("sweep_dims", list(ds.dims))]
                x = args.x or dims[0]
                y = args.y or next((d for d in dims if d != x), None)
                if y is None:
                    raise ValueError(f"{path}: a map needs two dimensions, found {dims}")
                fig = reversal_map(ds, x=x, y=y, var=var, facet=args.facet,
                                   select=select or None, reduce=args.reduce,
                                   overlay=overlay)
                name = var
            png = Path(args.out) if args.out and len(args.files) == 1 else \
                Path(path).with_name(f"{Path(path).stem}_{name}.png")
            fig.savefig(png, dpi=args.dpi)
            print(f"wrote {png}")
    if overlay is not None:
        overlay.close()
    return 0


def _sweep_output(path: Path) -> Path | None:
    """The sweep output ``path`` is or belongs to: a zarr store, a sweep directory, or
    the directory of a merged ``sweep.nc``; None for a file of no sweep directory."""
    from .sweep.directory import CONFIG_NAME, RESULT_NAME
    from .sweep.zarr_store import is_zarr_store

    if is_zarr_store(path) or (path / CONFIG_NAME).is_file():
        return path
    if path.name == RESULT_NAME and (path.parent / CONFIG_NAME).is_file():
        return path.parent
    return None


def _warn_damaged(path: Path, command: str) -> Path | None:
    """Verify the sweep output ``path`` is or belongs to (what ``rattlesweep verify``
    does) and warn on stderr about any tile or merged file damaged or lost; tiles of an
    unfinished output not computed yet are no damage. Returns the output warned
    about."""
    from .sweep.verify import verify

    out = _sweep_output(path)
    if out is None:
        return None
    try:
        found = verify(out)
    except ValueError as exc:
        print(f"rattlesweep {command}: warning: {out} cannot be verified: {exc}",
              file=sys.stderr)
        return out
    if not (found.damaged or found.problems or (found.missing and found.finished)):
        return None
    head, *lines = found.report().splitlines()
    print(f"rattlesweep {command}: warning: {out} is damaged ({head.split(': ', 1)[1]}; "
          f"`rattlesweep verify {out}` lists the same):", *lines, sep="\n",
          file=sys.stderr)
    return out


def _info_directory(path: Path) -> Path | None:
    """The merged result of a sweep directory, or None after printing the progress of an
    unfinished one; ValueError when ``path`` is no sweep directory."""
    from .sweep.zarr_store import is_zarr_store

    if is_zarr_store(path):
        return path
    if (path / "sweep.nc").is_file():
        return path / "sweep.nc"
    if not (path / "sweep.toml").is_file():
        raise ValueError(f"{path} is a directory without sweep.nc or sweep.toml: expected a "
                         "sweep directory (what 'rattlesweep sweep --out DIR' writes)")
    from .sweep.directory import read_config

    sweep = read_config(path / "sweep.toml")
    print(f"{path} (unfinished sweep: no sweep.nc yet)")
    print(f"  name: {sweep.name}")
    print("  dimensions: " + ", ".join(f"{d} ({n})" for d, n in zip(sweep.dims, sweep.shape)))
    if sweep.refine is not None:
        levels = sorted(path.glob("levels/level-*"))
        done = len(list(path.glob("levels/level-*/tile-*.nc")))
        fine = sweep.finest()
        print("  refined to: " + ", ".join(f"{d} ({n})" for d, n in zip(fine.dims, fine.shape)))
        print(f"  levels started: {len(levels)} of {sweep.refine['levels'] + 1}, {done} tiles "
              f"written; 'rattlesweep resume {path}' completes it")
        return None
    from .sweep.verify import verify

    found = verify(path)
    done = sweep.n_tiles - len(found.missing) - len(found.damaged)
    damaged = f", {len(found.damaged)} damaged" if found.damaged else ""
    print(f"  tiles written: {done} of {sweep.n_tiles} (complete and readable){damaged}; "
          f"'rattlesweep resume {path}' completes it")
    return None


def _open_result(path: Path) -> xr.Dataset:
    import xarray as xr

    from .sweep.zarr_store import is_zarr_store, open_result, stored_sweep, tiles_done

    if not is_zarr_store(path):
        return xr.open_dataset(path)
    sweep = stored_sweep(str(path))
    done = tiles_done(str(path), sweep.n_tiles)
    if done is not None and not done.all():
        print(f"{path} (unfinished zarr store: {int(done.sum())} of {sweep.n_tiles} tiles "
              f"written; 'rattlesweep resume {path}' completes it)")
    return open_result(str(path))


def _cmd_info(args: argparse.Namespace, argv: list[str] | None) -> int:
    failed = 0
    for name in args.files:
        path = Path(name)
        damaged = _warn_damaged(path, "info")
        try:
            if path.is_dir():
                result = _info_directory(path)
                if result is None:
                    continue
                path = result
        except ValueError as exc:
            print(f"rattlesweep info: {exc}", file=sys.stderr)
            failed += 1
            continue
        try:
            ds = _open_result(path)
        except (OSError, ValueError) as exc:
            reason = str(exc).splitlines()[0]
            if "did not find a match" in reason:
                reason = "it is not a netCDF file"
            if damaged is not None:
                print(f"rattlesweep info: cannot read {path} ({reason}): it is damaged; "
                      f"`rattlesweep resume {damaged}` writes it again", file=sys.stderr)
            else:
                print(f"rattlesweep info: cannot read {path}: expected a rattlesweep "
                      f"result file (netCDF) or a sweep directory; {reason}",
                      file=sys.stderr)
            failed += 1
            continue
        with ds:
            print(f"{path}")
            print(f"  title: {ds.attrs.get('title', '')}")
            print("  dimensions: " + ", ".join(f"{d} ({n})" for d, n in ds.sizes.items()))
            for name in ds.dims:
                if name in ds.coords:
                    c = ds[name]
                    units = c.attrs.get("units", "")
                    units = "" if units == "1" else units  # CF's dimensionless
                    vals = c.values
                    span = (f"{vals[0]} .. {vals[-1]}" if vals.dtype.kind in "fiu"
                            else ", ".join(map(str, vals)))
                    print(f"    {name}: {span} {units}  ({c.attrs.get('long_name', '')})")
            scalars = [f"{c}={ds[c].values.item()}" for c in ds.coords if ds[c].ndim == 0]
            if scalars:
                print("  fixed: " + ", ".join(scalars))
            print("  variables: " + ", ".join(map(str, ds.data_vars)))
            if "outcome" in ds:
                print(f"  outcomes: {_summary(ds)}")
            if "computed" in ds:
                simulated, n = int(ds.computed.sum()), int(ds.computed.size)
                print(f"  simulated: {simulated} of {n} points ({simulated / n:.1%}); the "
                      "others are filled from their refinement cell's corners (computed = 0)")
            for key in ("rattlesweep_version", "history"):
                if key in ds.attrs:
                    print(f"  {key}: {ds.attrs[key]}")
            if args.config and "sweep_config" in ds.attrs:
                print(ds.attrs["sweep_config"])
    return 2 if failed else 0


_SHAPE = ("a", "b", "c", "mass", "delta_deg")


def _body_from_args(args: argparse.Namespace) -> Body:
    """The preset, the body of ``--body FILE``, or a homogeneous semi-ellipsoid whose
    parameters not given are the ``toy`` preset's (as in a sweep file)."""
    from .rattleback.body import Body

    shape = {k: getattr(args, k) for k in _SHAPE if getattr(args, k) is not None}
    given = [o for o, used in (("--preset", args.preset is not None),
                               ("--body", args.body is not None),
                               ("--a/--b/--c/--mass/--delta-deg", bool(shape))) if used]
    if len(given) > 1:
        raise ValueError(f"{' and '.join(given)} each choose the body; give one of them")
    if args.body is not None:
        from .sweep.body_file import body_from_toml

        return body_from_toml(args.body)
    if shape:
        from .sweep.grid import semi_ellipsoid_defaults

        si = {**semi_ellipsoid_defaults(),
              **{k: v for k, v in shape.items() if k != "delta_deg"}}
        if "delta_deg" in shape:
            si["delta"] = math.radians(shape["delta_deg"])
        return Body.semi_ellipsoid(si["a"], si["b"], si["c"], si["mass"], si["delta"])
    return Body.preset(args.preset or "kane_levinson")


def _simulate_from_args(args: argparse.Namespace) -> xr.Dataset:
    from .rattleback.simulate import simulate

    return simulate(_body_from_args(args), spin=args.spin,
                    roll_deg=args.roll_deg, pitch_deg=args.pitch_deg,
                    yaw_deg=args.yaw_deg, velocity=args.velocity,
                    mu=args.mu, mu_static=args.mu_static, mu_spin=args.mu_spin,
                    mu_roll=args.mu_roll, damping=args.damping, g=args.g,
                    t_end=args.t_end, dt=args.dt, method=args.method)


def _cmd_simulate(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .io import write_netcdf

    ds = _simulate_from_args(args)
    if args.out:
        write_netcdf(ds, args.out)
        print(f"wrote {args.out}")
    if args.png:
        from .plot import spin_history

        spin_history([ds], [f"spin {args.spin:+g} rad/s"],
                     title=f"{ds.attrs.get('body_name', 'body')}, mu={args.mu:g}").savefig(
            args.png, dpi=120)
        print(f"wrote {args.png}")
    t_rev = float(ds.first_reversal_time)
    print(f"first reversal: {'none' if t_rev != t_rev else f'{t_rev:.4f} s'}; "
          f"reversals: {int(ds.n_reversals)}; final spin {float(ds.final_spin):+.4f} rad/s; "
          f"status: {ds.status.attrs['flag_meanings'].split()[int(ds.status)]}")
    return 0


def _cmd_animate(args: argparse.Namespace, argv: list[str] | None) -> int:
    import xarray as xr

    from .plot import animate

    if args.run is not None:
        with xr.open_dataset(args.run) as ds:
            run = ds.load()
    else:
        run = _simulate_from_args(args)
    t0 = time.perf_counter()
    animate(run, args.out, frames=args.frames, fps=args.fps, dpi=args.dpi,
            z_stretch=args.z_stretch)
    print(f"wrote {args.out}: {args.frames} frames at {args.fps:g} fps "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0


NOT_ROBUST_STATUS = 3
"""Exit status of ``rattlesweep design`` for a design that is not robust (without
``--accept-not-robust``); its files are written all the same."""


def _cmd_design(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .design import design

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    d = design(args.a, args.b, args.c, coin=args.coin, coin_mass=args.coin_mass,
               coin_diameter=args.coin_diameter, coin_thickness=args.coin_thickness,
               infill=args.infill, material=args.material, density=args.density,
               wall=args.wall, clearance=args.clearance, rim=args.rim,
               mu=tuple(args.mu), margin=args.margin, prefer=args.prefer, out=args.out,
               overwrite=args.force, progress=None if args.quiet else say)
    print(d.summary())
    print(f"wrote {', '.join(str(p) for p in d.files.values())} "
          f"({time.perf_counter() - t0:.1f} s)")
    if d.robust:
        return 0
    if args.accept_not_robust:
        print("the design is NOT ROBUST; accepted (--accept-not-robust)")
        return 0
    print(f"rattlesweep: the design is NOT ROBUST (see above); its files are written, "
          f"marked so, for you to inspect. Exit status {NOT_ROBUST_STATUS}; give "
          "--accept-not-robust to accept it.", file=sys.stderr)
    return NOT_ROBUST_STATUS


def _cmd_explore(args: argparse.Namespace, argv: list[str] | None) -> int:
    from .explore import PortInUse, serve

    try:
        serve(args.host, args.port, open_browser=not args.no_browser)
    except PortInUse as exc:
        print(f"rattlesweep explore: {exc.strerror}", file=sys.stderr)
        return 2
    return 0


def _add_launch_options(p: argparse.ArgumentParser) -> None:
    from .rattleback.body import PRESETS
    from .inputs import RATTLEBACK as INPUTS

    body = p.add_argument_group("body (one of: a preset, a TOML file, a semi-ellipsoid; "
                                "default: the kane_levinson preset)")
    body.add_argument("--preset", default=None, choices=sorted(PRESETS),
                      help="a preset body (default: kane_levinson, unless --body or a "
                      "semi-ellipsoid option is given)")
    body.add_argument("--body", default=None, metavar="FILE.toml",
                      help="the body of the file's [body] table: a, b, c, mass, com, "
                      "inertia[, full_ellipsoid, name] in SI units, as in a sweep file "
                      "(a sweep file's fixed.body works too); default: none")
    for name, what in (("a", "long semi-axis (m)"), ("b", "short semi-axis (m)"),
                       ("c", "depth semi-axis (m)"), ("mass", "mass (kg)")):
        body.add_argument(f"--{name}", type=float, default=None,
                          help=f"homogeneous semi-ellipsoid: {what} (default: the toy "
                          "preset's)")
    body.add_argument("--delta-deg", type=float, default=None,
                      help="homogeneous semi-ellipsoid: misalignment of the inertia axes "
                      "(degrees; default: the toy preset's)")
    launch = p.add_argument_group("launch")
    launch.add_argument("--spin", type=float, default=5.0,
                        help="rad/s about the vertical, positive counter-clockwise from above")
    launch.add_argument("--roll-deg", type=float, default=0.5,
                        help="initial roll (degrees; raises the body's +y side)")
    launch.add_argument("--pitch-deg", type=float, default=0.0,
                        help="initial pitch (degrees; lowers the body's +x end)")
    launch.add_argument("--yaw-deg", type=float, default=0.0,
                        help="initial heading (degrees about the vertical)")
    launch.add_argument("--velocity", type=float, nargs=2, default=None,
                        metavar=("VX", "VY"), help="horizontal velocity of G (m/s), a "
                        "sliding launch (default: the velocity at which the contact rolls)")
    friction = p.add_argument_group("friction and numerics")
    for name in ("mu", "mu_static", "mu_spin", "mu_roll", "damping", "g", "t_end", "dt"):
        spec = INPUTS[name]
        default = spec.default if isinstance(spec.default, float) else None
        text = spec.long_name + ("" if spec.units == "1" else f" ({spec.units})")
        if name == "t_end":  # required by run_batch; here a quick look from the terminal
            default = 10.0
        elif spec.default_doc:
            text += f"; default: {spec.default_doc.replace('`', '')}"
        friction.add_argument(f"--{name.replace('_', '-')}", type=float, default=default,
                              help=text)
    friction.add_argument("--method", choices=["rk4", "euler"], default="rk4",
                          help="integrator: RK4, or first-order semi-implicit Euler")


def _add_run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a running dask.distributed scheduler (default: none, "
                   "local threads)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local threads (default: all usable cores)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Adds each option's default to its help, unless the help says it already; flags
    (default off) and options without a default say what leaving them out means."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if ("default" in text or not action.option_strings or action.required
                or action.default is None or action.default is False
                or action.default is argparse.SUPPRESS):
            return text
        return f"{text} (default: %(default)s)" if text else "default: %(default)s"


class _Parser(argparse.ArgumentParser):
    """Every parser and subcommand parser shows the defaults in its --help."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rattlesweep", description=__doc__)
    parser.add_argument("--version", action="version", version=f"rattlesweep {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("sweep", help="run a sweep from a TOML file into a directory")
    p.add_argument("config", help="sweep configuration (TOML)")
    p.add_argument("--out", default=None,
                   help="output: a directory (netCDF) or a zarr store (a path or URL); "
                   "required unless --dry-run (default: none)")
    p.add_argument("--dry-run", action="store_true",
                   help="compute and write nothing: print the points, tiles, and the time "
                   "and memory expected (timed on a sample of the grid's launches)")
    p.add_argument("--output", choices=["netcdf", "zarr"], default=None,
                   help="output format (default: the configuration's 'output', netcdf)")
    p.add_argument("--refine", type=int, default=None, metavar="LEVELS",
                   help="refine the grid adaptively this many levels (each halves the "
                   "spacing of the refined axes; 0: no refinement); default: the "
                   "configuration's [refine]")
    p.add_argument("--stop", choices=["first_reversal", "t_end"], default=None,
                   help="end each launch at its first reversal, or run it to t_end "
                   "(default: the configuration's 'stop', t_end)")
    _add_run_options(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("resume", help="finish an interrupted sweep in DIR (a sweep "
                       "directory or zarr store)")
    p.add_argument("dir")
    _add_run_options(p)
    p.set_defaults(func=_cmd_resume)

    p = sub.add_parser("demo", help="run the default sweep (toy rattleback, spin x "
                       "misalignment x friction, refined adaptively, each launch stopped "
                       "at its first reversal); write the netCDF file and a map PNG")
    p.add_argument("--out", default="rattlesweep-demo", help="output directory")
    p.add_argument("--print-config", action="store_true",
                   help="print the demo's TOML configuration and exit")
    _add_run_options(p)
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("export", help="write a finished zarr store as one netCDF file")
    p.add_argument("store", help="zarr store (a path or URL)")
    p.add_argument("out", help="netCDF file to write")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("verify", help="read back every tile of sweep outputs (sweep "
                       "directories or zarr stores) and name what is missing or damaged; "
                       "exit status 1 if anything is")
    p.add_argument("outputs", nargs="+", metavar="OUT",
                   help="sweep directory or zarr store (a path or URL)")
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("plot", help="draw a map of a sweep result to PNG")
    p.add_argument("files", nargs="+", help="sweep result netCDF file(s)")
    p.add_argument("--var", default=None,
                   help="variable (default: outcome, or growth_rate for stability files)")
    p.add_argument("--x", default=None, help="dimension across (default: the first)")
    p.add_argument("--y", default=None, help="dimension up (default: the second)")
    p.add_argument("--facet", default=None, help="dimension to draw one panel per value (default: none, "
                   "one panel)")
    p.add_argument("--select", action="append", metavar="DIM=VALUE",
                   help="fix another dimension (nearest value); repeatable (default: "
                   "the first value of each dimension not drawn)")
    p.add_argument("--reduce", choices=["mean"], default=None,
                   help="average a continuous variable over the remaining dimensions "
                   "(default: none, select instead)")
    p.add_argument("--overlay", default=None, metavar="SWEEP.nc",
                   help="draw this sweep's simulated reversal boundary on the map "
                   "(default: none)")
    p.add_argument("--versus", default=None, metavar="SWEEP.nc",
                   help="instead of a map: first reversal time in SWEEP.nc against the "
                   "stability file's 1/growth rate (coloured by --facet; default: a map)")
    p.add_argument("--out", default=None, help="PNG path (default: next to the file)")
    p.add_argument("--dpi", type=int, default=120,
                   help="resolution of the PNG (dots per inch)")
    p.set_defaults(func=_cmd_plot)

    p = sub.add_parser("stability", help="linear stability of steady spin over a "
                       "sweep's grid (t_end not needed); write a netCDF file")
    p.add_argument("config", help="sweep configuration (TOML)")
    p.add_argument("--out", required=True, help="netCDF file to write")
    p.set_defaults(func=_cmd_stability)

    p = sub.add_parser("info", help="summarise result files or sweep directories")
    p.add_argument("files", nargs="+", help="netCDF result files or sweep directories")
    p.add_argument("--config", action="store_true", help="also print the sweep TOML")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("design", help="design a printable rattleback: a shell with two "
                       "coins in pockets placed by simulation; write STL, placement sheet, "
                       "design.toml and a reversal map")
    p.add_argument("--a", type=float, required=True, help="half length of the shell (m)")
    p.add_argument("--b", type=float, required=True, help="half width of the shell (m)")
    p.add_argument("--c", type=float, required=True, help="height of the shell (m)")
    p.add_argument("--coin", default=None, help="coin or washer preset, any case (default "
                   "eur_1): eur_1, eur_2, eur_0.50, usd_0.25, usd_0.05, usd_0.01, gbp_0.02, "
                   "gbp_0.10, washer_M8, washer_M10, washer_M12. Two coins are used (a pair "
                   "symmetric about the centre)")
    p.add_argument("--coin-mass", type=float, default=None,
                   help="coin mass (kg; default: the --coin preset's, which this "
                   "overrides; give all three --coin-* for a coin of your own)")
    p.add_argument("--coin-diameter", type=float, default=None,
                   help="coin diameter (m; default: the --coin preset's, which this "
                   "overrides)")
    p.add_argument("--coin-thickness", type=float, default=None,
                   help="coin thickness (m; default: the --coin preset's, which this "
                   "overrides)")
    p.add_argument("--infill", type=float, default=0.2,
                   help="infill fraction in (0, 1] (default 0.2, i.e. 20 %%)")
    p.add_argument("--material", default="pla",
                   help="pla, petg or abs (default pla); any name with --density")
    p.add_argument("--density", type=float, default=None, metavar="KG_M3",
                   help="density of the material (kg/m^3; default: the --material "
                   "preset's, pla 1240, petg 1270, abs 1040, which this overrides)")
    p.add_argument("--wall", type=float, default=1.2e-3,
                   help="solid wall thickness (m; default 0.0012)")
    p.add_argument("--clearance", type=float, default=0.4e-3,
                   help="pocket diameter minus coin diameter (m; default 0.0004)")
    p.add_argument("--rim", type=float, default=2e-3,
                   help="least material beside a pocket (m; default 0.002)")
    p.add_argument("--mu", type=float, nargs=2, default=(0.2, 0.5), metavar=("LOW", "HIGH"),
                   help="friction range to design for (default 0.2 0.5: a table top)")
    p.add_argument("--margin", type=float, default=0.1,
                   help="G at most (1 - margin) x the smaller radius of curvature")
    p.add_argument("--prefer", choices=["cw", "ccw"], default="cw",
                   help="sense (seen from above) in which it spins on")
    p.add_argument("--out", required=True,
                   help="output directory: new or empty, unless --force")
    p.add_argument("--force", action="store_true",
                   help="write into --out even when it holds files (the design's own "
                   "files there are replaced, others kept)")
    p.add_argument("--accept-not-robust", action="store_true",
                   help=f"exit 0 for a design that is not robust (default: exit status "
                   f"{NOT_ROBUST_STATUS}, the files written all the same)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress lines (on stderr) while it works")
    p.set_defaults(func=_cmd_design)

    p = sub.add_parser("simulate", help="simulate one launch: a preset, a homogeneous "
                       "semi-ellipsoid or a body from a TOML file")
    _add_launch_options(p)
    p.add_argument("--out", default=None, help="netCDF file to write (default: none)")
    p.add_argument("--png", default=None,
                   help="PNG of spin against time to write (default: none)")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("animate", help="3-D animation (GIF, or MP4 with ffmpeg) of one "
                       "launch, simulated from the options or read with --run")
    _add_launch_options(p)
    p.add_argument("--run", default=None, metavar="FILE.nc",
                   help="animate this saved simulate result instead of simulating "
                   "(default: simulate from the options)")
    p.add_argument("--out", required=True, help="animation file (.gif or .mp4)")
    p.add_argument("--frames", type=int, default=100, help="number of frames")
    p.add_argument("--fps", type=float, default=20.0, help="frames per second")
    p.add_argument("--dpi", type=int, default=80,
                   help="resolution of the frames (dots per inch)")
    p.add_argument("--z-stretch", type=float, default=None,
                   help="draw heights this many times larger (default: automatic)")
    p.set_defaults(func=_cmd_animate)

    p = sub.add_parser("explore", help="the rattleback live in the browser: a local web "
                       "page with controls, a 3-D view, plots and a reversal map",
                       description="Serve the explorer, a local web page with the body, "
                       "launch and friction as controls, a 3-D view of the run with linked "
                       "plots of spin, tilt, energy and slip speed, and a reversal map whose "
                       "points load their launch. Warms the kernels first (on the first run "
                       "after installing this compiles them: about a minute or two), then "
                       "prints the address and opens the browser. Ctrl-C stops it.")
    p.add_argument("--port", type=int, default=8050, help="port (default 8050; 0: any free)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.set_defaults(func=_cmd_explore)
    return parser


def _show_warning(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, file: Any = None, line: str | None = None) -> None:
    """A warning as the command's one line on stderr, without Python's source line."""
    print(f"rattlesweep: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    with warnings.catch_warnings():  # restores Python's own display on return
        warnings.showwarning = _show_warning
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        args = build_parser().parse_args(argv)
        status = args.func(args, argv)
        sys.stdout.flush()  # a closed pipe is then found here, not at interpreter exit
        return status
    except KeyboardInterrupt:
        # Ctrl-C outside the tiles (while an output is checked or merged): what was
        # written is intact, as every file is written atomically
        print("rattlesweep: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of the output went away (``rattlesweep info DIR | head``): nothing to
        # report; stdout is pointed at devnull so that Python's flush at exit stays quiet
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except ValueError as exc:
        print(f"rattlesweep: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that cannot be read or written: the message says which
        print(f"rattlesweep: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:
        # Ctrl-C while a compiled extension loads surfaces as the ImportError it causes
        # (numba's "numba._devicearray failed to import")
        if not _caused_by_interrupt(exc):
            raise
        print("rattlesweep: interrupted", file=sys.stderr)
        return 130


def _caused_by_interrupt(exc: BaseException) -> bool:
    """Whether a KeyboardInterrupt is among the causes of ``exc``."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def run() -> None:
    """The command's entry point: :func:`main`, then exit with its status.

    Ctrl-C anywhere in the command (its imports included: the package loads its heavy
    libraries only once the command runs) ends it with status 130 and one line, and the
    process then exits at once, without the interpreter's shutdown: a sweep stopped by
    a second Ctrl-C does not wait for the tiles still computing (a kernel call cannot be
    interrupted, and a tile of long launches may take hours; their threads would keep
    the process alive for results nothing writes any more), and a library whose import
    the interrupt cut short can turn the shutdown into a death by SIGINT. Every file
    written is complete, as each is written atomically, and the sweep's lock is released
    already."""
    try:
        status = main()
    except KeyboardInterrupt:  # outside main's own handling (while it reports an error)
        print("rattlesweep: interrupted", file=sys.stderr)
        status = 130
    if status == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)

if __name__ == "__main__":
    run()
