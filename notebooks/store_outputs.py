"""Run the notebooks at full size and store their outputs in them, for the documentation,
which renders them as stored (docs/conf.py: nb_execution_mode = "off").

    .venv/bin/python notebooks/store_outputs.py                 # all eight, 2-3 minutes
    .venv/bin/python notebooks/store_outputs.py 02 05           # those whose names start so

Each notebook runs in a scratch directory (its files, notebook-output/, are thrown away),
with the same kernel the test suite uses. Execution counts and timing metadata are left
out, so that a rerun changes only what the results changed.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import nbclient
import nbformat

HERE = Path(__file__).resolve().parent


def _strip_paths(output: dict) -> None:
    """This checkout's path out of the stored text (results record the command that made
    them, the kernel's interpreter among it)."""
    root = str(HERE.parent) + os.sep
    if "text" in output:
        output["text"] = output["text"].replace(root, "")
    for kind, value in output.get("data", {}).items():
        if kind.startswith("text/") and isinstance(value, str):
            output["data"][kind] = value.replace(root, "")


def store(path: Path) -> None:
    nb = nbformat.read(path, as_version=4)
    with tempfile.TemporaryDirectory() as scratch:
        client = nbclient.NotebookClient(
            nb,
            timeout=600,
            kernel_name="python3",
            resources={"metadata": {"path": scratch}},
        )
        client.execute()
    for cell in nb.cells:
        cell.metadata.pop("execution", None)
        if cell.cell_type == "code":
            cell.execution_count = None
            for output in cell.outputs:
                if "execution_count" in output:
                    output.execution_count = None
                _strip_paths(output)
    nb.metadata.pop("widgets", None)
    nbformat.write(nb, path)


def main(prefixes: list[str]) -> None:
    if os.environ.get("RATTLESWEEP_NOTEBOOK_SIZE", "full") != "full":
        sys.exit(
            "RATTLESWEEP_NOTEBOOK_SIZE is set: the stored outputs are the full-size ones"
        )
    os.environ.pop("MPLBACKEND", None)  # the kernel draws inline
    for path in sorted(HERE.glob("*.ipynb")):
        if prefixes and not any(path.name.startswith(p) for p in prefixes):
            continue
        t0 = time.perf_counter()
        store(path)
        print(
            f"{path.name}: {time.perf_counter() - t0:.0f} s, "
            f"{path.stat().st_size / 1e3:.0f} kB"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
