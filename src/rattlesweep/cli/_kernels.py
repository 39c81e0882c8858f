"""The command that compiles the kernels ahead: ``rattlesweep compile``."""

from __future__ import annotations

import argparse


def _cmd_compile(args: argparse.Namespace, argv: list[str] | None) -> int:
    from ..kernel_cache import compile_kernels

    compile_kernels(args.jobs)
    return 0
