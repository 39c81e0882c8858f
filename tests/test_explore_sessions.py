"""Sessions of the explorer's server on a shared network, tested with real sockets: a
session belongs to the browser the server gave its token to, reads never make one,
and a client flooding the server evicts its own sessions, not another's."""

import http.client
import json
import threading

import pytest

from rattlesweep.explore import server as server_module
from rattlesweep.explore import start
from rattlesweep.explore.settings import defaults

from explore_helpers import browser, exchange, serving


@pytest.fixture(scope="module")
def server():
    yield from serving()


def quick_run(srv, by, tab, spin=-3.0):
    settings = {**defaults(), "spin": spin, "t_end": 0.05}
    return exchange(srv, by, "api/run", {"session": tab, "settings": settings})


def test_a_browser_gets_a_signed_token_and_another_browser_cannot_read_its_session(
    server,
):
    victim, other = browser(), browser()
    status, _, headers = exchange(server, victim, "")
    cookie = headers["Set-Cookie"]
    assert status == 200 and "HttpOnly" in cookie and "SameSite=Strict" in cookie
    assert quick_run(server, victim, "lesson")[0] == 200
    assert exchange(server, victim, "api/run.nc?session=lesson")[0] == 200
    # the tab id is known to the other browser (chosen, guessed or seen): not enough
    for path in ("api/run.nc?session=lesson", "api/map?session=lesson"):
        assert exchange(server, other, path)[0] == 404
    # a forged token is not taken: its request gets a token of its own
    nonce = cookie.split("=", 1)[1].split(";")[0].split(".")[0]
    forged = http.client.HTTPConnection("127.0.0.1", server.server_address[1], timeout=30)
    forged.request(
        "GET",
        "/api/run.nc?session=lesson",
        headers={"Cookie": f"rattlesweep_session={nonce}.AAAAAAAAAAAAAAAAAAAAAAAA"},
    )
    answer = forged.getresponse()
    assert answer.status == 404 and "rattlesweep_session=" in answer.headers["Set-Cookie"]
    forged.close()


def test_reads_never_make_a_session(server):
    before = len(server.app._sessions)
    prankster = browser()
    for i in range(300):
        status, _, _ = exchange(server, prankster, f"api/map?session=x{i}")
        assert status == 404
    assert len(server.app._sessions) == before


def test_a_browser_keeps_at_most_its_cap_of_sessions(server):
    tabs = browser()
    cap = server_module._PER_BROWSER
    for i in range(cap + 2):
        assert quick_run(server, tabs, f"tab{i}")[0] == 200
    kept = [
        i
        for i in range(cap + 2)
        if exchange(server, tabs, f"api/run.nc?session=tab{i}")[0] == 200
    ]
    assert kept == list(range(2, cap + 2))  # its own two oldest went


def test_a_flood_from_another_address_evicts_its_own_sessions_only(server, monkeypatch):
    """The table shrunk to 12 sessions: a client at 127.0.0.2 making 40 sessions with
    a new token each (no cookies kept) leaves the teacher's sessions at 127.0.0.1."""
    monkeypatch.setattr(server_module, "_MAX_SESSIONS", 12)
    teacher = browser()
    for tab in ("one", "two"):
        assert quick_run(server, teacher, tab)[0] == 200
    port = server.server_address[1]
    body = json.dumps({"session": "p", "settings": {**defaults(), "t_end": 0.05}})
    for _ in range(40):
        conn = http.client.HTTPConnection(
            "127.0.0.1", port, timeout=30, source_address=("127.0.0.2", 0)
        )
        conn.request("POST", "/api/run", body, {"Content-Type": "application/json"})
        assert conn.getresponse().status == 200
        conn.close()
    assert len(server.app._sessions) <= 12
    for tab in ("one", "two"):
        assert exchange(server, teacher, f"api/run.nc?session={tab}")[0] == 200
    clients = [s.client for s in server.app._sessions.values()]
    assert clients.count("127.0.0.2") >= 12 - clients.count("127.0.0.1") - 1


def test_a_session_id_that_is_not_a_plain_name_is_refused(server):
    status, body, _ = quick_run(server, browser(), "../../etc" + "x" * 80)
    assert (
        status == 400 and "session must be at most 64 letters" in json.loads(body)["error"]
    )


def test_a_classroom_connecting_at_once_is_answered(server):
    statuses = []

    def one(i):  # each pupil a browser of its own
        settings = {**defaults(), "spin": i - 15.0, "t_end": 0.5}
        answer = exchange(
            server, browser(), "api/run", {"session": f"p{i}", "settings": settings}
        )
        statuses.append(answer[0])

    threads = [threading.Thread(target=one, args=(i,)) for i in range(30)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert statuses == [200] * 30


def test_a_half_sent_request_releases_its_thread(monkeypatch):
    """A client that sends headers and part of a body, then nothing: its connection is
    closed after the handler's timeout (1 s here) instead of holding a thread."""
    import socket
    import time

    monkeypatch.setattr(server_module._Handler, "timeout", 1.0)
    srv = start(workers=1)
    try:
        port = srv.server_address[1]
        with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
            sock.sendall(
                b"POST /api/run HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 100\r\n\r\n{"
            )
            began = time.monotonic()
            assert sock.recv(1024) == b""  # closed, no answer to a request never finished
            assert time.monotonic() - began < 5
    finally:
        srv.shutdown()
        srv.server_close()


def test_any_loopback_address_keeps_the_dns_rebinding_guard():
    """Served on 127.0.0.2, a request naming another host is refused, one naming the
    address answered."""
    srv = start(host="127.0.0.2", workers=1)
    try:
        port = srv.server_address[1]
        for host, status in (("evil.example", 403), (f"127.0.0.2:{port}", 200)):
            conn = http.client.HTTPConnection("127.0.0.2", port, timeout=30)
            conn.request("GET", "/api/config", headers={"Host": host})
            assert conn.getresponse().status == status
            conn.close()
    finally:
        srv.shutdown()
        srv.server_close()


def test_a_cookie_that_is_not_ascii_gets_a_new_token_not_an_error(server):
    conn = http.client.HTTPConnection("127.0.0.1", server.server_address[1], timeout=30)
    conn.putrequest("GET", "/")
    conn.putheader("Cookie", "rattlesweep_session=caf\xe9.\xe9t\xe9")
    conn.endheaders()
    answer = conn.getresponse()
    assert answer.status == 200 and "rattlesweep_session=" in answer.headers["Set-Cookie"]
    conn.close()
