"""Pages of the documentation generated from the package itself, so that they cannot
drift from it: the command-line help, the sweepable parameters and the body presets.

Called by conf.py at the start of each build; writes Markdown under ``docs/generated/``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rattlesweep.body import PRESETS
from rattlesweep.cli import build_parser
from rattlesweep.sweep.demo import DEMO_TOML
from rattlesweep.sweep.params import DEFAULTS, PARAMS

_RULES = {"positive": "finite, > 0", "finite": "finite", "nonneg_inf": ">= 0, `inf` allowed",
          "nonneg": "finite, >= 0"}


def cli_page() -> str:
    parser = build_parser()
    parser.prog = "rattlesweep"
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    lines = ["# Command-line reference", "",
             "Every command is `rattlesweep COMMAND ...`; `rattlesweep COMMAND --help` "
             "prints the same text as below. Errors in the input (a bad configuration, a "
             "file that is not a rattlesweep result) print a message naming what is wrong "
             "and exit with status 2.", "", "```text", parser.format_help().rstrip(), "```",
             "", "## At a glance", "", "```text"]
    for p in sub.choices.values():  # each usage without its "usage: " and that indent
        usage = p.format_usage().removeprefix("usage: ").rstrip().splitlines()
        lines += [usage[0], *(line.removeprefix(" " * len("usage: ")) for line in usage[1:])]
    lines += ["```", ""]
    for name, p in sub.choices.items():
        lines += [f"## `rattlesweep {name}`", "", "```text", p.format_help().rstrip(), "```",
                  ""]
    return "\n".join(lines)


def parameters_table() -> str:
    lines = ["| name | meaning | units (default first) | rule | default |",
             "|---|---|---|---|---|"]
    for p in PARAMS.values():
        units = ", ".join(f"`{u}`" for u in p.units)
        default = DEFAULTS.get(p.name, "")
        shown = "" if default == "" else f"`{default}`"
        if p.name == "mu_static":
            shown = "`mu`"
        if p.name == "dt":
            shown = "1/64 of the body's shortest small-oscillation period"
        if p.name in ("a", "b", "c", "mass", "delta"):
            shown = "the `toy` preset's"
        if p.name == "t_end":
            shown = "required to simulate"
        lines.append(f"| `{p.name}` | {p.long_name} | {units} | {_RULES[p.rule]} | {shown} |")
    return "\n".join(lines) + "\n"


def presets_table() -> str:
    lines = ["| name | description and source |", "|---|---|"]
    for name, (_, text) in PRESETS.items():
        lines.append(f"| `{name}` | {text} |")
    return "\n".join(lines) + "\n"


def write_all(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    pages = {"cli.md": cli_page(), "parameters.md": parameters_table(),
             "presets.md": presets_table(), "demo.toml": DEMO_TOML}
    for name, text in pages.items():
        path = out / name
        # rewrite only what changed, so that Sphinx rebuilds only what changed
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
