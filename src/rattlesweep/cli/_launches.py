"""The commands of one launch or one body: simulate, animate, design, explore, and
the options they share."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING


if TYPE_CHECKING:
    import xarray as xr

    from ..rattleback.body import Body

_SHAPE = ("a", "b", "c", "mass", "delta_deg")


def _body_from_args(args: argparse.Namespace) -> Body:
    """The preset, the body of ``--body FILE``, or a homogeneous semi-ellipsoid whose
    parameters not given are the ``toy`` preset's (as in a sweep file)."""
    from ..rattleback.body import Body

    shape = {k: getattr(args, k) for k in _SHAPE if getattr(args, k) is not None}
    given = [
        o
        for o, used in (
            ("--preset", args.preset is not None),
            ("--body", args.body is not None),
            ("--a/--b/--c/--mass/--delta-deg", bool(shape)),
        )
        if used
    ]
    if len(given) > 1:
        raise ValueError(f"{' and '.join(given)} each choose the body; give one of them")
    if args.body is not None:
        from ..sweep._config.body_file import body_from_argument

        return body_from_argument(args.body)
    if shape:
        from ..sweep._config.grid import semi_ellipsoid_defaults

        si = {
            **semi_ellipsoid_defaults(),
            **{k: v for k, v in shape.items() if k != "delta_deg"},
        }
        if "delta_deg" in shape:
            si["delta"] = math.radians(shape["delta_deg"])
        return Body.semi_ellipsoid(si["a"], si["b"], si["c"], si["mass"], si["delta"])
    return Body.preset(args.preset or "kane_levinson")


_QUICK_LOOK = {"spin": 5.0, "roll": 0.5, "t_end": 10.0}
"""The command line's defaults where they are not the library's: a launch worth a look
from the terminal (the roll in degrees, as its option takes it)."""

_HELP = {
    "spin": "rad/s about the vertical, positive counter-clockwise from above",
    "roll": "initial roll (degrees; raises the body's +y side)",
    "pitch": "initial pitch (degrees; lowers the body's +x end)",
    "yaw": "initial heading (degrees about the vertical)",
    "velocity": "horizontal velocity of G (m/s), a sliding launch (default: the "
    "velocity at which the contact rolls)",
}
"""The command line's own wording of some options; the others say their description."""


def launch_options() -> dict[str, str]:
    """The per-launch inputs of :func:`rattlesweep.simulate` the command line offers, by
    the keyword each is given to it by (an angle in degrees: ``roll_deg``): every input
    with a default or required. Those with neither (``omega``, ``orientation``: the
    alternatives to the spin and the angles) are left to the Python API."""
    from .._keywords import angles, per_launch
    from ..inputs import RATTLEBACK

    degrees = angles(RATTLEBACK)
    return {
        f"{name}_deg" if name in degrees else name: name
        for name, spec in per_launch(RATTLEBACK).items()
        if spec.required or spec.default is not None or spec.default_doc
    }


def _simulate_from_args(args: argparse.Namespace) -> xr.Dataset:
    from ..rattleback.simulate import simulate

    inputs = {key: getattr(args, key) for key in launch_options()}
    lyapunov = getattr(args, "lyapunov", False)  # an option of simulate, not animate
    return simulate(_body_from_args(args), method=args.method, lyapunov=lyapunov, **inputs)


def _cmd_simulate(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..io import check_netcdf_target, write_netcdf

    if args.out:
        check_netcdf_target(args.out)  # before the launch runs
    ds = _simulate_from_args(args)
    if args.out:
        write_netcdf(ds, args.out)
        print(f"wrote {args.out}")
    if args.png:
        from ..plot import spin_history

        figure = spin_history(
            [ds],
            [f"spin {args.spin:+g} rad/s"],
            title=f"{ds.attrs.get('body_name', 'body')}, mu={args.mu:g}",
        )
        Path(args.png).parent.mkdir(parents=True, exist_ok=True)
        figure.savefig(args.png, dpi=120)
        print(f"wrote {args.png}")
    t_rev = float(ds.first_reversal_time)
    print(
        f"first reversal: {'none' if t_rev != t_rev else f'{t_rev:.4f} s'}; "
        f"reversals: {int(ds.n_reversals)}; final spin {float(ds.final_spin):+.4f} rad/s; "
        f"status: {ds.status.attrs['flag_meanings'].split()[int(ds.status)]}"
        + (f"; Lyapunov exponent {float(ds.lyapunov):.4g} 1/s" if "lyapunov" in ds else "")
    )
    return 0


def _cmd_animate(args: argparse.Namespace, argv: list[str] | None) -> int:
    import xarray as xr

    from ..plot import animate

    if args.run is not None:
        from pathlib import Path

        from ._outputs import _check_readable

        _check_readable(Path(args.run))
        with xr.open_dataset(args.run) as ds:
            run = ds.load()
    else:
        run = _simulate_from_args(args)
    t0 = time.perf_counter()
    animate(
        run,
        args.out,
        frames=args.frames,
        fps=args.fps,
        dpi=args.dpi,
        z_stretch=args.z_stretch,
    )
    print(
        f"wrote {args.out}: {args.frames} frames at {args.fps:g} fps "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    return 0


NOT_ROBUST_STATUS = 3
"""Exit status of ``rattlesweep design`` for a design that is not robust (without
``--accept-not-robust``); its files are written all the same."""


def _cmd_design(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..design import design

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    d = design(
        args.a,
        args.b,
        args.c,
        coin=args.coin,
        coin_mass=args.coin_mass,
        coin_diameter=args.coin_diameter,
        coin_thickness=args.coin_thickness,
        infill=args.infill,
        material=args.material,
        density=args.density,
        wall=args.wall,
        clearance=args.clearance,
        rim=args.rim,
        mu=tuple(args.mu),
        margin=args.margin,
        prefer=args.prefer,
        out=args.out,
        overwrite=args.force,
        progress=None if args.quiet else say,
    )
    print(d.summary())
    print(
        f"wrote {', '.join(str(p) for p in d.files.values())} "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    if d.robust:
        return 0
    if args.accept_not_robust:
        print("the design is NOT ROBUST; accepted (--accept-not-robust)")
        return 0
    print(
        f"rattlesweep: the design is NOT ROBUST (see above); its files are written, "
        f"marked so, for you to inspect. Exit status {NOT_ROBUST_STATUS}; give "
        "--accept-not-robust to accept it.",
        file=sys.stderr,
    )
    return NOT_ROBUST_STATUS


def _cmd_explore(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..explore import PortInUse, serve

    try:
        serve(args.host, args.port, open_browser=not args.no_browser)
    except PortInUse as exc:
        print(f"rattlesweep explore: {exc.strerror}", file=sys.stderr)
        return 2
    return 0


def _add_launch_options(p: argparse.ArgumentParser) -> None:
    from ..rattleback.body import PRESETS
    from ..inputs import RATTLEBACK as INPUTS

    body = p.add_argument_group(
        "body (one of: a preset, a TOML file, a semi-ellipsoid; "
        "default: the kane_levinson preset)"
    )
    body.add_argument(
        "--preset",
        default=None,
        choices=sorted(PRESETS),
        help="a preset body (default: kane_levinson, unless --body or a "
        "semi-ellipsoid option is given)",
    )
    body.add_argument(
        "--body",
        default=None,
        metavar="PRESET|FILE.toml",
        help="a preset name, or the body of the file's [body] table: a, b, c, mass, "
        "com, inertia[, full_ellipsoid, name] in SI units, as in a sweep file "
        "(a sweep file's fixed.body and a fit's fit.toml work too); default: none",
    )
    for name, what in (
        ("a", "long semi-axis (m)"),
        ("b", "short semi-axis (m)"),
        ("c", "depth semi-axis (m)"),
        ("mass", "mass (kg)"),
    ):
        body.add_argument(
            f"--{name}",
            type=float,
            default=None,
            help=f"homogeneous semi-ellipsoid: {what} (default: the toy preset's)",
        )
    body.add_argument(
        "--delta-deg",
        type=float,
        default=None,
        help="homogeneous semi-ellipsoid: misalignment of the inertia axes "
        "(degrees; default: the toy preset's)",
    )
    groups = {
        "launch": p.add_argument_group("launch"),
        "friction": p.add_argument_group("friction and numerics"),
    }
    for key, name in launch_options().items():
        spec = INPUTS[name]
        default = _QUICK_LOOK.get(name, spec.default)
        units = "degrees" if key != name else spec.units
        text = _HELP.get(name) or spec.long_name + ("" if units == "1" else f" ({units})")
        if name not in _HELP and name not in _QUICK_LOOK and spec.default_doc:
            text += f"; default: {spec.default_doc.replace('`', '')}"
        group = groups["launch" if spec.group == "launch" else "friction"]
        option, given = (
            f"--{key.replace('_', '-')}",
            default if isinstance(default, float) else None,
        )
        if spec.width > 1:
            metavar = tuple(f"V{c}" for c in "XYZW"[: spec.width])
            group.add_argument(
                option,
                type=float,
                nargs=spec.width,
                metavar=metavar,
                default=given,
                help=text,
            )
        else:
            group.add_argument(option, type=float, default=given, help=text)
    friction = groups["friction"]
    friction.add_argument(
        "--method",
        choices=["rk4", "euler"],
        default="rk4",
        help="integrator: RK4, or first-order semi-implicit Euler",
    )


def _add_run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="address of a running dask.distributed scheduler (default: none, "
        "local threads)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local threads (default: all usable cores)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
