"""The package's type annotations hold: mypy, with the ``[tool.mypy]`` configuration of
pyproject.toml, finds no error in ``src/rattlesweep``; the package carries the marker
that it is typed (``py.typed``, PEP 561); and the constructors spelled out for type
checkers are those the dataclasses make.

The mypy check needs mypy (the ``test`` extra, which CI installs) and the sources next to
the tests; it is skipped without them."""

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import rattlesweep

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "rattlesweep"


def test_package_is_marked_typed():
    assert (Path(rattlesweep.__file__).parent / "py.typed").is_file()


def test_mypy_finds_no_error(tmp_path):
    pytest.importorskip("mypy")
    if not (ROOT / "pyproject.toml").is_file() or not PACKAGE.is_dir():
        pytest.skip("the sources are not next to the tests")
    # a fresh cache: the check does not depend on, or leave, state in the checkout
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--config-file",
            str(ROOT / "pyproject.toml"),
            "--cache-dir",
            str(tmp_path / "mypy-cache"),
            str(PACKAGE),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize("cls", [rattlesweep.Body, rattlesweep.PlanarBody])
def test_constructor_signature_for_type_checkers_is_the_dataclass_one(cls):
    """Body and PlanarBody spell out their constructor under ``if TYPE_CHECKING`` (it
    takes other types than the fields hold); its parameters and defaults are those of the
    ``__init__`` the dataclass makes at run time."""
    source = Path(inspect.getsourcefile(cls)).read_text()
    typed = None
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ClassDef) and node.name == cls.__name__:
            typed = next(
                f
                for block in node.body
                if isinstance(block, ast.If)
                for f in block.body
                if isinstance(f, ast.FunctionDef) and f.name == "__init__"
            )
    assert typed is not None
    args = typed.args.args[1:]
    defaults = [None] * (len(args) - len(typed.args.defaults)) + typed.args.defaults
    made = list(inspect.signature(cls).parameters.values())
    assert [a.arg for a in args] == [p.name for p in made]
    for default, p in zip(defaults, made):
        expected = inspect.Parameter.empty if default is None else ast.literal_eval(default)
        assert p.default == expected, p.name
