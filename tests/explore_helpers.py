"""What the explorer's server tests (test_explore_server.py, test_explore_fit.py,
test_explore_sessions.py) share: a server for a module, browsers that keep the
session token the server sets in a cookie, and requests through them."""

import json
import urllib.error
import urllib.request

from rattlesweep.explore import start, warm


def serving():
    """A server with one worker, its kernels warm, for a module's ``server`` fixture
    (``yield from serving()``); shut down after."""
    warm()
    srv = start(workers=1)
    yield srv
    srv.shutdown()
    srv.server_close()


def browser():
    """A browser of its own: a cookie jar for the server's session token."""
    return urllib.request.build_opener(urllib.request.HTTPCookieProcessor())


def opener(srv):
    """The test module's browser for ``srv``."""
    if not hasattr(srv, "test_opener"):
        srv.test_opener = browser()
    return srv.test_opener


def exchange(srv, by, path, body=None):
    """(status, body, headers) of a request to ``path`` through browser ``by``: a GET,
    or a POST of ``body`` as JSON."""
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(
        srv.url + path, data=data, headers={"Content-Type": "application/json"}
    )
    try:
        with by.open(req, timeout=60) as r:
            return r.status, r.read(), r.headers
    except urllib.error.HTTPError as e:
        return e.code, e.read(), e.headers


def call(srv, path, body=None, session="s", by=None):
    """(status, body) of a request for page tab ``session`` (the module's browser
    unless ``by``)."""
    sent = None if body is None else {"session": session, **body}
    status, answer, _ = exchange(srv, by or opener(srv), path, sent)
    return status, answer
