"""The package as users get it: ``python -m build`` makes an sdist and a wheel; the wheel,
installed into a fresh virtual environment, runs ``rattlesweep demo`` through its console
script; the compiled kernels are cached where numba can write, and the next process loads
them from there instead of compiling, also when the installed package is read-only.

Where numba caches (``numba.core.caching``): next to the sources, in the ``__pycache__``
of the installed package, when it can create a file there; otherwise in the user's cache
directory, ``$XDG_CACHE_HOME/numba`` (``~/.cache/numba``). ``NUMBA_CACHE_DIR`` overrides
both, so the tests remove it from the environment, and they point ``XDG_CACHE_HOME`` at a
temporary directory so that the first run compiles and the user's cache stays untouched.
``NUMBA_DEBUG_CACHE=1`` makes numba print each cache file it saves or loads: the tests
read where the first process saved and that the second saved nothing and loaded from the
same place.

The fresh environment gets only the wheel (``pip install --no-deps``); a ``.pth`` file
puts the running interpreter's site-packages after its own, for the dependencies, instead
of installing them again from the network (hundreds of MB, minutes). That site-packages
may hold this checkout's editable install, but it cannot shadow the wheel: the lines of a
``.pth`` file are appended to ``sys.path`` after the environment's own site-packages, and
``.pth`` files inside the added directory (where an editable install hooks itself in) are
not run. The tests check that ``rattlesweep`` imports from the fresh environment.

A first demo compiles for about a minute, in one thread; the two first demos, one per
installation, run at the same time. A demo that loads the kernels takes about 8 s, and
building a few seconds (setuptools comes from PyPI into the build's isolated
environment).
"""

from __future__ import annotations

import os
import re
import runpy
import shutil
import site
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import pytest

pytest.importorskip("build")

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "rattlesweep"

if os.name != "posix" or not (ROOT / "pyproject.toml").is_file():
    pytest.skip("builds from a POSIX source checkout", allow_module_level=True)

CACHE_LINE = re.compile(r"^\[cache\] data (saved to|loaded from) '(.+)'$", re.MULTILINE)
# the outcome counts the demo prints after its timing
SUMMARY = re.compile(r" in [\d.]+ s; (.+)$", re.MULTILINE)
# run in a process that cannot create a file in the directory given, as numba tries to
READ_ONLY_PROBE = """\
import sys, tempfile
try:
    tempfile.TemporaryFile(dir=sys.argv[1]).close()
except PermissionError:
    print("read-only")
"""


def _run(cmd, **kwargs) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [str(c) for c in cmd], capture_output=True, text=True, timeout=600, **kwargs
    )
    assert proc.returncode == 0, (
        f"{cmd} exited with "
        f"{proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    )
    return proc


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> tuple[Path, Path]:
    """The wheel and the sdist. ``python -m build`` without options builds the sdist and
    then the wheel from the unpacked sdist, so a file missing from the sdist that the
    build needs fails here."""
    out = tmp_path_factory.mktemp("dist")
    _run([sys.executable, "-m", "build", "--outdir", out, ROOT])
    (wheel,) = out.glob("rattlesweep-*.whl")
    (sdist,) = out.glob("rattlesweep-*.tar.gz")
    return wheel, sdist


@pytest.fixture(scope="module")
def matplotlib_dir(tmp_path_factory) -> Path:
    """One matplotlib configuration directory for all runs, so that its font cache is
    built once (it would otherwise follow XDG_CACHE_HOME into each test's directory)."""
    return tmp_path_factory.mktemp("matplotlib")


def _source_modules() -> set[str]:
    return {
        p.relative_to(SRC.parent).as_posix()
        for p in SRC.rglob("*.py")
        if "__pycache__" not in p.parts
    }


def test_build_makes_a_wheel_and_an_sdist(dist):
    """The wheel holds every module of the package, ``py.typed``, the console script and
    the version; the sdist holds what a release needs besides the code (README, citation,
    changelog, the complete test suite), and neither holds compiled files from the
    checkout's caches."""
    wheel, sdist = dist
    version = runpy.run_path(str(SRC / "_version.py"))["__version__"]

    assert wheel.name == f"rattlesweep-{version}-py3-none-any.whl"
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        info = f"rattlesweep-{version}.dist-info"
        entry_points = zf.read(f"{info}/entry_points.txt").decode()
        metadata = zf.read(f"{info}/METADATA").decode()
    missing = _source_modules() - names
    assert not missing, f"modules missing from the wheel: {sorted(missing)}"
    assert "rattlesweep/py.typed" in names
    assert re.search(
        r"^\[console_scripts\]\s*^rattlesweep = rattlesweep\.cli:run$",
        entry_points,
        re.MULTILINE,
    ), entry_points
    assert f"\nVersion: {version}\n" in metadata
    assert "\nLicense-Expression: MIT\n" in metadata

    with tarfile.open(sdist) as tf:
        top = f"rattlesweep-{version}/"
        members = {m.name.removeprefix(top) for m in tf.getmembers()}
    for name in (
        "README.md",
        "CITATION.cff",
        "CHANGELOG.md",
        "pyproject.toml",
        "tests/conftest.py",
        "tests/data/reference_runs.npz",
        "tests/test_wheel.py",
    ):
        assert name in members, f"{name} missing from the sdist"
    assert not {f"src/{m}" for m in _source_modules()} - members
    for archive, held in ((wheel, names), (sdist, members)):
        cached = [
            n for n in held if "__pycache__" in n or n.endswith((".nbi", ".nbc", ".pyc"))
        ]
        assert not cached, f"{archive.name} holds cache files: {cached[:5]}"


@dataclass
class Installed:
    """A fresh venv with the wheel installed: its python, the installed package, the
    directory the demo runs in (whose ``user-cache`` is XDG_CACHE_HOME), the environment,
    and the command prefix the demo runs under."""

    python: Path
    package: Path
    home: Path
    env: dict[str, str]
    prefix: list[str] = field(default_factory=list)

    def start_demo(self, out: str) -> subprocess.Popen:
        # output into a file: two demos run at once, and a full pipe would stall one
        log = (self.home / f"{out}.log").open("w")
        with log:
            return subprocess.Popen(
                [
                    *self.prefix,
                    str(self.python.parent / "rattlesweep"),
                    "demo",
                    "--out",
                    out,
                ],
                cwd=self.home,
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
                text=True,
            )

    def finish_demo(self, proc: subprocess.Popen, out: str) -> tuple[dict, str]:
        """Wait for the demo; the cache files it saved and loaded, and the outcome counts
        it printed."""
        proc.wait(timeout=600)
        output = (self.home / f"{out}.log").read_text()
        assert proc.returncode == 0, (
            f"{proc.args} exited with {proc.returncode}:\n{output[-5000:]}"
        )
        assert (self.home / out / "sweep.nc").stat().st_size > 0
        assert (self.home / out / "reversal_map.png").stat().st_size > 0
        events = {"saved to": [], "loaded from": []}
        for kind, path in CACHE_LINE.findall(output):
            events[kind].append(Path(path))
        (summary,) = SUMMARY.findall(output)
        return events, summary

    def demo(self, out: str) -> tuple[dict, str]:
        return self.finish_demo(self.start_demo(out), out)

    @property
    def user_cache(self) -> Path:
        return self.home / "user-cache" / "numba"


def _install(wheel: Path, home: Path, matplotlib_dir: Path) -> Installed:
    """A fresh venv in ``home`` with the wheel installed and the running interpreter's
    dependencies reachable."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON"))}
    env.update(
        XDG_CACHE_HOME=str(home / "user-cache"),
        MPLCONFIGDIR=str(matplotlib_dir),
        NUMBA_DEBUG_CACHE="1",
    )
    _run([sys.executable, "-m", "venv", home / "venv"], env=env)
    python = home / "venv" / "bin" / "python"
    _run(
        [
            python,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--no-index",
            "--disable-pip-version-check",
            "--quiet",
            wheel,
        ],
        env=env,
    )
    purelib = Path(
        _run(
            [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            env=env,
        ).stdout.strip()
    )
    deps = [
        *site.getsitepackages(),
        sysconfig.get_paths()["purelib"],
        sysconfig.get_paths()["platlib"],
    ]
    if site.ENABLE_USER_SITE:
        deps.append(site.getusersitepackages())
    deps = [d for d in dict.fromkeys(deps) if Path(d).is_dir()]
    # written after the install, so that pip does not see this checkout's rattlesweep
    (purelib / "zz_test_wheel_dependencies.pth").write_text("\n".join(deps) + "\n")
    package = purelib / "rattlesweep"
    imported = _run(
        [python, "-c", "import rattlesweep; print(rattlesweep.__file__)"], env=env
    )
    assert Path(imported.stdout.strip()) == package / "__init__.py"
    return Installed(python, package, home, env)


def _chmod_all(package: Path, *, add: int = 0, remove: int = 0) -> None:
    for path in (package, *package.rglob("*")):
        path.chmod(path.stat().st_mode & ~remove | add)


def _make_read_only(installed: Installed) -> None:
    """Take write permission off the installed package, and set the command prefix under
    which a process cannot write into it.

    Permission bits do not bind root, which CI runs as. Where user namespaces are
    allowed, ``unshare --user`` runs a process as root without root's capabilities, to
    which the bits apply. Where they are not (a container's default seccomp profile
    refuses them), each ``__pycache__`` directory of the package becomes a plain file:
    numba cannot create its cache directory there, which it treats as a directory it
    cannot write to (its in-tree locator catches the ``OSError`` of either and numba
    falls through to the user-wide cache)."""
    package = installed.package
    _chmod_all(package, remove=0o222)

    def read_only_under(prefix: list[str]) -> bool:
        proc = subprocess.run(
            [
                *prefix,
                str(installed.python),
                "-c",
                READ_ONLY_PROBE,
                str(package / "_core" / "__pycache__"),
            ],
            capture_output=True,
            text=True,
            env=installed.env,
        )
        return proc.stdout.strip() == "read-only"

    if read_only_under([]):
        return
    if shutil.which("unshare") and read_only_under(["unshare", "--user"]):
        installed.prefix = ["unshare", "--user"]
        return
    for cache in sorted(package.rglob("__pycache__"), reverse=True):
        shutil.rmtree(cache)  # as root, despite the permission bits
        cache.touch()
    _chmod_all(package, remove=0o222)


def _snapshot(package: Path) -> dict[str, tuple[bool, int, int]]:
    return {
        p.relative_to(package).as_posix(): (
            p.is_dir(),
            p.stat().st_size,
            p.stat().st_mtime_ns,
        )
        for p in package.rglob("*")
    }


@pytest.fixture(scope="module")
def installs(dist, tmp_path_factory, matplotlib_dir):
    """Two installations of the wheel, one writable and one read-only, each with the
    result of its first demo. Compiling takes about a minute on one core (numba compiles
    in one thread), so the two first demos run at the same time."""
    writable = _install(dist[0], tmp_path_factory.mktemp("writable"), matplotlib_dir)
    read_only = _install(dist[0], tmp_path_factory.mktemp("read-only"), matplotlib_dir)
    started = []
    try:
        _make_read_only(read_only)
        untouched = _snapshot(read_only.package)
        started = [(i, i.start_demo("first")) for i in (writable, read_only)]
        firsts = [i.finish_demo(proc, "first") for i, proc in started]
        yield {
            "writable": (writable, *firsts[0]),
            "read-only": (read_only, *firsts[1], untouched),
        }
    finally:
        for _, proc in started:  # the other demo, when one failed
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        _chmod_all(read_only.package, add=0o200)


def _all_under(paths: list[Path], directory: Path) -> bool:
    return bool(paths) and all(p.is_relative_to(directory) for p in paths)


def test_installed_wheel_runs_the_demo_and_caches_its_kernels_in_the_package(installs):
    """From a writable installation the first demo compiles and saves the machine code
    in the installed package's ``__pycache__`` directories (nothing in the user's cache);
    a second process loads it from there, compiles nothing, and gets the same map."""
    installed, first, summary = installs["writable"]
    package = installed.package
    assert _all_under(first["saved to"], package), first["saved to"][:3]
    assert {p.parent.name for p in first["saved to"]} == {"__pycache__"}
    assert not installed.user_cache.exists()
    # the stamp of drop_stale_cache: the next import keeps these files
    assert (package / "_core" / "__pycache__" / "kernel-sources.sha256").is_file()

    second, summary_again = installed.demo("second")
    assert not second["saved to"], second["saved to"][:3]
    assert _all_under(second["loaded from"], package), second["loaded from"][:3]
    assert summary_again == summary


def test_read_only_installation_caches_its_kernels_per_user(installs):
    """From a read-only installation (a system-wide site-packages) the demo still runs:
    the first process compiles and saves the machine code in the user's cache directory
    and writes nothing into the installed package (``drop_stale_cache`` keeps its stamp
    in the user's cache too); a second process loads the kernels from the user's cache,
    compiling nothing."""
    installed, first, summary, untouched = installs["read-only"]
    assert _all_under(first["saved to"], installed.user_cache), first["saved to"][:3]
    # the stamp of drop_stale_cache, which drops these files after an upgrade in place
    assert list(installed.user_cache.glob("_core_*/kernel-sources.sha256"))

    second, summary_again = installed.demo("second")
    assert not second["saved to"], second["saved to"][:3]
    assert _all_under(second["loaded from"], installed.user_cache), second["loaded from"][
        :3
    ]
    assert summary_again == summary
    assert _snapshot(installed.package) == untouched
