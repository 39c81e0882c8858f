"""``rattlesweep explore``: the rattleback live in the browser.

A local web page (served by :class:`~rattlesweep.explore.server.Server`, standard library
only; the 3-D view uses a copy of three.js shipped with the package) with controls for
the body, the launch and friction, a 3-D view and linked plots of the run, and a
reversal map whose points load their launch. :func:`show` puts the same page in a
notebook.
"""

from __future__ import annotations

import errno
import math
import sys
import time
import webbrowser
from typing import Any

from .caps import Caps
from .server import LOCAL_HOSTS, Server, is_loopback, start

__all__ = ["Caps", "LOCAL_HOSTS", "PortInUse", "Server", "serve", "show", "start", "warm"]


class PortInUse(OSError):
    """The port asked for is taken; the message says what to do."""


def _bind(host: str, port: int, **kwargs: Any) -> Server:
    """A :class:`Server` on ``host:port``; :class:`PortInUse` when the port is taken."""
    try:
        return Server(host, port, **kwargs)
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise PortInUse(
                errno.EADDRINUSE,
                f"port {port} is in use: choose another with "
                "--port, or --port 0 for any free port",
            ) from None
        raise


_NOTEBOOK_SERVER: Server | None = None


def warm() -> float:
    """Compile (or load from numba's cache) the kernels the page uses; seconds taken."""
    from ..rattleback.body import Body
    from ..rattleback.simulate import simulate
    from ..sweep import Sweep
    from ..sweep._execution.tiles import compute_points
    import numpy as np

    t0 = time.perf_counter()
    simulate(Body.preset("toy"), spin=-5.0, roll=0.01, mu=0.3, t_end=0.01)
    sweep = Sweep(axes={"spin": [-5.0, 5.0]}, fixed={"t_end": 0.01}, stop="first_reversal")
    compute_points(sweep, np.arange(2, dtype=np.int64))
    return time.perf_counter() - t0


def serve(
    host: str = "127.0.0.1",
    port: int = 8050,
    *,
    open_browser: bool = True,
    caps: Caps | None = None,
    workers: int | None = None,
) -> None:
    """Warm the kernels, start the server, print its address, open the browser and serve
    until interrupted (Ctrl-C); what ``rattlesweep explore`` runs.

    Parameters
    ----------
    host : str
        Address to listen on. The default, 127.0.0.1, serves this machine only; any
        other prints that anyone who can reach it can use the explorer.
    port : int
        Port (0: any free one).
    open_browser : bool
        Open the page in the default browser.
    caps : Caps, optional
        Limits on the work of one request (default: :class:`Caps`).
    workers : int, optional
        Worker threads running the simulations (default: one per usable core).

    Raises
    ------
    PortInUse
        The port is taken (checked before the kernels are warmed).
    """
    server = _bind(host, port, caps=caps, workers=workers)
    print(
        "rattlesweep explore: warming the kernels (a first run after installing "
        "compiles them, which takes minutes unless `rattlesweep compile` did it "
        "ahead; later starts take seconds)...",
        flush=True,
    )
    try:
        print(f"kernels ready ({warm():.1f} s)", flush=True)
    except BaseException:
        server.server_close()
        raise
    if not is_loopback(host):
        print(
            f"warning: listening on {host}: anyone who can reach this address can use "
            "the explorer (and the CPU time it spends)",
            flush=True,
        )
    print(f"rattlesweep explore: serving at {server.url} (Ctrl-C to stop)", flush=True)
    if open_browser:
        webbrowser.open(server.url)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("stopped", flush=True)
    finally:
        server.server_close()


class _Frame:
    """The page in a notebook: an iframe of a running server."""

    def __init__(self, url: str, height: int) -> None:
        self.url, self.height = url, height

    def _repr_html_(self) -> str:
        return (
            f'<iframe src="{self.url}" width="100%" height="{self.height}" '
            'style="border:0"></iframe>'
        )

    def __repr__(self) -> str:
        return f"rattlesweep explorer at {self.url}"


def show(height: int = 900, *, port: int = 0, caps: Caps | None = None) -> Any:
    """Show the explorer inline in a notebook.

    Starts a server on 127.0.0.1 on a background thread (once per kernel) and returns an
    object that the notebook displays as the page in an iframe. Outside IPython (a plain
    script) nothing would display it, so it also prints the address and how to keep the
    page up: the server lives on a background thread that ends with the script; from a
    shell use ``rattlesweep explore``, or call :func:`serve` to block.

    Parameters
    ----------
    height : int
        Height of the frame (pixels).
    port : int
        Port of the server (0: any free one); used when the server starts.
    caps : Caps, optional
        Limits on the work of one request; used when the server starts.
    """
    global _NOTEBOOK_SERVER
    if _NOTEBOOK_SERVER is None:
        warm()
        _NOTEBOOK_SERVER = start("127.0.0.1", port, caps=caps)
    if not _in_ipython():
        print(
            f"rattlesweep explore: serving at {_NOTEBOOK_SERVER.url} while this Python "
            "runs (outside a notebook nothing shows the page inline: use `rattlesweep "
            "explore` from a shell, or call explore.serve() to block)",
            flush=True,
        )
    return _Frame(_NOTEBOOK_SERVER.url, int(height) if math.isfinite(height) else 900)


def _in_ipython() -> bool:
    """Whether an IPython shell (a notebook's kernel included) is running."""
    ipython = sys.modules.get("IPython")
    return (
        ipython is not None and getattr(ipython, "get_ipython", lambda: None)() is not None
    )
