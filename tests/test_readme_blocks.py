"""The front page and the getting-started page work as pasted: every ```python block of
README.md and docs/tutorial.md runs, in order, in one fresh Python process per page (the
tutorial's blocks build on each other, as a reader's session does), in a scratch
directory. The README's commands are the ones CI runs, and no page points a reader at
files they do not have."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", ROOT / "docs" / "tutorial.md"]

# runs the blocks given as arguments one after another in one namespace, naming the
# block that fails
RUNNER = """
import sys, traceback
ns = {"__name__": "__main__"}
for i, block in enumerate(sys.argv[1:], 1):
    try:
        exec(compile(block, f"<block {i}>", "exec"), ns)
    except BaseException:
        traceback.print_exc()
        sys.exit(f"python block {i} of {len(sys.argv) - 1} failed:\\n{block}")
"""


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_blocks_are_found():
    blocks = python_blocks(
        "x\n```python\na = 1\n```\n```bash\nls\n```\n```python\nb\n```\n"
    )
    assert blocks == ["a = 1\n", "b\n"]


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_python_blocks_run_as_pasted(page, tmp_path):
    blocks = python_blocks(page.read_text())
    assert blocks, f"{page.name} has no python block"
    env = {"PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg", "HOME": str(tmp_path)}
    for key in ("NUMBA_CACHE_DIR", "NUMBA_NUM_THREADS", "PYTHONPATH"):
        if key in os.environ:
            env[key] = os.environ[key]
    result = subprocess.run(
        [sys.executable, "-c", RUNNER, *blocks],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-5000:]


def test_readme_is_a_front_page_with_the_two_commands():
    text = (ROOT / "README.md").read_text()
    assert len(text.encode()) <= 8192
    commands = re.findall(r"^```bash\n(.*?)\n```", text, flags=re.S | re.M)
    main_job = (
        "python3 -m venv .venv && .venv/bin/pip install -e . && "
        ".venv/bin/rattlesweep compile && .venv/bin/rattlesweep demo --out rattlesweep-demo"
    )
    tests = (
        "python3 -m venv .venv && .venv/bin/pip install -e '.[test,docs]' && "
        ".venv/bin/rattlesweep compile && .venv/bin/python -m pytest"
    )
    assert commands == [main_job, tests]
    assert tests in (ROOT / ".ci" / "run").read_text()  # CI runs the README's command
    assert "docs/gallery/reversal_map.png" in text
    for link in re.findall(r"\]\((?!https?:)([^)#]+)", text):
        assert (ROOT / link).exists(), link


def test_no_page_points_at_the_developers_shared_folder():
    pages = [
        ROOT / "README.md",
        *(ROOT / "docs").rglob("*.md"),
        *(ROOT / "notebooks").glob("*.ipynb"),
    ]
    pages = [p for p in pages if "_build" not in p.parts and "generated" not in p.parts]
    found = [
        p.relative_to(ROOT)
        for p in pages
        if re.search(r"MODEL\.md|shared folder", p.read_text())
    ]
    assert not found
