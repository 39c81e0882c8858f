"""The command line's parser: every command, its options and the function it runs."""

from __future__ import annotations

import argparse
import difflib
from typing import Any, NoReturn

from .._version import __version__

from ._launches import (
    NOT_ROBUST_STATUS,
    _add_launch_options,
    _add_run_options,
    _cmd_animate,
    _cmd_design,
    _cmd_explore,
    _cmd_simulate,
)
from ._fit import add_fit_parser
from ._kernels import _cmd_compile
from ._outputs import _cmd_info, _cmd_plot
from ._sweeps import (
    _cmd_demo,
    _cmd_export,
    _cmd_resume,
    _cmd_stability,
    _cmd_sweep,
    _cmd_verify,
)


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Adds each option's default to its help, unless the help says it already; flags
    (default off) and options without a default say what leaving them out means."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if (
            "default" in text
            or not action.option_strings
            or action.required
            or action.default is None
            or action.default is False
            or action.default is argparse.SUPPRESS
        ):
            return text
        return f"{text} (default: %(default)s)" if text else "default: %(default)s"


class _Parser(argparse.ArgumentParser):
    """Every parser and subcommand parser shows the defaults in its --help, and takes
    options by their full names only: argparse's abbreviations would take ``--roll 0.3``
    as ``--roll-deg 0.3``, an angle in degrees where radians were meant."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        if message.startswith("unrecognized arguments:"):
            message += _suggestion(self, message.split(":", 1)[1].split())
        super().error(message)


def _suggestion(parser: argparse.ArgumentParser, given: list[str]) -> str:
    """For options not known, the closest known ones (``--roll``: ``--roll-deg``)."""
    known: set[str] = set()
    stack = [parser]
    while stack:
        p = stack.pop()
        for action in p._actions:
            known.update(o for o in action.option_strings if o.startswith("--"))
            if isinstance(action, argparse._SubParsersAction):
                stack.extend(action.choices.values())
    hints = []
    for option in (g.split("=", 1)[0] for g in given if g.startswith("--")):
        if f"{option}-deg" in known:  # an angle given as if in radians
            close = [f"{option}-deg"]
        else:
            close = difflib.get_close_matches(option, sorted(known), n=1, cutoff=0.6)
        if close:
            unit = (
                " (angles on the command line are in degrees)" if "-deg" in close[0] else ""
            )
            hints.append(f"{option}: did you mean {close[0]}?{unit}")
    return ("; " + "; ".join(hints)) if hints else ""


DESCRIPTION = (
    "Simulate rattlebacks (celts) and map where their spin reverses: one launch "
    "(simulate, animate), a grid of launches (sweep, resume, info, plot, export, "
    "verify, demo), linear stability (stability), a printable rattleback (design), "
    "a fit to a measured one (fit), a page in the browser (explore), and the compiled "
    "kernels built ahead (compile). `rattlesweep COMMAND --help` says more."
)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rattlesweep", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"rattlesweep {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("sweep", help="run a sweep from a TOML file into a directory")
    p.add_argument("config", help="sweep configuration (TOML)")
    p.add_argument(
        "--out",
        default=None,
        help="output: a directory (netCDF) or a zarr store (a path or URL); "
        "required unless --dry-run (default: none)",
    )
    p.add_argument(
        "--dry-run",
        action="store_true",
        help="compute and write nothing: print the points, tiles, and the time "
        "and memory expected (timed on a sample of the grid's launches)",
    )
    p.add_argument(
        "--output",
        choices=["netcdf", "zarr"],
        default=None,
        help="output format (default: the configuration's 'output', netcdf)",
    )
    p.add_argument(
        "--refine",
        type=int,
        default=None,
        metavar="LEVELS",
        help="refine the grid adaptively this many levels (each halves the "
        "spacing of the refined axes; 0: no refinement); default: the "
        "configuration's [refine]",
    )
    p.add_argument(
        "--stop",
        choices=["first_reversal", "t_end"],
        default=None,
        help="end each launch at its first reversal, or run it to t_end "
        "(default: the configuration's 'stop', t_end)",
    )
    p.add_argument(
        "--lyapunov",
        action="store_true",
        help="add each launch's largest Lyapunov exponent, lyapunov (1/s; rolling "
        "contact only); default: the configuration's 'lyapunov', false",
    )
    _add_run_options(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser(
        "resume",
        help="finish an interrupted sweep in DIR (a sweep directory or zarr store)",
    )
    p.add_argument("dir", help="sweep directory (or its sweep.nc) or zarr store")
    _add_run_options(p)
    p.set_defaults(func=_cmd_resume)

    p = sub.add_parser(
        "demo",
        help="run the default sweep (toy rattleback, spin x "
        "misalignment x friction, refined adaptively, each launch stopped "
        "at its first reversal); write the netCDF file and a map PNG",
    )
    p.add_argument("--out", default="rattlesweep-demo", help="output directory")
    p.add_argument(
        "--print-config",
        action="store_true",
        help="print the demo's TOML configuration and exit",
    )
    _add_run_options(p)
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("export", help="write a finished zarr store as one netCDF file")
    p.add_argument("store", help="zarr store (a path or URL)")
    p.add_argument("out", help="netCDF file to write")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser(
        "verify",
        help="read back every tile of sweep outputs (sweep "
        "directories or zarr stores) and name what is missing or damaged; "
        "exit status 1 if anything is, 2 if an output holds no sweep",
    )
    p.add_argument(
        "outputs",
        nargs="+",
        metavar="OUT",
        help="sweep directory (or its sweep.nc) or zarr store (a path or URL)",
    )
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("plot", help="draw a map of a sweep result to PNG")
    p.add_argument(
        "files",
        nargs="+",
        help="sweep result netCDF file(s), or sweep directories (their sweep.nc)",
    )
    p.add_argument(
        "--var",
        default=None,
        help="variable (default: outcome, or growth_rate for stability files); "
        "lyapunov draws the exponent over the linear stability of steady spin",
    )
    p.add_argument("--x", default=None, help="dimension across (default: the first)")
    p.add_argument("--y", default=None, help="dimension up (default: the second)")
    p.add_argument(
        "--facet",
        default=None,
        help="dimension to draw one panel per value (default: none, one panel)",
    )
    p.add_argument(
        "--select",
        action="append",
        metavar="DIM=VALUE",
        help="fix another dimension (nearest value); repeatable (default: "
        "the first value of each dimension not drawn)",
    )
    p.add_argument(
        "--reduce",
        choices=["mean"],
        default=None,
        help="average a continuous variable over the remaining dimensions "
        "(default: none, select instead)",
    )
    p.add_argument(
        "--overlay",
        default=None,
        metavar="SWEEP.nc",
        help="draw this sweep's simulated reversal boundary on the map (default: none)",
    )
    p.add_argument(
        "--versus",
        default=None,
        metavar="SWEEP.nc",
        help="instead of a map: first reversal time in SWEEP.nc against the "
        "stability file's 1/growth rate (coloured by --facet; default: a map)",
    )
    p.add_argument("--out", default=None, help="PNG path (default: next to the file)")
    p.add_argument(
        "--dpi", type=int, default=120, help="resolution of the PNG (dots per inch)"
    )
    p.set_defaults(func=_cmd_plot)

    p = sub.add_parser(
        "stability",
        help="linear stability of steady spin over a "
        "sweep's grid (t_end not needed); write a netCDF file",
    )
    p.add_argument("config", help="sweep configuration (TOML)")
    p.add_argument("--out", required=True, help="netCDF file to write")
    p.set_defaults(func=_cmd_stability)

    p = sub.add_parser("info", help="summarise result files or sweep directories")
    p.add_argument("files", nargs="+", help="netCDF result files or sweep directories")
    p.add_argument("--config", action="store_true", help="also print the sweep TOML")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser(
        "design",
        help="design a printable rattleback: a shell with two "
        "coins in pockets placed by simulation; write STL, placement sheet, "
        "design.toml and a reversal map",
    )
    p.add_argument("--a", type=float, required=True, help="half length of the shell (m)")
    p.add_argument("--b", type=float, required=True, help="half width of the shell (m)")
    p.add_argument("--c", type=float, required=True, help="height of the shell (m)")
    p.add_argument(
        "--coin",
        default=None,
        help="coin or washer preset, any case (default "
        "eur_1): eur_1, eur_2, eur_0.50, usd_0.25, usd_0.05, usd_0.01, gbp_0.02, "
        "gbp_0.10, washer_M8, washer_M10, washer_M12. Two coins are used (a pair "
        "symmetric about the centre)",
    )
    p.add_argument(
        "--coin-mass",
        type=float,
        default=None,
        help="coin mass (kg; default: the --coin preset's, which this "
        "overrides; give all three --coin-* for a coin of your own)",
    )
    p.add_argument(
        "--coin-diameter",
        type=float,
        default=None,
        help="coin diameter (m; default: the --coin preset's, which this overrides)",
    )
    p.add_argument(
        "--coin-thickness",
        type=float,
        default=None,
        help="coin thickness (m; default: the --coin preset's, which this overrides)",
    )
    p.add_argument(
        "--infill",
        type=float,
        default=0.2,
        help="infill fraction in (0, 1] (default 0.2, i.e. 20 %%)",
    )
    p.add_argument(
        "--material",
        default="pla",
        help="pla, petg or abs (default pla); any name with --density",
    )
    p.add_argument(
        "--density",
        type=float,
        default=None,
        metavar="KG_M3",
        help="density of the material (kg/m^3; default: the --material "
        "preset's, pla 1240, petg 1270, abs 1040, which this overrides)",
    )
    p.add_argument(
        "--wall",
        type=float,
        default=1.2e-3,
        help="solid wall thickness (m; default 0.0012)",
    )
    p.add_argument(
        "--clearance",
        type=float,
        default=0.4e-3,
        help="pocket diameter minus coin diameter (m; default 0.0004)",
    )
    p.add_argument(
        "--rim",
        type=float,
        default=2e-3,
        help="least material beside a pocket (m; default 0.002)",
    )
    p.add_argument(
        "--mu",
        type=float,
        nargs=2,
        default=(0.2, 0.5),
        metavar=("LOW", "HIGH"),
        help="friction range to design for (default 0.2 0.5: a table top)",
    )
    p.add_argument(
        "--margin",
        type=float,
        default=0.1,
        help="G at most (1 - margin) x the smaller radius of curvature",
    )
    p.add_argument(
        "--prefer",
        choices=["cw", "ccw"],
        default="cw",
        help="sense (seen from above) in which it spins on",
    )
    p.add_argument(
        "--out", required=True, help="output directory: new or empty, unless --force"
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="write into --out even when it holds files (the design's own "
        "files there are replaced, others kept)",
    )
    p.add_argument(
        "--accept-not-robust",
        action="store_true",
        help=f"exit 0 for a design that is not robust (default: exit status "
        f"{NOT_ROBUST_STATUS}, the files written all the same)",
    )
    p.add_argument(
        "--quiet", action="store_true", help="no progress lines (on stderr) while it works"
    )
    p.set_defaults(func=_cmd_design)

    p = sub.add_parser(
        "simulate",
        help="simulate one launch: a preset, a homogeneous "
        "semi-ellipsoid or a body from a TOML file",
    )
    _add_launch_options(p)
    p.add_argument("--out", default=None, help="netCDF file to write (default: none)")
    p.add_argument(
        "--png", default=None, help="PNG of spin against time to write (default: none)"
    )
    p.add_argument(
        "--lyapunov",
        action="store_true",
        help="also compute the launch's largest Lyapunov exponent (1/s; rolling "
        "contact only; default: not computed)",
    )
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "animate",
        help="3-D animation (GIF, or MP4 with ffmpeg) of one "
        "launch, simulated from the options or read with --run",
    )
    _add_launch_options(p)
    p.add_argument(
        "--run",
        default=None,
        metavar="FILE.nc",
        help="animate this saved simulate result instead of simulating "
        "(default: simulate from the options)",
    )
    p.add_argument("--out", required=True, help="animation file (.gif or .mp4)")
    p.add_argument("--frames", type=int, default=100, help="number of frames")
    p.add_argument("--fps", type=float, default=20.0, help="frames per second")
    p.add_argument(
        "--dpi", type=int, default=80, help="resolution of the frames (dots per inch)"
    )
    p.add_argument(
        "--z-stretch",
        type=float,
        default=None,
        help="draw heights this many times larger (default: automatic)",
    )
    p.set_defaults(func=_cmd_animate)

    p = sub.add_parser(
        "explore",
        help="the rattleback live in the browser: a local web "
        "page with controls, a 3-D view, plots and a reversal map",
        description="Serve the explorer, a local web page with the body, "
        "launch and friction as controls, a 3-D view of the run with linked "
        "plots of spin, tilt, energy and slip speed, and a reversal map whose "
        "points load their launch. Warms the kernels first (a first run after "
        "installing compiles them, minutes unless `rattlesweep compile` did it "
        "ahead), then prints the address and opens the browser. Ctrl-C stops it.",
    )
    p.add_argument(
        "--port", type=_port, default=8050, help="port (default 8050; 0: any free)"
    )
    p.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only)",
    )
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.set_defaults(func=_cmd_explore)

    p = sub.add_parser(
        "compile",
        help="compile every simulation kernel ahead, in parallel (once after "
        "installing: later runs start in about a second)",
        description="Compile every kernel specialisation the library can call (both "
        "models, every friction level) into numba's on-disk cache, in several "
        "processes, printing each as it finishes and the cache's place and size. "
        "Without it, the first run of each kind compiles what it needs on the spot. "
        "Run again, it finds everything compiled and does nothing. Point "
        "NUMBA_CACHE_DIR at a shared directory to compile once for many processes or "
        "a cluster's workers.",
    )
    p.add_argument(
        "--jobs",
        type=_positive_int,
        default=None,
        help="processes compiling at once (default: the cores this process may use)",
    )
    p.set_defaults(func=_cmd_compile)

    add_fit_parser(sub)
    return parser


def _port(text: str) -> int:
    """An argparse type: a TCP port number, 0 to 65535 (0: any free port)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(
            f"must be a port number from 0 to 65535 (0: any free port), got {text!r}"
        )
    return value


def _positive_int(text: str) -> int:
    """An argparse type: a whole number of at least 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(
            f"must be a whole number of at least 1, got {text!r}"
        )
    return value
