"""The commands that read results: plot and info, with the damage checks they share."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING


if TYPE_CHECKING:
    import xarray as xr

from ._sweeps import _summary, _sweep_dims, _sweep_output


def _open_netcdf(path: str) -> xr.Dataset:
    """A result file, or a ValueError saying it is none (not xarray's list of
    backends)."""
    import xarray as xr

    _check_readable(Path(path))
    try:
        with xr.open_dataset(path) as ds:
            return ds.load()  # all read here: a damaged chunk fails now, not mid-plot
    except (OSError, ValueError, RuntimeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc).strip() else type(exc).__name__
        if "did not find a match" in reason:
            reason = "it is not a netCDF file"
        if isinstance(exc, RuntimeError):  # netCDF4's report of an HDF5 read failure
            raise ValueError(f"cannot read {path}: {_DAMAGED.format(reason)}") from None
        raise ValueError(
            f"cannot read {path}: expected a rattlesweep result file (netCDF), "
            f"sweep directory or zarr store; {reason}"
        ) from None


_DAMAGED = "it is damaged ({}: a chunk fails its checksum or cannot be read)"


def _check_readable(path: Path) -> None:
    """Raise DamagedFile (a ValueError) naming the file ``path`` as damaged when it
    differs from the digest recorded when it was written, or, with none recorded, a
    child process cannot read it in full; checked before the netCDF library opens it
    here, as damaged metadata can crash that library."""
    from ..io import DamagedFile, check_readable

    if path.is_file():
        try:
            check_readable(path)
        except DamagedFile as exc:
            raise DamagedFile(f"cannot read {path}: {exc}") from None


def _cmd_plot(args: argparse.Namespace, argv: list[str] | None) -> int:

    from ..plot import lyapunov_map, reversal_map, reversal_vs_growth
    from ..plot.maps import GROWTH_ZERO

    select = {}
    for item in args.select or []:
        key, _, value = item.partition("=")
        if not _:
            raise ValueError(f"--select takes DIM=VALUE, got {item!r}")
        if key in select:
            raise ValueError(f"--select {key} is given twice")
        try:
            select[key] = float(value)
        except ValueError:
            select[key] = value
    if args.versus:
        unused = [
            option
            for option, value in (
                ("--x", args.x),
                ("--y", args.y),
                ("--var", args.var),
                ("--select", args.select),
                ("--reduce", args.reduce),
                ("--overlay", args.overlay),
            )
            if value
        ]
        if unused:
            raise ValueError(
                f"--versus draws every grid point the files share, coloured by --facet; "
                f"{', '.join(unused)} {'does' if len(unused) == 1 else 'do'} not apply "
                "to it"
            )
    if args.out and len(args.files) > 1:
        raise ValueError(
            f"--out names one PNG, for one file; got {len(args.files)} files (leave "
            "--out out to write each map next to its file)"
        )
    damage = {}
    for path in (*args.files, *filter(None, (args.overlay, args.versus))):
        damage[path] = _warn_damaged(Path(path), "plot")

    def read(path: str) -> xr.Dataset:
        found = damage.get(path)
        if found is not None and found.unread:
            raise ValueError(found.unreadable(path))
        try:
            ds = _open_netcdf(_plotted_file(Path(path)))
        except ValueError:
            if found is None:
                raise
            raise ValueError(found.unreadable(path)) from None
        unfinished = _unfinished_store(Path(path))
        if unfinished:
            print(
                f"{path} is unfinished ({unfinished}): its points not computed yet are "
                "drawn as such"
            )
        return ds

    overlay = read(args.overlay) if args.overlay else None
    for path in args.files:
        with read(path) as ds:
            if args.versus:
                _check_names(ds, "growth_rate", {"--facet": args.facet}, {})
                with read(args.versus) as sweep:
                    fig = reversal_vs_growth(ds, sweep, color_by=args.facet)
                name = "reversal_vs_growth"
            else:
                var = args.var or ("outcome" if "outcome" in ds else "growth_rate")
                dims = _sweep_dims(ds)
                x = args.x or dims[0]
                y = args.y or next((d for d in dims if d != x), None)
                if y is None:
                    raise ValueError(f"{path}: a map needs two dimensions, found {dims}")
                _check_names(ds, var, {"--x": x, "--y": y, "--facet": args.facet}, select)
                first = _first_values(ds, var, (x, y, args.facet), select, args.reduce)
                if var == "lyapunov":
                    if overlay is not None:
                        raise ValueError(
                            "--overlay does not apply to a map of lyapunov: it is drawn "
                            "with the linear stability boundary of the sweep's grid"
                        )
                    fig = lyapunov_map(
                        ds,
                        x=x,
                        y=y,
                        stability=_stability_of(path, ds),
                        facet=args.facet,
                        select={**first, **select} or None,
                        reduce=args.reduce,
                    )
                else:
                    fig = reversal_map(
                        ds,
                        x=x,
                        y=y,
                        var=var,
                        facet=args.facet,
                        select={**first, **select} or None,
                        reduce=args.reduce,
                        overlay=overlay,
                        zero_line=GROWTH_ZERO if var == "growth_rate" else None,
                    )
                if first:
                    print(
                        f"{path}: {var} at "
                        + ", ".join(f"{d} = {v}" for d, v in first.items())
                        + " (the first values of the dimensions not drawn; --select "
                        "DIM=VALUE picks another, --facet DIM draws each)"
                    )
                for dim, value in _snapped(ds, select).items():
                    print(
                        f"{path}: {dim} = {select[dim]} is not on its axis: drawn at "
                        f"the nearest value, {value}"
                    )
                name = var
            drawn = _plotted_file(Path(path))
            png = (
                Path(args.out)
                if args.out and len(args.files) == 1
                else Path(drawn).with_name(f"{Path(drawn).stem}_{name}.png")
            )
            if not png.suffix:  # matplotlib adds it
                png = png.with_suffix(".png")
            png.parent.mkdir(parents=True, exist_ok=True)  # as a netCDF output's
            fig.savefig(png, dpi=args.dpi)
            print(f"wrote {png}")
    if overlay is not None:
        overlay.close()
    return 0


def _stability_of(path: str, ds: xr.Dataset) -> xr.Dataset | None:
    """The linear stability of steady spin over the grid of the sweep that wrote ``ds``
    (its ``sweep_config``), or None, said, when it cannot be had."""
    from ..stability import stability_dataset

    config = ds.attrs.get("sweep_config")
    try:
        if not isinstance(config, str):
            raise ValueError("the file holds no sweep configuration")
        return stability_dataset(config)
    except ValueError as error:
        print(f"{path}: the linear stability boundary is not drawn: {error}")
        return None


def _unfinished_store(path: Path) -> str | None:
    """For a zarr store not every tile of which is written, how many are and who
    finishes it ("N of M tiles written; ..."); None otherwise."""
    from ..sweep._outputs.verify import finish_advice
    from ..sweep._outputs.zarr_store import is_zarr_store, stored_sweep, tiles_done

    if not is_zarr_store(path):
        return None
    n_tiles = stored_sweep(str(path)).n_tiles
    done = tiles_done(str(path), n_tiles)
    if done is None or done.all():
        return None
    return f"{int(done.sum())} of {n_tiles} tiles written; {finish_advice(path)}"


def _check_names(ds: xr.Dataset, var: str, named: dict, select: dict) -> None:
    """Refuse a parameter named as the configuration names it (``spin``, ``roll``)
    where the result calls it otherwise (``launch_spin``, ``roll_deg``), saying so."""
    from ..sweep._config.params import result_name

    if var not in ds.data_vars:
        return  # reversal_map names a missing variable
    for option, name in [*named.items(), *(("--select", d) for d in select)]:
        if name is None or name in ds[var].dims:
            continue
        known = result_name(name)
        if known != name and known in ds[var].dims:
            raise ValueError(f"{option} {name}: results name it {known}")


def _snapped(ds: xr.Dataset, select: dict) -> dict:
    """The nearest axis value of each numeric ``select`` value not on its axis (which
    the map draws instead)."""
    import numpy as np

    out = {}
    for dim, value in select.items():
        values = ds[dim].values
        if values.dtype.kind in "fiu" and value not in values:
            out[dim] = values[np.argmin(np.abs(values - value))].item()
    return out


def _first_values(
    ds: xr.Dataset,
    var: str,
    drawn: tuple[str | None, ...],
    select: dict,
    reduce: str | None,
) -> dict:
    """The first value of each dimension of ``var`` neither drawn nor selected: what a
    map shows of it by default (none where ``reduce`` averages over them)."""
    if var not in ds.data_vars or (reduce == "mean" and "flag_values" not in ds[var].attrs):
        return {}  # reversal_map names a missing variable
    return {
        str(dim): ds[var][dim].values[0].item()
        for dim in ds[var].dims
        if dim not in drawn and dim not in select
    }


def _plotted_file(path: Path) -> str:
    """The file ``plot`` draws for ``path``: a sweep directory's merged result, else the
    path itself; ValueError for an unfinished sweep directory or another directory."""
    from ..sweep._outputs.directory import CONFIG_NAME, RESULT_NAME
    from ..sweep._outputs.zarr_store import is_zarr_store

    if not path.is_dir() or is_zarr_store(path):  # a zarr store is read as it is
        return str(path)
    if (path / RESULT_NAME).is_file():
        return str(path / RESULT_NAME)
    if (path / CONFIG_NAME).is_file():
        from ..sweep._outputs.verify import finish_advice

        raise ValueError(
            f"cannot plot {path}: the sweep is unfinished (no {RESULT_NAME} yet); "
            f"{finish_advice(path)}"
        )
    raise ValueError(
        f"cannot plot {path}: a directory without {RESULT_NAME} or {CONFIG_NAME}; "
        "expected a result file or a sweep directory (what `rattlesweep sweep --out "
        "DIR` writes)"
    )


@dataclass(frozen=True)
class _Damage:
    """A sweep output found damaged: ``out``, what is wrong first (``what``), and
    whether it is a zarr store with tiles that cannot be read (``unread``: they are
    not read at all, as zarr's reads of a store's other chunks, left pending when one
    fails, end the process with asyncio's 'Task was destroyed' noise)."""

    out: Path
    what: str
    unread: bool = False
    resumable: bool = True

    def unreadable(self, path: str | Path) -> str:
        """The line that ends a command that could not read ``path`` for this damage."""
        advice = (
            f"`rattlesweep resume {self.out}` recomputes what is missing or damaged"
            if self.resumable
            # resume reads the same configuration, and would refuse it too
            else "restore it from a copy, or run the sweep again into a new output"
        )
        return f"cannot read {path}: {self.what}; {advice}"


def _warn_damaged(path: Path, command: str) -> _Damage | None:
    """Verify the sweep output ``path`` is or belongs to (what ``rattlesweep verify``
    does) and warn on stderr about any tile or merged file damaged or lost; tiles of an
    unfinished output not computed yet are no damage. Returns the damage warned
    about."""
    from ..sweep._outputs.verify import verify

    out = _sweep_output(path)
    if out is None:
        return None
    try:
        found = verify(out)
    except ValueError as exc:
        print(
            f"rattlesweep {command}: warning: {out} cannot be verified: {exc}",
            file=sys.stderr,
        )
        return _Damage(out, "it cannot be verified", resumable=False)
    if not (found.damaged or found.problems or (found.missing and found.finished)):
        return None
    # one line: the first thing wrong; verify lists them all
    head, *lines = found.report().splitlines()
    issues = [line.strip() for line in lines if not line.strip().startswith("`")]
    more = (
        f"; and {len(issues) - 1} more (`rattlesweep verify {out}` lists them)"
        if len(issues) > 1
        else ""
    )
    print(
        f"rattlesweep {command}: warning: {out} is damaged ({head.split(': ', 1)[1]}): "
        f"{issues[0] if issues else 'see `rattlesweep verify`'}{more}; "
        f"`rattlesweep resume {out}` recomputes what is missing or damaged",
        file=sys.stderr,
    )
    if found.damaged:
        from ..sweep._outputs.zarr_store import is_zarr_store

        # a chunk missing reads as not computed; one that cannot be decoded fails a read
        failing = [t for t, w in found.damaged.items() if " damaged (" in w]
        tile = (failing or list(found.damaged))[0]
        what = f"tile {tile} is damaged: {found.damaged[tile]}"
        return _Damage(out, what, unread=bool(failing) and is_zarr_store(out))
    if found.problems:
        what = found.problems[0]
    else:
        what = f"tile {found.missing[0]} is missing"
    return _Damage(out, what)


def _info_directory(path: Path) -> Path | None:
    """The merged result of a sweep directory, or None after printing the progress of an
    unfinished one; ValueError when ``path`` is no sweep directory."""
    from ..sweep._outputs.zarr_store import is_zarr_store

    if is_zarr_store(path):
        return path
    if (path / "sweep.nc").is_file():
        return path / "sweep.nc"
    if not (path / "sweep.toml").is_file():
        raise ValueError(
            f"{path} is a directory without sweep.nc or sweep.toml: expected a "
            "sweep directory (what `rattlesweep sweep --out DIR` writes)"
        )
    from ..sweep._outputs.directory import read_config
    from ..sweep._outputs.verify import finish_advice

    sweep = read_config(path / "sweep.toml")
    print(f"{path} (unfinished sweep: no sweep.nc yet)")
    print(f"  name: {sweep.name}")
    print(
        "  dimensions: " + ", ".join(f"{d} ({n})" for d, n in zip(sweep.dims, sweep.shape))
    )
    if sweep.refine is not None:
        levels = sorted(path.glob("levels/level-*"))
        done = len(list(path.glob("levels/level-*/tile-*.nc")))
        fine = sweep.finest()
        print(
            "  refined to: "
            + ", ".join(f"{d} ({n})" for d, n in zip(fine.dims, fine.shape))
        )
        print(
            f"  levels started: {len(levels)} of {sweep.refine['levels'] + 1}, {done} "
            "tiles "
            f"written; {finish_advice(path)}"
        )
        return None
    from ..sweep._outputs.verify import verify

    found = verify(path)
    done = sweep.n_tiles - len(found.missing) - len(found.damaged)
    damaged = f", {len(found.damaged)} damaged" if found.damaged else ""
    print(
        f"  tiles written: {done} of {sweep.n_tiles} (complete and readable){damaged}; "
        f"{finish_advice(path)}"
    )
    return None


def _open_result(path: Path) -> xr.Dataset:
    import xarray as xr

    from ..sweep._outputs.zarr_store import is_zarr_store, open_result

    if not is_zarr_store(path):
        _check_readable(path)
        with xr.open_dataset(path) as ds:
            return ds.load()  # all read here: a damaged chunk fails now
    unfinished = _unfinished_store(path)
    if unfinished:
        print(f"{path} (unfinished zarr store: {unfinished})")
    ds = open_result(str(path))
    for name in ("outcome", "computed", *ds.coords):  # what info reads, read here: a
        if name in ds:  # damaged chunk fails now, where it is named
            ds[name].load()
    return ds


def _cmd_info(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..io import DamagedFile

    failed = 0
    for name in args.files:
        path = Path(name)
        damaged = _warn_damaged(path, "info")
        if damaged is not None and damaged.unread:
            print(f"rattlesweep info: {damaged.unreadable(path)}", file=sys.stderr)
            failed += 1
            continue
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
        except (OSError, ValueError, RuntimeError) as exc:
            if isinstance(exc, DamagedFile):
                print(
                    "rattlesweep info: "
                    + (damaged.unreadable(path) if damaged is not None else str(exc)),
                    file=sys.stderr,
                )
                failed += 1
                continue
            reason = str(exc).splitlines()[0]
            if "did not find a match" in reason:
                reason = "it is not a netCDF file"
            if isinstance(exc, RuntimeError):  # netCDF4's report of an HDF5 failure
                reason = _DAMAGED.format(reason)
            if damaged is not None:
                print(f"rattlesweep info: {damaged.unreadable(path)}", file=sys.stderr)
            elif isinstance(exc, RuntimeError):
                print(f"rattlesweep info: cannot read {path}: {reason}", file=sys.stderr)
            else:
                print(
                    f"rattlesweep info: cannot read {path}: expected a rattlesweep "
                    f"result file (netCDF) or a sweep directory; {reason}",
                    file=sys.stderr,
                )
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
                    span = (
                        f"{vals[0]} .. {vals[-1]}"
                        if vals.dtype.kind in "fiu"
                        else ", ".join(map(str, vals))
                    )
                    print(f"    {name}: {span} {units}  ({c.attrs.get('long_name', '')})")
            scalars = [
                f"{c}={ds[c].values.item()} {ds[c].attrs.get('units', '1')}".removesuffix(
                    " 1"  # CF's dimensionless
                )
                for c in ds.coords
                if ds[c].ndim == 0
            ]
            if scalars:
                print("  fixed: " + ", ".join(scalars))
            print("  variables: " + ", ".join(map(str, ds.data_vars)))
            if "outcome" in ds:
                print(f"  outcomes: {_summary(ds)}")
            if "computed" in ds:
                simulated, n = int(ds.computed.sum()), int(ds.computed.size)
                print(
                    f"  simulated: {simulated} of {n} points ({simulated / n:.1%}); the "
                    "others are filled from their refinement cell's corners (computed = 0)"
                )
            for key in ("rattlesweep_version", "history"):
                if key in ds.attrs:
                    print(f"  {key}: {ds.attrs[key]}")
            if args.config and "sweep_config" in ds.attrs:
                print(ds.attrs["sweep_config"])
    return 2 if failed else 0
