"""The keyword arguments of the public entry points (:func:`rattlesweep.run_batch`,
:func:`rattlesweep.simulate` and the planar model's), from the descriptions of
:mod:`rattlesweep.inputs`: the per-launch inputs a model takes, the refusal of any other
name, and each function's signature and parameter documentation.

The functions take the per-launch inputs as ``**inputs`` and pass them down the batch
layer as one mapping, so an input added to a model's description is taken, checked,
documented and packed for the kernel (by its name) without an edit here or in them.
"""

from __future__ import annotations

import difflib
import inspect
import textwrap
from typing import Any, Callable, Mapping, Sequence, TypeVar

from .inputs import INPUTS, Input

__all__ = [
    "LAUNCH_GROUPS",
    "accepted",
    "angles",
    "check_keywords",
    "document",
    "launch_values",
    "per_launch",
]

F = TypeVar("F", bound=Callable[..., Any])

LAUNCH_GROUPS = ("launch", "friction", "numerics")
"""The groups of the inputs each launch takes (the body's are the body's; the run's are
options of the call)."""


def per_launch(inputs: Mapping[str, Input]) -> dict[str, Input]:
    """The inputs each launch of a model takes, in the description's order."""
    return {k: i for k, i in inputs.items() if i.group in LAUNCH_GROUPS}


def angles(inputs: Mapping[str, Input]) -> tuple[str, ...]:
    """The launch angles, which a caller may give in degrees as ``<name>_deg``."""
    return tuple(k for k, i in per_launch(inputs).items() if i.result_units == "degree")


def accepted(inputs: Mapping[str, Input]) -> tuple[str, ...]:
    """The names a model's per-launch inputs may be given by: each input's, and the
    degree form of each angle after it."""
    degrees = angles(inputs)
    names: list[str] = []
    for name in per_launch(inputs):
        names += [name, f"{name}_deg"] if name in degrees else [name]
    return tuple(names)


def check_keywords(
    function: Callable[..., Any],
    given: Mapping[str, Any],
    names: Sequence[str],
    required: Mapping[str, Input] | None = None,
) -> None:
    """Refuse, before anything is computed, a keyword of ``given`` that is not one of
    ``names`` (the inputs ``function`` takes as ``**given``), naming it and listing
    the inputs and the function's own keyword-only options, with the closest of all
    these names, and an input of ``required`` (the model's inputs) that is required and
    not in ``given``: TypeErrors, as Python's own for an unexpected keyword or a missing
    argument."""
    for key in given:
        if key not in names:
            options = [
                p.name
                for p in inspect.signature(function).parameters.values()
                if p.kind is p.KEYWORD_ONLY and p.name not in names
            ]
            close = difflib.get_close_matches(key, [*names, *options], n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            described = INPUTS.get(key.removesuffix("_deg"))
            if described is not None and described.group == "body":
                hint = " (it describes the body: give it where the body is made)"
            takes = f"its inputs are {', '.join(names)}"
            if options:
                takes += f"; its options are {', '.join(options)}"
            raise TypeError(
                f"{function.__name__}() got an unknown keyword {key!r}{hint}; {takes}"
            )
    for name, spec in (required or {}).items():
        if spec.required and name not in given:
            raise TypeError(f"{name} ({spec.units}) is required")


def launch_values(given: Mapping[str, Any], inputs: Mapping[str, Input]) -> dict[str, Any]:
    """The scalar per-launch inputs of a call by name: each value given, or for one
    omitted (or None) the value of the input its description names as ``same_as``, else
    its default. An input with neither is left out (the time step, whose default is the
    body's); a required one given as None is refused (a ValueError: one omitted is
    :func:`check_keywords`'s TypeError)."""
    values: dict[str, Any] = {}
    for name, spec in per_launch(inputs).items():
        if spec.width > 1:
            continue
        value = given.get(name)
        if value is None and spec.same_as:
            value = values.get(spec.same_as)
        if value is None:
            value = spec.default
        if value is None and spec.required:
            raise ValueError(f"{name} ({spec.units}) is required")
        if value is not None:
            values[name] = value
    return values


def _code(text: str) -> str:
    """Markdown code spans of the descriptions as reStructuredText literals."""
    parts = text.split("`")
    return "".join(f"``{p}``" if i % 2 else p for i, p in enumerate(parts))


def _kind(spec: Input, scalar: bool) -> str:
    if spec.kind:
        kind = spec.kind
    elif spec.width > 1:
        kind = (
            f"array_like, shape ({spec.width},)"
            if scalar
            else (f"array_like, shape (..., {spec.width})")
        )
    else:
        kind = "float" if scalar else "array_like"
    return kind if spec.required else f"{kind}, optional"


def _entry(spec: Input, scalar: bool) -> list[str]:
    """An input's entry in a numpydoc parameter section: what it is, its units, its
    rule and its default."""
    sentences = [spec.doc, spec.details]
    if spec.units != "1":
        sentences.append(f"Units: {spec.units}.")
    if spec.rule is not None:
        sentences.append(f"Rule: {_code(spec.rule.short)}.")
    if spec.required:
        sentences.append("Required.")
    else:
        sentences.append(f"Default: {_code(spec.default_text) or 'none'}.")
    text = " ".join(s for s in sentences if s)
    return [
        f"{spec.name} : {_kind(spec, scalar)}",
        *textwrap.wrap(text, 84, initial_indent="    ", subsequent_indent="    "),
    ]


def document(inputs: Mapping[str, Input], *, scalar: bool = False) -> Callable[[F], F]:
    """Decorate a public entry point of a model described by ``inputs``: it takes the
    per-launch inputs as ``**inputs`` and the run's options as keyword arguments, each
    described in ``inputs`` too. Gives it the signature of every input, in the
    description's order (the degree form of an angle after it; an input without a value
    of its own shows None), and replaces the line ``{inputs}`` of its docstring with their
    parameter entries. ``scalar``: a single run, whose inputs are numbers."""

    def decorate(function: F) -> F:
        own = inspect.signature(function).parameters
        first = [p for p in own.values() if p.kind is p.POSITIONAL_OR_KEYWORD]
        options = {k: p for k, p in own.items() if p.kind is p.KEYWORD_ONLY}
        undescribed = set(options) - set(inputs)
        if undescribed:
            raise TypeError(
                f"{function.__name__}: the options {sorted(undescribed)} have no "
                "description in rattlesweep.inputs"
            )
        degrees = angles(inputs)
        params: list[inspect.Parameter] = []
        entries: list[str] = []
        for name, spec in inputs.items():
            if name in options:
                params.append(options[name])
            elif spec.group in LAUNCH_GROUPS:
                default = inspect.Parameter.empty if spec.required else spec.default
                kind = "float" if scalar and spec.width == 1 else "ArrayLike"
                params.append(
                    inspect.Parameter(
                        name,
                        inspect.Parameter.KEYWORD_ONLY,
                        default=default,
                        annotation=kind,
                    )
                )
            else:
                continue
            entries += _entry(spec, scalar)
            if name in degrees:
                params.append(
                    inspect.Parameter(
                        f"{name}_deg",
                        inspect.Parameter.KEYWORD_ONLY,
                        default=None,
                        annotation="float" if scalar else "ArrayLike",
                    )
                )
                entries += [
                    f"{name}_deg : {'float' if scalar else 'array_like'}, optional",
                    f"    ``{name}`` in degrees; give one form of the angle, not both.",
                ]
        function.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
            first + params, return_annotation=inspect.signature(function).return_annotation
        )
        doc = function.__doc__ or ""
        marker = next(line for line in doc.splitlines() if line.strip() == "{inputs}")
        indent = marker[: len(marker) - len(marker.lstrip())]
        function.__doc__ = doc.replace(marker, "\n".join(indent + e for e in entries))
        return function

    return decorate
