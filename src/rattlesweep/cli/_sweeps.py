"""The sweep commands: sweep, resume, demo, export, verify, stability."""

from __future__ import annotations

import argparse
import contextlib
import shlex
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator


if TYPE_CHECKING:
    import xarray as xr

    from ..sweep import Sweep


def _command(argv: list[str] | None) -> str:
    return "rattlesweep " + shlex.join(sys.argv[1:] if argv is None else argv)


def _sweep_output(path: Path) -> Path | None:
    """The sweep output ``path`` is or belongs to: a zarr store, a sweep directory, or
    the directory of a merged ``sweep.nc``; None for a file of no sweep directory."""
    from ..sweep._outputs.directory import CONFIG_NAME, RESULT_NAME
    from ..sweep._outputs.zarr_store import is_zarr_store

    if is_zarr_store(path) or (path / CONFIG_NAME).is_file():
        return path
    if path.name == RESULT_NAME and (path.parent / CONFIG_NAME).is_file():
        return path.parent
    return None


def _sweep_dims(ds: xr.Dataset) -> list[str]:
    """The sweep's dimensions in its own order (a file's attribute; netCDF gives a list
    of one name back as the name), else the dataset's."""
    dims = ds.attrs.get("sweep_dims", list(ds.dims))
    return [dims] if isinstance(dims, str) else [str(d) for d in dims]


def _save_map(ds: xr.Dataset, png: Path, var: str = "outcome") -> Path:
    from ..plot import reversal_map

    dims = [d for d in _sweep_dims(ds) if d in ds[var].dims]
    if len(dims) < 2:
        raise ValueError(f"a map needs two sweep dimensions; this sweep has {dims}")
    facet = dims[2] if len(dims) > 2 else None
    select = {d: ds[d].values[0] for d in dims[3:]}
    fig = reversal_map(
        ds, x=dims[0], y=dims[1], var=var, facet=facet, select=select or None
    )
    fig.savefig(png, dpi=120)
    return png


def _summary(ds: xr.Dataset) -> str:
    import numpy as np

    flags = list(ds.outcome.attrs["flag_values"])
    names = ds.outcome.attrs["flag_meanings"].split()
    values, counts = np.unique(np.asarray(ds.outcome.values).ravel(), return_counts=True)
    found = dict(zip(values.tolist(), counts.tolist()))
    return ", ".join(
        f"{n.replace('_', ' ')} {found[f]}" for f, n in zip(flags, names) if found.get(f)
    )


def _sweep_args(args: argparse.Namespace) -> dict[str, Any]:
    if args.scheduler and args.workers:
        raise ValueError(
            "--workers sets local threads; with --scheduler the cluster's size "
            "is set where it was started"
        )
    return {
        "scheduler": args.scheduler,
        "workers": args.workers,
        "progress": not args.quiet,
    }


def _points(ds: xr.Dataset) -> str:
    """How many points a result holds, and how many of them were simulated."""
    n = int(ds.outcome.size)
    if "points_simulated" not in ds.attrs:
        return f"{n} launches"
    simulated = int(ds.attrs["points_simulated"])
    return f"{n} points ({simulated} simulated, {simulated / n:.1%})"


def _interrupted(state: str) -> int:
    """Say that Ctrl-C stopped the command, and what state it left the output in."""
    print(f"rattlesweep: interrupted; {state}", file=sys.stderr)
    return 130


def _kept(out: str | Path, interrupt: KeyboardInterrupt, existed: bool) -> str:
    """What an interrupt of a sweep left in ``out`` (``existed``: before the command):
    its merged result complete (written atomically, and not older than any tile),
    nothing of a sweep at all, or the tiles kept (the runner's count when it says, as
    :class:`~rattlesweep.sweep._outputs.store.SweepInterrupted`)."""
    from ..sweep._outputs.directory import CONFIG_NAME, RESULT_NAME
    from ..sweep._outputs.store import SweepInterrupted
    from ..sweep._outputs.zarr_store import every_tile_done, is_zarr_store

    location, out = out, Path(out)
    merged = out / RESULT_NAME
    if _complete(out, merged):
        return f"the result is complete: {merged} is written"
    if is_zarr_store(location) and every_tile_done(str(location)):
        return f"the result is complete: every tile of {location} is written"
    if not (out / CONFIG_NAME).is_file() and not is_zarr_store(location):
        if not existed:  # the directory this command made, empty but for its lock
            with contextlib.suppress(OSError):
                out.rmdir()
        return f"nothing was written to {out}"
    if isinstance(interrupt, SweepInterrupted):
        return str(interrupt)
    return f"the tiles written so far are kept: `rattlesweep resume {out}` finishes it"


def _complete(out: Path, merged: Path) -> bool:
    """Whether the sweep directory ``out`` holds its merged file whole (the digest
    written with it matches) and not older than any of its tiles."""
    from ..io import recorded_digest_matches
    from ..sweep._outputs.directory import TILES_DIR
    from ..sweep._outputs.refined import LEVELS_DIR

    try:
        if recorded_digest_matches(merged) is not True:
            return False
        made = merged.stat().st_mtime_ns
        tiles = (
            *out.glob(f"{TILES_DIR}/tile-*.nc"),
            *out.glob(f"{LEVELS_DIR}/level-*/tile-*.nc"),
        )
        return all(t.stat().st_mtime_ns <= made for t in tiles)
    except OSError:
        return False


class _NotedInterrupts:
    """A SIGINT handler that raises KeyboardInterrupt as Python's own does, and counts
    it: netCDF4 reads attributes under a bare ``except:`` (while tiles are checked or
    merged), and a finaliser's exception is only printed, so an interrupt raised there
    is lost and the command went on to status 0. The sweep's runner replaces it while
    tiles run (``raises_keyboard_interrupt`` tells it that it may)."""

    raises_keyboard_interrupt = True

    def __init__(self) -> None:
        self.count = 0

    def __call__(self, signum: int, frame: Any) -> None:
        self.count += 1
        raise KeyboardInterrupt


@contextlib.contextmanager
def _noted_interrupts() -> Iterator[_NotedInterrupts]:
    """:class:`_NotedInterrupts` as the SIGINT handler for the ``with``, where Python's
    default one is (in the main thread; elsewhere its count stays 0)."""
    import signal
    import threading

    noted = _NotedInterrupts()
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield noted
        return
    signal.signal(signal.SIGINT, noted)
    try:
        yield noted
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _run(
    sweep: Sweep,
    out: str,
    args: argparse.Namespace,
    argv: list[str] | None,
    draw: Path | None = None,
) -> int:
    """Run (or resume) ``sweep`` into ``out``; with ``draw``, also draw its map there."""
    existed = Path(out).exists()
    with _noted_interrupts() as noted:
        try:
            from ..sweep._execution.run import RESULT_NAME, run_sweep

            written = out if sweep.output == "zarr" else Path(out) / RESULT_NAME
            ds = run_sweep(sweep, out, command=_command(argv), **_sweep_args(args))
        except KeyboardInterrupt as interrupt:
            return _interrupted(_kept(out, interrupt, existed))
    if noted.count:  # lost in a library; the merge went on to the end (atomically)
        return _interrupted(f"the merged result was complete: {written} is written")
    print(f"wrote {written}: {_points(ds)}; {_summary(ds)}")
    if draw is not None:
        print(f"wrote {_save_map(ds, draw)}")
    return 0


def _cmd_sweep(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..sweep import Sweep

    sweep = Sweep.from_toml(Path(args.config))
    changes = {}
    if args.output is not None and args.output != sweep.output:
        changes["output"] = args.output
    if args.stop is not None:
        changes["stop"] = None if args.stop == "t_end" else args.stop
    if args.lyapunov:
        changes["lyapunov"] = True
    if args.refine is not None and args.refine < 0:
        raise ValueError(
            f"--refine must be an integer >= 0 (levels of refinement; 0: "
            f"none), got {args.refine}"
        )
    if args.refine is not None:
        changes["refine"] = (
            {**(sweep.refine or {}), "levels": args.refine} if (args.refine > 0) else None
        )
    if changes:
        sweep = Sweep(**{**sweep.to_dict(), **changes})
    if args.dry_run:
        return _dry_run(sweep, args)
    if args.out is None:
        raise ValueError("--out is required to run a sweep (only --dry-run goes without)")
    return _run(sweep, args.out, args, argv)


def _dry_run(sweep: Sweep, args: argparse.Namespace) -> int:
    from ..sweep._execution.estimate import estimate, format_estimate
    from ..sweep._execution.run import _cores

    _sweep_args(args)  # the same checks of the options as a run
    if args.scheduler:
        workers, where = (
            1,
            (
                f"one worker of the cluster at {args.scheduler} (divide by "
                "its number of single-threaded workers)"
            ),
        )
    else:
        workers = args.workers or _cores()
        where = f"{workers} local thread{'s' if workers > 1 else ''}"
    found = estimate(sweep, workers)
    print(format_estimate(sweep, found, where))
    return 2 if found.refused else 0  # the status of the run it stands for


def _cmd_resume(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..sweep._execution.run import stored_sweep

    out = _output_named(args.dir)
    from ..sweep import Sweep
    from ..sweep._config.demo import DEMO_TOML

    try:
        sweep = stored_sweep(out)
    except KeyboardInterrupt:  # while its configuration was read: nothing touched yet
        return _interrupted(f"{out} is unchanged")
    # the demo draws its map when it finishes, resumed or not
    demo = sweep == Sweep.from_toml(DEMO_TOML) and sweep.output == "netcdf"
    return _run(sweep, out, args, argv, Path(out) / "reversal_map.png" if demo else None)


def _output_named(name: str) -> str:
    """The sweep output a command line argument names: the directory of a merged
    ``sweep.nc`` given in its place, else the argument as given."""
    out = _sweep_output(Path(name))
    return str(out) if out is not None and Path(name).name != out.name else name


def _cmd_export(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..io import check_netcdf_target

    check_netcdf_target(args.out)
    out = Path(args.out)
    before = _stamp(out)
    try:
        from ..sweep._execution.run import export

        path = export(args.store, args.out)
    except KeyboardInterrupt:
        # the file is written atomically: in place whole, or not at all
        now = _stamp(out)
        if now is not None and now != before:
            return _interrupted(f"the export is complete: {out} is written")
        return _interrupted(
            f"{out} is unchanged" if now is not None else f"nothing was written to {out}"
        )
    print(f"wrote {path}")
    return 0


def _stamp(path: Path) -> tuple[int, int] | None:
    """The inode and modification time of ``path`` (None: there is none): a file
    written atomically has a new inode."""
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_ino, st.st_mtime_ns)


def _cmd_verify(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..sweep._outputs.verify import verify

    failed = refused = 0
    for name in args.outputs:
        try:
            found = verify(_output_named(name))
        except ValueError as exc:  # the others are still verified
            print(f"rattlesweep verify: {exc}", file=sys.stderr)
            refused += 1
            continue
        print(found.report())
        failed += not found.ok
    return 2 if refused else (1 if failed else 0)


def _cmd_demo(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..sweep import Sweep
    from ..sweep._config.demo import DEMO_TOML
    from ..sweep._execution.run import RESULT_NAME, run_sweep

    if args.print_config:
        print(DEMO_TOML, end="")
        return 0
    out = Path(args.out)
    existed = out.exists()
    t0 = time.perf_counter()
    with _noted_interrupts() as noted:
        try:
            ds = run_sweep(
                Sweep.from_toml(DEMO_TOML), out, command=_command(argv), **_sweep_args(args)
            )
        except KeyboardInterrupt as interrupt:
            return _interrupted(_kept(out, interrupt, existed))
    if noted.count:
        return _interrupted(f"the merged result was complete: {out / RESULT_NAME}")
    png = _save_map(ds, out / "reversal_map.png")
    print(
        f"{ds.attrs['sweep_name']}: {_points(ds)} in {time.perf_counter() - t0:.1f} s; "
        f"{_summary(ds)}"
    )
    print(f"wrote {out / RESULT_NAME} and {png}")
    return 0


def _cmd_stability(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..io import check_netcdf_target, write_netcdf
    from ..stability import NEUTRAL, PITCH_UNSTABLE, ROLL_UNSTABLE, stability_dataset
    from ..stability import friction_dims
    from ..sweep import Sweep

    check_netcdf_target(args.out)
    t0 = time.perf_counter()
    ds = stability_dataset(Sweep.from_toml(Path(args.config)), command=_command(argv))
    path = write_netcdf(ds, args.out)
    # by the mode, as the file classifies each point: a growth rate of rounding size
    # (a symmetric body, zero spin) is neutral, not unstable
    unstable = float(ds["mode"].isin([PITCH_UNSTABLE, ROLL_UNSTABLE]).mean())
    neutral = float((ds["mode"] == NEUTRAL).mean())
    print(
        f"wrote {path}: {int(ds.growth_rate.size)} grid points in "
        f"{time.perf_counter() - t0:.2f} s; {unstable:.0%} unstable"
        + (f", {neutral:.0%} neutral" if neutral else "")
        + f", largest growth rate {float(ds.growth_rate.max()):.4g} s-1"
    )
    repeated = friction_dims(ds)
    if repeated:
        names = " and ".join(repeated)
        print(
            f"friction does not enter the linearisation (rolling contact, the same for "
            f"every mu > 0): the values repeat along {names}"
        )
    return 0
