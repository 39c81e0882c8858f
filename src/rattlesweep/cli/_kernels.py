"""The command that compiles the kernels ahead: ``rattlesweep compile``."""

from __future__ import annotations

import argparse


def _cmd_compile(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..kernel_cache import compile_kernels

    try:
        compile_kernels(args.jobs)
    except KeyboardInterrupt:  # compile_kernels said what is kept
        return 130
    return 0
