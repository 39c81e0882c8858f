"""The explorer's HTTP server: one static page and a small JSON API, on the standard
library's threading HTTP server.

Routes: ``GET /`` (the page), ``GET /static/<file>``, ``GET /api/config`` (caps,
defaults, the choices of the controls), ``POST /api/run`` (settings → the run),
``POST /api/map`` (settings and map axes → starts the session's map), ``GET
/api/map?session=S`` (the map so far), ``POST /api/toml`` (the map's sweep TOML),
``GET /api/run.nc?session=S`` (the session's last run as netCDF).

Refused settings answer 400 with ``{"error": <the library's message>, "control": <name>}``,
requests over a cap 413 with the message naming the cap, superseded work 409.
"""

from __future__ import annotations

import gzip
import json
import os
import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlparse

from .._version import __version__
from ..io import write_netcdf
from .caps import CapExceeded, Caps
from .maps import MapJob
from .measured import FIT_CONTROLS, fit_controls, load, overlay
from .runs import payload, run, to_json
from .scheduler import Scheduler, Superseded
from .settings import (
    LABELS,
    UNITS,
    SettingError,
    defaults,
    map_axes,
    map_sweep,
    preset_bodies,
    run_spec,
)

__all__ = ["Explorer", "LOCAL_HOSTS", "Server", "start"]

STATIC = Path(__file__).with_name("static")
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".txt": "text/plain; charset=utf-8",
}
_MAX_BODY = 1 << 20  # bytes of a request body
_MAX_SESSIONS = 256  # sessions remembered (their last run and map); the oldest go first
_CACHED_RUNS = 64  # runs kept for the next request of the same settings (~0.4 MB each)


class Busy(RuntimeError):
    """The server is doing this kind of work for someone else; try again later."""


@dataclass
class Session:
    run: Any = None  # the last run's Dataset
    map: MapJob | None = None
    measurement: Any = None  # a loaded fitting.Measurement
    seen: float = field(default_factory=time.monotonic)


class Explorer:
    """The application behind the server: caps, the scheduler and the sessions."""

    def __init__(self, caps: Caps | None = None, workers: int | None = None) -> None:
        self.caps = caps or Caps()
        self.scheduler = Scheduler(workers or max(1, len(os.sched_getaffinity(0))))
        self._sessions: OrderedDict[str, Session] = OrderedDict()
        self._lock = threading.Lock()
        # a fit holds a worker for seconds: one at a time, so the others stay free
        self._fitting = threading.Lock()
        # a class moving sliders in steps asks for the same launches again and again
        self._runs: OrderedDict[str, tuple[Any, str]] = OrderedDict()
        self.cache_hits = 0

    def session(self, key: str) -> Session:
        with self._lock:
            s = self._sessions.pop(key, None) or Session()
            s.seen = time.monotonic()
            self._sessions[key] = s
            while len(self._sessions) > _MAX_SESSIONS:
                old, gone = self._sessions.popitem(last=False)
                self.scheduler.cancel(old, "map")
            return s

    def config(self) -> dict[str, Any]:
        return {
            "caps": self.caps.to_dict(),
            "defaults": defaults(),
            "presets": preset_bodies(),
            "labels": LABELS,
            "units": UNITS,
            "map_axes": map_axes(),
            "version": __version__,
        }

    def run(self, key: str, settings: dict[str, Any]) -> dict[str, Any]:
        """Check and run the settings for session ``key`` (waits for the scheduler)."""
        spec = run_spec(settings, self.caps)
        session = self.session(key)
        same = json.dumps([spec.body_args, spec.kwargs], default=float)
        with self._lock:
            hit = self._runs.get(same)
            if hit is not None:
                self._runs.move_to_end(same)
                self.cache_hits += 1
        if hit is not None:
            self.scheduler.cancel(key, "run")  # the cached answer supersedes stale work
            session.run = hit[0]
            return {"_json": hit[1]}

        def step() -> tuple[bool, Any]:
            ds, messages = run(spec, self.caps)
            return True, (ds, to_json(payload(spec, ds, messages)))

        job = self.scheduler.submit(key, "run", step)
        ds, text = job.future.result()
        session.run = ds
        with self._lock:
            self._runs[same] = (ds, text)
            while len(self._runs) > _CACHED_RUNS:
                self._runs.popitem(last=False)
        assert job.started is not None and job.finished is not None
        return {
            "_json": text,
            "_timing": (job.started - job.queued, job.finished - job.started),
        }

    def start_map(
        self, key: str, settings: dict[str, Any], axes: dict[str, Any]
    ) -> dict[str, Any]:
        sweep = map_sweep(settings, axes, self.caps)
        job = MapJob(sweep)
        session = self.session(key)
        session.map = job
        self.scheduler.submit(key, "map", job.step)
        return job.snapshot()

    def load_measurement(self, key: str, name: Any, text: Any) -> dict[str, Any]:
        """Read a measurement file's text into session ``key``; return what the page
        draws over the spin plot."""
        m = load(str(name or ""), text, self.caps)
        self.session(key).measurement = m
        shown = overlay(m)
        return {
            **shown,
            "name": m.source,
            "samples": len(m.time),
            "duration": m.duration,
            "free": list(FIT_CONTROLS),
        }

    def fit(self, key: str, settings: dict[str, Any], free: Any) -> dict[str, Any]:
        """Fit the controls ``free`` of these settings to the session's measurement, on
        one worker; one fit runs at a time."""
        spec = run_spec(settings, self.caps)
        m = self.session(key).measurement
        if m is None:
            raise SettingError("fit: load a measurement first", "measurement")
        if not isinstance(free, list) or not all(isinstance(n, str) for n in free):
            raise SettingError("fit: free must be a list of control names", "measurement")
        if not self._fitting.acquire(blocking=False):
            raise Busy("another fit is running on this server; try again when it ends")
        try:
            job = self.scheduler.submit(
                key, "fit", lambda: (True, fit_controls(spec, m, free, settings))
            )
            return job.future.result()
        finally:
            self._fitting.release()

    def map_state(self, key: str) -> dict[str, Any] | None:
        job = self.session(key).map
        return None if job is None else job.snapshot()

    def netcdf(self, key: str) -> bytes | None:
        ds = self.session(key).run
        if ds is None:
            return None
        with tempfile.TemporaryDirectory() as tmp:
            path = write_netcdf(ds, Path(tmp) / "run.nc")
            return path.read_bytes()

    def close(self) -> None:
        self.scheduler.close()


class _Handler(BaseHTTPRequestHandler):
    server: "Server"
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:
        if self.server.verbose:
            super().log_message(format, *args)

    # --- responses -------------------------------------------------------------------
    def _send(
        self, status: int, body: bytes, ctype: str, extra: dict[str, str] | None = None
    ) -> None:
        if len(body) > 1024 and "gzip" in self.headers.get("Accept-Encoding", ""):
            body = gzip.compress(body, compresslevel=1)
            extra = {**(extra or {}), "Content-Encoding": "gzip"}
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        for k, v in (extra or {}).items():
            self.send_header(k, v)
        self.end_headers()
        self.wfile.write(body)

    def _json(self, status: int, obj: Any) -> None:
        text = obj["_json"] if isinstance(obj, dict) and "_json" in obj else to_json(obj)
        extra = {}
        if isinstance(obj, dict) and "_timing" in obj:  # seconds waiting and computing
            wait, compute = obj["_timing"]
            extra["Server-Timing"] = (
                f"queue;dur={1000 * wait:.1f}, compute;dur={1000 * compute:.1f}"
            )
        self._send(status, text.encode(), "application/json", extra)

    def _error(self, exc: Exception) -> None:
        if isinstance(exc, CapExceeded):
            self._json(
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                {"error": str(exc), "cap": True, "control": exc.control},
            )
        elif isinstance(exc, SettingError):
            self._json(HTTPStatus.BAD_REQUEST, {"error": str(exc), "control": exc.control})
        elif isinstance(exc, Busy):
            self._json(HTTPStatus.SERVICE_UNAVAILABLE, {"error": str(exc), "busy": True})
        elif isinstance(exc, Superseded):
            self._json(HTTPStatus.CONFLICT, {"superseded": True, "error": str(exc)})
        elif isinstance(exc, ValueError):
            self._json(HTTPStatus.BAD_REQUEST, {"error": str(exc), "control": None})
        else:
            self._json(
                HTTPStatus.INTERNAL_SERVER_ERROR, {"error": f"{type(exc).__name__}: {exc}"}
            )

    def _foreign_host(self) -> bool:
        """On a loopback address, refuse requests naming another host: a web page
        elsewhere could otherwise reach the server through a name that resolves to
        127.0.0.1 (DNS rebinding)."""
        if not self.server.loopback:
            return False
        host = self.headers.get("Host", "")
        name = (
            host.rsplit(":", 1)[0] if not host.startswith("[") else host[1:].split("]")[0]
        )
        if name in LOCAL_HOSTS:
            return False
        self._json(HTTPStatus.FORBIDDEN, {"error": f"host {host!r} is not this machine"})
        return True

    # --- routes ----------------------------------------------------------------------
    def do_GET(self) -> None:
        if self._foreign_host():
            return
        url = urlparse(self.path)
        query = {k: v[0] for k, v in parse_qs(url.query).items()}
        app = self.server.app
        if url.path in ("/", "/index.html"):
            return self._static("index.html")
        if url.path.startswith("/static/"):
            return self._static(url.path[len("/static/") :])
        if url.path == "/api/config":
            return self._json(HTTPStatus.OK, app.config())
        if url.path == "/api/map":
            state = app.map_state(query.get("session", ""))
            if state is None:
                return self._json(HTTPStatus.NOT_FOUND, {"error": "no map in this session"})
            return self._json(HTTPStatus.OK, state)
        if url.path == "/api/run.nc":
            data = app.netcdf(query.get("session", ""))
            if data is None:
                return self._json(HTTPStatus.NOT_FOUND, {"error": "no run in this session"})
            return self._send(
                HTTPStatus.OK,
                data,
                "application/x-netcdf",
                {"Content-Disposition": 'attachment; filename="run.nc"'},
            )
        self._json(HTTPStatus.NOT_FOUND, {"error": f"no such page: {url.path}"})

    def do_POST(self) -> None:
        if self._foreign_host():
            return
        url = urlparse(self.path)
        # the length is checked before a byte of the body is read: a length that is not
        # a plain number, or one over the cap, is refused and the connection closed
        # (where its body ends is then unknown)
        given = self.headers.get("Content-Length", "0").strip() or "0"
        if not given.isdecimal() or len(given) > 12:
            self.close_connection = True
            return self._json(
                HTTPStatus.BAD_REQUEST,
                {"error": f"bad request: Content-Length {given[:20]!r} is not a length"},
            )
        length = int(given)
        if length > _MAX_BODY:
            self.close_connection = True
            return self._json(
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                {"error": f"request body over {_MAX_BODY} bytes"},
            )
        try:
            body = json.loads(self.rfile.read(length) or b"{}")
            if not isinstance(body, dict):
                raise ValueError("the request must be a JSON object")
            for part in ("settings", "map"):
                if body.get(part) is not None and not isinstance(body[part], dict):
                    raise ValueError(f"{part} must be a JSON object")
        except (ValueError, RecursionError) as exc:  # RecursionError: JSON nested deep
            reason = "nested too deep" if isinstance(exc, RecursionError) else exc
            return self._json(HTTPStatus.BAD_REQUEST, {"error": f"bad request: {reason}"})
        app = self.server.app
        key = str(body.get("session", ""))
        settings = body.get("settings") or {}
        try:
            if url.path == "/api/run":
                return self._json(HTTPStatus.OK, app.run(key, settings))
            if url.path == "/api/map":
                return self._json(
                    HTTPStatus.OK, app.start_map(key, settings, body.get("map") or {})
                )
            if url.path == "/api/measurement":
                return self._json(
                    HTTPStatus.OK,
                    app.load_measurement(key, body.get("name"), body.get("text")),
                )
            if url.path == "/api/fit":
                return self._json(HTTPStatus.OK, app.fit(key, settings, body.get("free")))
            if url.path == "/api/toml":
                text = map_sweep(settings, body.get("map") or {}, app.caps).to_toml()
                return self._send(
                    HTTPStatus.OK,
                    text.encode(),
                    "application/toml",
                    {"Content-Disposition": 'attachment; filename="map.toml"'},
                )
        except Exception as exc:  # every failure becomes an answer, never a dead request
            return self._error(exc)
        self._json(HTTPStatus.NOT_FOUND, {"error": f"no such endpoint: {url.path}"})

    def _static(self, name: str) -> None:
        data = self.server.static.get(name)
        if data is None:
            return self._json(HTTPStatus.NOT_FOUND, {"error": f"no such file: {name}"})
        ctype = _TYPES.get(Path(name).suffix, "application/octet-stream")
        self._send(HTTPStatus.OK, data, ctype)


def _static_files() -> dict[str, bytes]:
    return {
        str(p.relative_to(STATIC)): p.read_bytes() for p in STATIC.rglob("*") if p.is_file()
    }


class Server(ThreadingHTTPServer):
    """The explorer's HTTP server; ``url`` is where it listens."""

    daemon_threads = True
    # a classroom connects at once: socketserver's default backlog of 5 resets the rest
    request_queue_size = 128

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        caps: Caps | None = None,
        workers: int | None = None,
        verbose: bool = False,
    ) -> None:
        super().__init__((host, port), _Handler)
        self.app = Explorer(caps, workers)
        self.static = _static_files()
        self.verbose = verbose
        self.loopback = host in LOCAL_HOSTS
        shown = f"[{host}]" if ":" in host else host
        self.url = f"http://{shown}:{self.server_address[1]}/"

    def server_close(self) -> None:
        app = getattr(self, "app", None)  # absent when binding the port failed
        if app is not None:
            app.close()
        super().server_close()


def start(host: str = "127.0.0.1", port: int = 0, **kwargs: Any) -> Server:
    """Start the explorer's server on a background thread and return it.

    Parameters
    ----------
    host : str
        Address to listen on (default 127.0.0.1: this machine only).
    port : int
        Port (0: any free one).
    **kwargs
        ``caps``, ``workers`` and ``verbose`` (log each request) of :class:`Server`.

    Returns
    -------
    Server
        The running server: its address is ``server.url``; stop it with
        ``server.shutdown(); server.server_close()``.
    """
    server = Server(host, port, **kwargs)
    threading.Thread(
        target=server.serve_forever, name="explore-server", daemon=True
    ).start()
    return server
