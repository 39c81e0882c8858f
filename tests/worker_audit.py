"""A dask worker preload (``preload=[this file]``) for the cluster tests: it moves the
worker into a working directory of its own and records, through a Python audit hook,
every path the worker process opens, creates, renames, removes or lists."""

import os
import sys
import tempfile

_EVENTS = {
    "open",
    "os.mkdir",
    "os.rename",
    "os.remove",
    "os.rmdir",
    "os.link",
    "os.symlink",
    "os.truncate",
    "os.chmod",
    "os.utime",
    "os.listdir",
    "os.scandir",
    "shutil.copyfile",
    "shutil.rmtree",
    "shutil.move",
}
_touched: list[str] = []


def _hook(event, args):
    if event not in _EVENTS or not args:
        return
    for arg in args[:2] if event in ("os.rename", "os.link", "os.symlink") else args[:1]:
        if isinstance(arg, (str, bytes, os.PathLike)):
            try:
                _touched.append(os.path.abspath(os.fsdecode(arg)))
            except Exception:
                pass


def dask_setup(worker):
    os.chdir(tempfile.mkdtemp(prefix="worker-cwd-", dir=worker.local_directory))
    sys.addaudithook(_hook)


def touched() -> list[str]:
    """Every path recorded so far in this worker process."""
    return list(_touched)


def working_directory() -> str:
    return os.getcwd()
