"""Pages of the documentation generated from the package itself, so that they cannot
drift from it: the command-line help, the inputs of both models and the sweepable
parameters (from their descriptions, :mod:`rattlesweep.inputs`) and the body presets.

Called by conf.py at the start of each build; writes Markdown under ``docs/generated/``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rattlesweep.rattleback.body import PRESETS
from rattlesweep.cli import build_parser
from rattlesweep.sweep import DEMO_TOML
from rattlesweep.inputs import PLANAR, RATTLEBACK, Input
from rattlesweep.sweep._config.params import PARAMS


def cli_page() -> str:
    parser = build_parser()
    parser.prog = "rattlesweep"
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    lines = [
        "# Command-line reference",
        "",
        "Every command is `rattlesweep COMMAND ...`; `rattlesweep COMMAND --help` "
        "prints the same text as below. Errors in the input (a bad configuration, a "
        "file that is not a rattlesweep result) print a message naming what is wrong "
        "and exit with status 2.",
        "",
        "```text",
        parser.format_help().rstrip(),
        "```",
        "",
        "## At a glance",
        "",
        "```text",
    ]
    for p in sub.choices.values():  # each usage without its "usage: " and that indent
        usage = p.format_usage().removeprefix("usage: ").rstrip().splitlines()
        lines += [
            usage[0],
            *(line.removeprefix(" " * len("usage: ")) for line in usage[1:]),
        ]
    lines += ["```", ""]
    for name, p in sub.choices.items():
        lines += [
            f"## `rattlesweep {name}`",
            "",
            "```text",
            p.format_help().rstrip(),
            "```",
            "",
        ]
    return "\n".join(lines)


def parameters_table() -> str:
    lines = [
        "| name | meaning | units (default first) | rule | default |",
        "|---|---|---|---|---|",
    ]
    for p in PARAMS.values():
        units = ", ".join(f"`{u}`" for u in p.units)
        if p.group == "body":
            shown = "the `toy` preset's"  # a sweep's body when none is given
        elif p.spec.required:
            shown = "required to simulate"
        else:
            shown = p.spec.default_text
        lines.append(f"| `{p.name}` | {p.long_name} | {units} | {p.rule.short} | {shown} |")
    return "\n".join(lines) + "\n"


def _inputs_table(inputs: dict[str, Input], function: str) -> list[str]:
    lines = [
        f"| argument of `{function}` | name in results | units | meaning | default | "
        "rule |",
        "|---|---|---|---|---|---|",
    ]
    for i in inputs.values():
        if i.group == "body":
            continue
        shown = (
            f"`{i.result_name}`"
            if i.in_results
            else "global attribute"
            if (i.name in ("method", "record_every", "reversal_band", "stop"))
            else "not kept"
        )
        units = i.result_units or i.units
        rule = i.rule.short if i.rule else ""
        if i.launch_state and rule:
            rule += " (a batch gives a non-finite value the status `non_finite`)"
        lines.append(
            f"| `{i.name}` | {shown} | {units} | {i.doc} | {i.default_text} | {rule} |"
        )
    return lines


def _body_table(inputs: dict[str, Input]) -> list[str]:
    lines = ["| name in results | units | long name |", "|---|---|---|"]
    lines += [
        f"| `{i.result_name}` | {i.result_units or i.units} | {i.long_name} |"
        for i in inputs.values()
        if i.group == "body" and i.in_results
    ]
    return lines


def inputs_page() -> str:
    """The inputs of both models: the arguments and the body's parameters as results
    name them, each with its units, default and rule."""
    lines = [
        "### The rattleback (`run_batch`, `simulate`)",
        "",
        *_inputs_table(RATTLEBACK, "run_batch"),
        "",
        "Its body's parameters, coordinates of every result (`delta_deg` of a sweep "
        "that varies it):",
        "",
        *_body_table(RATTLEBACK),
        "",
        "### The rocking semi-ellipse (`run_planar_batch`, `simulate_planar`)",
        "",
        *_inputs_table(PLANAR, "run_planar_batch"),
        "",
        "Its body's parameters:",
        "",
        *_body_table(PLANAR),
    ]
    return "\n".join(lines) + "\n"


def presets_table() -> str:
    lines = ["| name | description and source |", "|---|---|"]
    for name, (_, text) in PRESETS.items():
        lines.append(f"| `{name}` | {text} |")
    return "\n".join(lines) + "\n"


def write_all(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    pages = {
        "cli.md": cli_page(),
        "parameters.md": parameters_table(),
        "inputs.md": inputs_page(),
        "presets.md": presets_table(),
        "demo.toml": DEMO_TOML,
    }
    for name, text in pages.items():
        path = out / name
        # rewrite only what changed, so that Sphinx rebuilds only what changed
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
