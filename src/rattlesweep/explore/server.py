"""The explorer's HTTP server: one static page and a small JSON API, on the standard
library's threading HTTP server.

Routes: ``GET /`` (the page), ``GET /static/<file>``, ``GET /api/config`` (caps,
defaults, the choices of the controls), ``POST /api/run`` (settings → the run),
``POST /api/map`` (settings and map axes → starts the session's map), ``GET
/api/map?session=S`` (the map so far), ``POST /api/toml`` (the map's sweep TOML),
``GET /api/run.nc?session=S`` (the session's last run as netCDF), ``POST
/api/measurement`` and ``POST /api/fit`` (a measured rattleback, :mod:`.measured`).

Sessions belong to a browser: the server issues each browser an unguessable token in
an HttpOnly, SameSite=Strict cookie (signed, so the server keeps no list of them), and
a session is the pair (token, the page's tab id ``S``). A request without the token
gets a new one, so it can neither read nor replace another browser's sessions. Only
work creates a session (a run, a map, a measurement, a fit); reads of one that does not
exist answer 404. Each browser holds at most :data:`_PER_BROWSER` sessions (its oldest
goes first); when the table is full, the client address holding the most sessions
loses its oldest, so a client flooding the server, with new tokens or not, evicts its
own sessions before anyone else's.

Refused settings answer 400 with ``{"error": <the library's message>, "control": <name>}``,
requests over a cap 413 with the message naming the cap, superseded work 409.
"""

from __future__ import annotations

import base64
import gzip
import hashlib
import hmac
import ipaddress
import json
import os
import re
import secrets
import tempfile
import threading
import time
from collections import Counter, OrderedDict
from dataclasses import dataclass, field
from http import HTTPStatus
from http.cookies import CookieError, SimpleCookie
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlparse

from .._version import __version__
from ..io import write_netcdf
from .caps import CapExceeded, Caps
from .maps import MapJob
from .measured import FIT_CONTROLS, SENSOR_YAW, fit_controls, load, overlay
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

__all__ = ["Explorer", "LOCAL_HOSTS", "Server", "is_loopback", "start"]

STATIC = Path(__file__).with_name("static")
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")
_REQUEST_TIMEOUT = 30.0  # s a connection may take to send a request's next bytes


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address) is this machine only: ``localhost`` or
    a loopback address (all of 127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".txt": "text/plain; charset=utf-8",
}
_MAX_BODY = 1 << 20  # bytes of a request body
_MAX_SESSIONS = 256  # sessions remembered (their last run and map)
_PER_BROWSER = 8  # sessions (page tabs) one browser's token holds
_COOKIE = "rattlesweep_session"
_TAB = re.compile(r"[A-Za-z0-9_-]{0,64}")  # a page's tab id
_CACHED_RUNS = 64  # runs kept for the next request of the same settings (~0.4 MB each)


class Busy(RuntimeError):
    """The server is doing this kind of work for someone else; try again later."""


@dataclass
class Session:
    client: str = ""  # the address that made it
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
        self._secret = secrets.token_bytes(32)

    # --- browsers and their sessions ---------------------------------------------------
    def _sign(self, nonce: str) -> str:
        mac = hmac.new(self._secret, nonce.encode(), hashlib.sha256).digest()
        return base64.urlsafe_b64encode(mac[:18]).decode()

    def new_token(self) -> str:
        """A browser's token: a random nonce and its signature."""
        nonce = secrets.token_urlsafe(18)
        return f"{nonce}.{self._sign(nonce)}"

    def valid_token(self, token: str) -> bool:
        if not token.isascii():  # compare_digest takes ASCII text only
            return False
        nonce, _, mac = token.partition(".")
        return bool(nonce) and hmac.compare_digest(mac, self._sign(nonce))

    def session(self, key: str, client: str = "") -> Session:
        """Session ``key`` (``token/tab``), made for ``client`` (an address) if there
        is none."""
        with self._lock:
            s = self._sessions.pop(key, None)
            if s is None:
                s = Session(client=client)
                self._make_room(key.partition("/")[0])
            s.seen = time.monotonic()
            self._sessions[key] = s
            return s

    def find(self, key: str) -> Session | None:
        """Session ``key`` if it exists; a read never makes one."""
        with self._lock:
            return self._sessions.get(key)

    def _make_room(self, token: str) -> None:
        """Evict for one more session of the browser ``token``: its own oldest at its
        cap, else, with the table full, the oldest of the address holding the most."""
        mine = [k for k in self._sessions if k.partition("/")[0] == token]
        if len(mine) >= _PER_BROWSER:
            self._evict(mine[0])
        elif len(self._sessions) >= _MAX_SESSIONS:
            counts = Counter(s.client for s in self._sessions.values())
            largest = counts.most_common(1)[0][0]
            self._evict(next(k for k, s in self._sessions.items() if s.client == largest))

    def _evict(self, key: str) -> None:
        self._sessions.pop(key)
        for kind in ("map", "run", "fit"):
            self.scheduler.cancel(key, kind)

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

    def run(self, key: str, settings: dict[str, Any], client: str = "") -> dict[str, Any]:
        """Check and run the settings for session ``key`` (waits for the scheduler)."""
        spec = run_spec(settings, self.caps)
        session = self.session(key, client)
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
        self, key: str, settings: dict[str, Any], axes: dict[str, Any], client: str = ""
    ) -> dict[str, Any]:
        sweep = map_sweep(settings, axes, self.caps)
        job = MapJob(sweep)
        session = self.session(key, client)
        session.map = job
        self.scheduler.submit(key, "map", job.step)
        return job.snapshot()

    def load_measurement(
        self, key: str, name: Any, text: Any, client: str = ""
    ) -> dict[str, Any]:
        """Read a measurement file's text into session ``key``; return what the page
        draws over the spin plot."""
        m = load(str(name or ""), text, self.caps)
        self.session(key, client).measurement = m
        shown = overlay(m)
        return {
            **shown,
            "name": m.source,
            "samples": len(m.time),
            "duration": m.duration,
            "free": list(FIT_CONTROLS) + ([SENSOR_YAW] if m.kind == "gyro" else []),
        }

    def fit(
        self, key: str, settings: dict[str, Any], free: Any, client: str = ""
    ) -> dict[str, Any]:
        """Fit the controls ``free`` of these settings to the session's measurement, on
        one worker; one fit runs at a time."""
        spec = run_spec(settings, self.caps)
        found = self.find(key)
        m = None if found is None else found.measurement
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
        found = self.find(key)
        job = None if found is None else found.map
        return None if job is None else job.snapshot()

    def netcdf(self, key: str) -> bytes | None:
        found = self.find(key)
        ds = None if found is None else found.run
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
    # a connection that stops sending (a request half sent, a client gone) releases its
    # thread after this long, rather than holding it for ever
    timeout = _REQUEST_TIMEOUT

    def log_message(self, format: str, *args: Any) -> None:
        if self.server.verbose:
            super().log_message(format, *args)

    # --- the browser's token ------------------------------------------------------------
    def _begin(self) -> None:
        self._issued: str | None = None  # a token issued in this request's answer

    def _token(self) -> str:
        """This browser's token from its cookie, or a new one the answer sets."""
        if self._issued is not None:
            return self._issued
        cookie: SimpleCookie = SimpleCookie()
        try:
            cookie.load(self.headers.get("Cookie", ""))
        except CookieError:
            pass
        morsel = cookie.get(_COOKIE)
        if morsel is not None and self.server.app.valid_token(morsel.value):
            return morsel.value
        self._issued = self.server.app.new_token()
        return self._issued

    def _session_key(self, tab: Any) -> str:
        """The session of this browser's page tab ``tab``."""
        tab = "" if tab is None else str(tab)
        if not _TAB.fullmatch(tab):
            raise ValueError(
                f"session must be at most 64 letters, digits, '-' or '_', got {tab[:20]!r}"
            )
        return f"{self._token()}/{tab}"

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
        if getattr(self, "_issued", None):
            self.send_header(
                "Set-Cookie",
                f"{_COOKIE}={self._issued}; Path=/; HttpOnly; SameSite=Strict",
            )
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
        # an address is no DNS name to rebind: any loopback literal is this machine
        if is_loopback(name):
            return False
        self._json(HTTPStatus.FORBIDDEN, {"error": f"host {host!r} is not this machine"})
        return True

    # --- routes ----------------------------------------------------------------------
    def do_GET(self) -> None:
        self._begin()
        if self._foreign_host():
            return
        url = urlparse(self.path)
        query = {k: v[0] for k, v in parse_qs(url.query).items()}
        app = self.server.app
        if url.path in ("/", "/index.html"):
            self._token()  # the page's requests carry it from here on
            return self._static("index.html")
        if url.path in ("/api/map", "/api/run.nc"):
            try:
                key = self._session_key(query.get("session"))
            except ValueError as exc:
                return self._json(HTTPStatus.BAD_REQUEST, {"error": str(exc)})
        if url.path.startswith("/static/"):
            return self._static(url.path[len("/static/") :])
        if url.path == "/api/config":
            return self._json(HTTPStatus.OK, app.config())
        if url.path == "/api/map":
            state = app.map_state(key)
            if state is None:
                return self._json(HTTPStatus.NOT_FOUND, {"error": "no map in this session"})
            return self._json(HTTPStatus.OK, state)
        if url.path == "/api/run.nc":
            data = app.netcdf(key)
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
        self._begin()
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
        settings = body.get("settings") or {}
        client = self.client_address[0]
        try:
            key = self._session_key(body.get("session"))
            if url.path == "/api/run":
                return self._json(HTTPStatus.OK, app.run(key, settings, client))
            if url.path == "/api/map":
                axes = body.get("map") or {}
                return self._json(HTTPStatus.OK, app.start_map(key, settings, axes, client))
            if url.path == "/api/measurement":
                name, text = body.get("name"), body.get("text")
                return self._json(
                    HTTPStatus.OK, app.load_measurement(key, name, text, client)
                )
            if url.path == "/api/fit":
                free = body.get("free")
                return self._json(HTTPStatus.OK, app.fit(key, settings, free, client))
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
        self.loopback = is_loopback(host)
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
