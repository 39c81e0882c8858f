"""``python -m rattlesweep``: the command line, as the ``rattlesweep`` command
(:func:`rattlesweep.cli.run`)."""

from .cli import run

run()
