"""``rattlesweep fit``: a measured rattleback's inputs from a video or gyroscope file."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

NOT_DETERMINED_STATUS = 3
"""Exit status when a free input is not pinned down by the data (files still written)."""


def _pairs(items: list[str] | None, option: str) -> list[tuple[str, str]]:
    out = []
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise ValueError(f"{option} {item!r}: expected NAME=VALUE")
        out.append((name.strip(), value.strip()))
    return out


def _number(text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{what}: {text!r} is not a number") from None


def _free(items: list[str] | None) -> dict[str, tuple[float, float]]:
    free: dict[str, tuple[float, float]] = {}
    for name, value in _pairs(items, "--free"):
        low, sep, high = value.partition(":")
        if not sep:
            raise ValueError(f"--free {name}={value}: expected NAME=LOW:HIGH")
        if name in free:
            raise ValueError(f"--free {name} given twice")
        free[name] = (
            _number(low, f"--free {name} low"),
            _number(high, f"--free {name} high"),
        )
    return free


def _fixed(items: list[str] | None) -> dict[str, Any]:
    fixed: dict[str, Any] = {}
    for name, value in _pairs(items, "--fixed"):
        if name in fixed:
            raise ValueError(f"--fixed {name} given twice")
        if name == "sensor_position":
            parts = value.split(",")
            if len(parts) != 3:
                raise ValueError(
                    f"--fixed sensor_position={value}: expected X,Y,Z in m (body frame "
                    "from the centre of the flat face)"
                )
            fixed[name] = tuple(_number(p, f"--fixed {name}") for p in parts)
            continue
        fixed[name] = (
            math.inf if value in ("inf", "infinity") else _number(value, f"--fixed {name}")
        )
    return fixed


def _refuse_what_does_not_apply(args: argparse.Namespace, kind: str) -> None:
    """Options of the other kind of data are refused, not ignored."""
    wrong = []
    if kind == "gyro":
        wrong += ["--mirrored"] if args.mirrored else []
        wrong += ["--angle-units"] if args.angle_units else []
    elif args.no_bias:
        wrong.append("--no-bias")
    if wrong:
        other = "heading (video)" if kind == "gyro" else "gyroscope"
        raise ValueError(
            f"{', '.join(wrong)}: for {other} data; {args.data} holds "
            f"{'gyroscope rates' if kind == 'gyro' else 'a heading'}"
        )


def _cmd_fit(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..fitting import fit, read_measurement, write_fit
    from ..fitting.files import NAMES, plain_record, simulate_command
    from ..fitting.models import MODELS, compare_models, model_inputs
    from ..fitting.parameters import bounds_from, check_fixed
    from ..io import write_text_atomic
    from ..sweep._config.body_file import body_from_argument
    from ..sweep._config.toml_io import format_toml

    free, fixed = _free(args.free), _fixed(args.fixed)
    # refused before anything is read or said
    if args.compare_models:
        for model in MODELS:
            model_free, model_fixed = model_inputs(model, free, fixed)
            if not model_free:
                raise ValueError(
                    "--compare-models: free at least one input besides the friction "
                    "(mu, mu_spin), e.g. --free spin=LOW:HIGH: the rolling model "
                    "would have nothing to fit"
                )
            check_fixed(model_fixed, bounds_from(model_free))
    else:
        check_fixed(fixed, bounds_from(free))
    columns = {}
    if args.time_column:
        columns["time"] = args.time_column
    if args.heading_column:
        columns["heading"] = args.heading_column
    if args.rate_columns:
        columns.update(zip("xyz", args.rate_columns))
    if columns and args.format != "csv":
        raise ValueError(
            "--time-column, --heading-column and --rate-columns name the columns of "
            "--format csv; other formats name their own"
        )
    if args.out.exists() and not args.out.is_dir():
        raise ValueError(f"--out {args.out}: exists and is not a directory")
    names = NAMES + (("models.toml",) if args.compare_models else ())
    taken = [n for n in names if (args.out / n).exists()] if args.out.is_dir() else []
    if taken and not args.force:
        raise ValueError(
            f"{args.out} holds a fit already ({', '.join(taken)}): choose another --out, "
            "or --force to replace it"
        )
    body = body_from_argument(args.body)
    data = read_measurement(
        args.data,
        format=args.format,
        columns=columns or None,
        angle_units=args.angle_units,
        trim_start=args.trim_start,
    )
    _refuse_what_does_not_apply(args, data.kind)
    if data.time[0] >= args.window:  # said on the file's own clock
        release = args.trim_start + data.time[0]
        raise ValueError(
            f"the data start {data.time[0]:.4g} s after "
            + (f"--trim-start {args.trim_start:g}" if args.trim_start else "time zero")
            + f": time zero must be the release. Give --trim-start {release:.4g} (or "
            "the time of the release on the file's clock)"
        )
    say = (
        (lambda line: None)
        if args.quiet
        else (lambda line: print(line, file=sys.stderr, flush=True))
    )
    say(
        f"fitting {', '.join(free)} to {data.kind} data: {len(data.time)} samples over "
        f"{data.duration:.2f} s"
    )
    options: dict[str, Any] = dict(
        window=args.window,
        fit_bias=not args.no_bias,
        heading_sign=-1.0 if args.mirrored else 1.0,
        seed=args.seed,
        progress=say,
    )
    comparison = None
    if args.compare_models:
        comparison = compare_models(data, body, free, fixed, **options)
        result = comparison[comparison.preferred].result
    else:
        result = fit(data, body, free, fixed, **options)
    paths = write_fit(result, args.out, overwrite=args.force)
    stale = args.out / "models.toml"
    if comparison is None and stale.exists():  # it names a fit no longer there
        stale.unlink()
        print(f"removed {stale}: the model comparison of the fit this one replaced")
    if comparison is not None:
        print(f"friction models compared on {args.data}:")
        print(comparison.table())
        write_text_atomic(
            args.out / "models.toml",
            format_toml(
                plain_record(comparison.document()),
                comment="rattlesweep fit --compare-models: the friction models "
                "ranked by AICc; fit.toml holds the preferred one's fit",
            ),
        )
        paths.append(args.out / "models.toml")
        runs = sum(s.result.evaluations for s in comparison.scores)
        seconds = sum(s.result.seconds for s in comparison.scores)
        print(f"({len(comparison.scores)} models: {runs} model runs in {seconds:.1f} s)")
        print(f"fit of the preferred model, {comparison.preferred}:")
    else:
        print(f"fit of {args.data}:")
    print(result.summary())
    print(f"wrote {', '.join(str(p) for p in paths)}")
    print(f"run the fitted rattleback: {simulate_command(result, str(paths[0]))}")
    if not result.determined:
        print(
            "rattlesweep: some inputs are not determined by these data (see the notes); "
            f"exit status {NOT_DETERMINED_STATUS}",
            file=sys.stderr,
        )
        return NOT_DETERMINED_STATUS
    return 0


def add_fit_parser(sub: argparse._SubParsersAction) -> None:
    from pathlib import Path

    p = sub.add_parser(
        "fit",
        help="fit a measured rattleback's friction, damping and launch, with intervals",
        description="Fit the inputs named by --free to a measurement of a real "
        "rattleback: a Tracker video export (heading), a phyphox gyroscope export, a "
        "CSV or a netCDF file. Searches with batches of candidate runs, then writes "
        "fit.toml (each input with its 95 % interval, the fitted body, and the "
        "simulate command that runs the fitted rattleback), fit.nc and fit.png into "
        "--out. Exit status 3 "
        "when an input is not determined by the data (the files are still written).",
    )
    p.add_argument("data", help="the measurement file")
    p.add_argument(
        "--body",
        required=True,
        metavar="PRESET|FILE.toml",
        help="a preset name or a TOML file with a [body] table",
    )
    p.add_argument(
        "--free",
        action="append",
        metavar="NAME=LOW:HIGH",
        required=True,
        help="an input to fit and its bounds (repeat): any input of simulate "
        "(spin, roll_deg, mu, damping, mu_spin, ...), delta_deg, the body's misalignment, "
        "or a gyroscope's angle sensor_yaw_deg, sensor_pitch_deg, sensor_roll_deg",
    )
    p.add_argument(
        "--fixed",
        action="append",
        metavar="NAME=VALUE",
        help="an input held at a value (repeat; default: none, the others take simulate's "
        "defaults); also a gyroscope's angles, sensor_mass=KG and "
        "sensor_position=X,Y,Z (m, from the centre of the flat face)",
    )
    p.add_argument(
        "--out", type=Path, required=True, help="directory for fit.toml, fit.nc, fit.png"
    )
    p.add_argument(
        "--format",
        choices=["phyphox", "tracker", "csv", "netcdf"],
        default=None,
        help="the file's format (default: detected)",
    )
    p.add_argument(
        "--time-column", default=None, help="csv: the time column (s); default: none"
    )
    p.add_argument(
        "--heading-column", default=None, help="csv: the heading column; default: none"
    )
    p.add_argument(
        "--rate-columns",
        nargs=3,
        metavar=("X", "Y", "Z"),
        default=None,
        help="csv: the gyroscope rate columns (rad/s); default: none",
    )
    p.add_argument(
        "--angle-units",
        choices=["deg", "rad"],
        default=None,
        help="units of a heading column (default: degrees for Tracker)",
    )
    p.add_argument(
        "--trim-start",
        type=float,
        default=0.0,
        help="seconds before the release to drop; time counts from there",
    )
    p.add_argument("--window", type=float, default=0.5, help="seconds per compared window")
    p.add_argument("--no-bias", action="store_true", help="gyroscope: no per-axis bias")
    p.add_argument(
        "--mirrored",
        action="store_true",
        help="heading: the video is mirrored (clockwise from above counted positive)",
    )
    p.add_argument(
        "--compare-models",
        action="store_true",
        help="fit rolling contact, Coulomb friction and Coulomb with spin friction, "
        "rank them by AICc (models.toml), and write the preferred one's fit; mu and "
        "mu_spin may be given in --free for their bounds",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed of the search")
    p.add_argument("--force", action="store_true", help="replace a fit already in --out")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=_cmd_fit)
