"""``python -m rattlesweep.cli``: the command line."""

from . import run

run()
