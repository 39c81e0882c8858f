"""`rattlesweep explore`, server level: a real server on 127.0.0.1 answering real HTTP.

Refused settings carry the library's own message (compared with what the library raises
for the same value), requests over a cap name the cap, a session's stale work is
superseded by its newer request, and what the page offers to take away (Python,
netCDF, sweep TOML) is what it claims to be."""

import json
import math
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import numpy as np
import pytest
import xarray as xr

import rattlesweep as rs
from rattlesweep.explore import Caps, start
from rattlesweep.explore.scheduler import Scheduler, Superseded
from rattlesweep.explore.maps import _classes
from rattlesweep.explore.settings import defaults, map_sweep

from explore_helpers import call, serving


@pytest.fixture(scope="module")
def server():
    yield from serving()


def run(srv, session="s", by=None, **changes):
    settings = {**defaults(), **changes}
    status, body = call(srv, "api/run", {"settings": settings}, session, by)
    return status, json.loads(body)


def library_message(fn):
    with pytest.raises(ValueError) as info:
        fn()
    return str(info.value)


def test_a_run_answers_with_its_series_and_summary(server):
    status, data = run(server, spin=-5.0)
    assert status == 200
    toy = rs.Body.semi_ellipsoid(0.0475, 0.0095, 0.011, defaults()["mass"], math.radians(5))
    ref = rs.simulate(toy, spin=-5.0, roll=math.radians(0.5), mu=0.3, t_end=5.0)
    assert data["summary"]["first_reversal_time"] == pytest.approx(
        float(ref.first_reversal_time), abs=2 * data["summary"]["dt"]
    )
    assert data["spin"][0] == pytest.approx(-5.0)
    n = len(data["t"])
    assert 100 < n <= Caps().max_frames
    assert len(data["quaternion"]) == 4 * n and len(data["contact"]) == 2 * n


@pytest.mark.parametrize(
    "control, value, library",
    [
        ("a", -0.01, lambda: rs.Body.semi_ellipsoid(-0.01, 0.0095, 0.011, 0.01)),
        ("mass", "heavy", lambda: rs.Body.semi_ellipsoid(0.0475, 0.0095, 0.011, "heavy")),
        (
            "mu_static",
            0.1,
            lambda: rs.simulate(rs.Body.preset("toy"), mu=0.3, mu_static=0.1, t_end=1.0),
        ),
        (
            "damping",
            -1.0,
            lambda: rs.simulate(rs.Body.preset("toy"), damping=-1.0, t_end=1.0),
        ),
    ],
)
def test_refused_values_get_the_library_message_by_their_control(
    server, control, value, library
):
    status, data = run(server, **{control: value})
    assert status == 400
    assert data["control"] == control
    message = library_message(library)
    if control == "mass":  # the page's text is refused before it reaches the library
        assert data["error"] == "mass must be a number, got 'heavy'"
    else:
        assert data["error"] == message


def test_the_rim_on_the_floor_is_the_library_message_at_the_roll_control(server):
    status, data = run(server, roll_deg=95.0)
    message = library_message(
        lambda: rs.simulate(rs.Body.preset("toy"), roll_deg=95.0, t_end=1.0)
    )
    assert (status, data["control"], data["error"]) == (400, "roll_deg", message)


@pytest.mark.parametrize(
    "changes, cap",
    [
        ({"t_end": 1000.0}, "max_t_end"),
        ({"masses": [[0.001, 0.0, 0.0, -0.001]] * 5}, "max_point_masses"),
    ],
)
def test_oversize_runs_are_refused_naming_the_cap(server, changes, cap):
    status, data = run(server, **changes)
    assert status == 413 and cap in data["error"]


def test_oversize_maps_are_refused_naming_the_cap(server):
    axes = {
        "x": {"param": "spin", "start": -5, "stop": 5, "num": 500},
        "y": {"param": "delta_deg", "start": -5, "stop": 5, "num": 5},
        "levels": 0,
    }
    status, body = call(server, "api/map", {"settings": defaults(), "map": axes})
    assert status == 413 and "max_map_num" in json.loads(body)["error"]
    axes["x"]["num"], axes["levels"] = 5, 9
    status, body = call(server, "api/map", {"settings": defaults(), "map": axes})
    assert status == 413 and "max_map_levels" in json.loads(body)["error"]


def test_a_newer_run_supersedes_the_running_one():
    # caps roomy enough for a run of a second or so, so that the newer request surely
    # arrives while it runs
    roomy = start(workers=1, caps=Caps(max_t_end=600.0, max_steps=10**6))
    answers = {}
    try:
        call(roomy, "")  # the page, which gives this browser its session token

        def slow():
            answers["slow"] = run(roomy, session="race", t_end=600.0, spin=-7.0)

        t = threading.Thread(target=slow)
        t.start()
        deadline = time.monotonic() + 30
        while roomy.app.scheduler.busy() == 0 and time.monotonic() < deadline:
            time.sleep(0.001)
        answers["new"] = run(roomy, session="race", t_end=1.0, spin=3.0)
        t.join()
    finally:
        roomy.shutdown()
        roomy.server_close()
    assert answers["slow"][0] == 409 and answers["slow"][1]["superseded"]
    assert answers["new"][0] == 200 and answers["new"][1]["spin"][0] == pytest.approx(3.0)


def test_waiting_work_is_superseded_and_sessions_take_turns():
    sched = Scheduler(1)
    gate = threading.Event()
    order = []

    def piece(name, pieces=1):
        left = [pieces]

        def step():
            gate.wait(10)
            order.append(name)
            left[0] -= 1
            return left[0] == 0, name

        return step

    try:
        blocker = sched.submit("other", "map", piece("blocker", 3))
        time.sleep(0.05)  # the worker holds the blocker's first piece
        stale = sched.submit("me", "run", piece("stale"))
        fresh = sched.submit("me", "run", piece("fresh"))
        with pytest.raises(Superseded):
            stale.future.result(timeout=5)
        gate.set()
        assert fresh.future.result(timeout=10) == "fresh"
        assert blocker.future.result(timeout=10) == "blocker"
    finally:
        sched.close()
    # the other session's map gave way to this session's run after one piece
    assert order == ["blocker", "fresh", "blocker", "blocker"]


def test_copy_as_python_makes_the_same_run(server):
    status, data = run(
        server, spin=-6.0, mu=0.2, damping=1e-7, masses=[[0.001, 0.02, 0.002, -0.002]]
    )
    assert status == 200
    namespace = {}
    exec(
        compile(data["python"].replace("print(", "(lambda *a: None)("), "<python>", "exec"),
        namespace,
    )
    ref = namespace["run"]
    assert int(ref.n_reversals) == data["summary"]["n_reversals"]
    assert float(ref.final_spin) == pytest.approx(data["summary"]["final_spin"], rel=1e-9)


def test_the_run_downloads_as_netcdf(server, tmp_path):
    status, data = run(server, session="nc", spin=-4.0)
    status, body = call(server, "api/run.nc?session=nc")
    assert status == 200
    path = tmp_path / "run.nc"
    path.write_bytes(body)
    with xr.open_dataset(path) as ds:
        assert ds.spin.attrs["units"] == "rad s-1"
        assert float(ds.spin[0]) == pytest.approx(-4.0)
        assert float(ds.final_spin) == pytest.approx(data["summary"]["final_spin"])


def test_a_map_runs_to_the_end_and_its_toml_is_the_sweep(server):
    axes = {
        "x": {"param": "spin", "start": -20, "stop": 20, "num": 5},
        "y": {"param": "delta_deg", "start": -6, "stop": 6, "num": 3},
        "levels": 1,
    }
    settings = {**defaults(), "mu": "inf", "t_end": 3.0}
    status, body = call(server, "api/map", {"settings": settings, "map": axes}, "map")
    assert status == 200
    deadline = time.monotonic() + 60
    while True:
        snap = json.loads(call(server, "api/map?session=map")[1])
        if snap["done"] or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert snap["done"] and snap["progress"] == 1.0
    outcome = np.array(snap["outcome"])
    assert outcome.shape == (5, 9)  # rows: delta (3 refined once), columns: spin
    assert outcome.min() >= 0
    # the map agrees with the library's own batch run at the declared grid's corners
    sweep = rs.Sweep.from_toml(snap["toml"])
    bodies, kwargs = sweep.points_at(np.array([0, sweep.size - 1]))
    ref = rs.run_batch(bodies, stop="first_reversal", **kwargs)
    assert (outcome[0, 0] == 1) == (int(ref.n_reversals[0]) >= 1)
    assert (outcome[-1, -1] == 1) == (int(ref.n_reversals[1]) >= 1)
    assert snap["unstable"] is not None  # rolling: the stability boundary is drawn
    status, text = call(server, "api/toml", {"settings": settings, "map": axes}, "map")
    assert rs.Sweep.from_toml(text.decode()) == sweep


def test_the_command_line_serves_and_warns_off_localhost(tmp_path):
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rattlesweep.cli",
            "explore",
            "--no-browser",
            "--port",
            "0",
            "--host",
            "0.0.0.0",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    try:
        for line in proc.stdout:
            lines.append(line)
            if "serving at" in line:
                break
        url = lines[-1].split("serving at ")[1].split()[0]
        port = url.rsplit(":", 1)[1].strip("/")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=30) as r:
            assert b"rattlesweep explore" in r.read()
    finally:
        proc.terminate()
        proc.wait(30)
    text = "".join(lines)
    assert "warming the kernels" in text and "first run" in text
    assert "anyone who can reach this address" in text


def test_a_run_that_capsizes_is_shown_with_its_warning(server):
    status, data = run(server, spin=20.0, delta_deg=-4.0, mu="inf", t_end=3.0)
    assert status == 200
    assert data["summary"]["status"] == "capsized"
    assert any("capsized" in w for w in data["warnings"])
    t_stop = max(t for t, s in zip(data["t"], data["spin"]) if s is not None)
    assert all(b <= t_stop for _, b in data["slips"])


def test_the_notebook_shows_the_page_in_a_frame():
    from rattlesweep import explore

    frame = explore.show(height=700)
    try:
        html = frame._repr_html_()
        assert 'height="700"' in html
        url = html.split('src="')[1].split('"')[0]
        assert url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(url, timeout=30) as r:
            assert b"rattlesweep explore" in r.read()
        assert explore.show().url == url  # one server per kernel
    finally:
        explore._NOTEBOOK_SERVER.shutdown()
        explore._NOTEBOOK_SERVER.server_close()
        explore._NOTEBOOK_SERVER = None


def test_a_new_map_supersedes_the_stale_one(server):
    settings = {**defaults(), "mu": "inf", "t_end": 10.0}
    big = {
        "x": {"param": "spin", "start": -30, "stop": 30, "num": 25},
        "y": {"param": "delta_deg", "start": -8, "stop": 8, "num": 25},
        "levels": 2,
    }
    status, _ = call(server, "api/map", {"settings": settings, "map": big}, "maps")
    assert status == 200
    stale = next(s for k, s in server.app._sessions.items() if k.endswith("/maps")).map
    small = {
        "x": {"param": "spin", "start": -5, "stop": 5, "num": 3},
        "y": {"param": "roll_deg", "start": 0.5, "stop": 1, "num": 2},
        "levels": 0,
    }
    status, _ = call(
        server, "api/map", {"settings": {**settings, "t_end": 1.0}, "map": small}, "maps"
    )
    assert status == 200
    deadline = time.monotonic() + 60
    while not json.loads(call(server, "api/map?session=maps")[1])["done"]:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    simulated = stale.simulated
    time.sleep(0.3)
    # the stale map stopped: far from its 625 declared launches, and no further work
    assert stale.simulated == simulated < 625 and not stale.done


def test_a_loopback_server_refuses_other_host_names(server):
    port = server.url.rsplit(":", 1)[1].strip("/")
    req = urllib.request.Request(
        f"http://127.0.0.1:{port}/api/config", headers={"Host": f"attacker.example:{port}"}
    )
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(req, timeout=30)
    assert info.value.code == 403
    with urllib.request.urlopen(f"http://localhost:{port}/api/config", timeout=30) as r:
        assert json.loads(r.read())["caps"]["max_t_end"] == Caps().max_t_end


def test_a_repeated_launch_is_answered_from_the_cache(server):
    first = run(server, session="c1", spin=-9.5)
    completed, hits = server.app.scheduler.completed, server.app.cache_hits
    again = run(server, session="c2", spin="-9.5")  # the same launch, typed as text
    assert first == again and again[0] == 200
    assert server.app.scheduler.completed == completed  # not simulated again
    assert server.app.cache_hits == hits + 1
    status, body = call(server, "api/run.nc?session=c2")  # the session has its run
    assert status == 200 and body[:4] == b"\x89HDF"


def test_library_messages_read_as_plain_numbers_without_an_index(server):
    for control, value in (("damping", -1.0), ("mu", -1.0), ("mu_spin", -0.5)):
        status, data = run(server, **{control: value})
        assert status == 400 and data["control"] == control
        assert "np.float64" not in data["error"]
        assert f"got {value!r}" in data["error"]
    status, data = run(server, roll_deg=160.0)
    assert status == 400 and data["control"] == "roll_deg"
    assert data["error"].startswith("roll/pitch/orientation: initial tilt 160 deg puts")
    assert "index" not in data["error"]


@pytest.mark.parametrize(
    "control, value, message",
    [
        ("spin", "inf", "spin must be a finite number (rad/s), got inf"),
        ("spin", "-inf", "spin must be a finite number (rad/s), got -inf"),
        ("spin", 1e300, "spin must be at most 1e+08 rad/s in size, got 1e+300"),
        ("t_end", "nan", "t_end must be a finite number (s), got nan"),
        ("a", "inf", "a must be a finite number (m), got inf"),
    ],
)
def test_values_the_page_cannot_show_are_refused_by_their_control(
    server, control, value, message
):
    status, data = run(server, **{control: value})
    assert (status, data["control"], data["error"]) == (400, control, message)


def test_rolling_is_still_allowed(server):
    assert run(server, mu="inf", mu_static="inf", t_end=0.5)[0] == 200


def test_a_run_that_ends_at_t0_sends_its_one_sample(server):
    status, data = run(server, spin=1e6)
    assert status == 200 and data["summary"]["status"] == "lifted_off"
    assert len(data["t"]) == 1 and data["spin"] == [1e6]
    assert len(data["position"]) == 3 and None not in data["position"]
    assert any("lifted_off" in w for w in data["warnings"])


def test_caps_name_their_control(server):
    status, data = run(server, t_end=1000.0)
    assert (status, data["control"]) == (413, "t_end")
    status, data = run(server, masses=[[0.001, 0.0, 0.0, -0.001]] * 5)
    assert (status, data["control"]) == (413, "masses")


def test_the_config_describes_presets_and_map_axes(server):
    config = json.loads(call(server, "api/config")[1])
    golden = config["presets"]["golden"]
    body = rs.Body.preset("golden")
    assert (golden["a"], golden["b"], golden["c"], golden["mass"]) == (
        body.a,
        body.b,
        body.c,
        body.mass,
    )
    assert "_" not in golden["label"]
    axes = config["map_axes"]
    assert axes["delta_deg"]["label"] == config["labels"]["delta_deg"] == "misalignment δ"
    assert axes["spin"]["units"] == "rad/s"
    for name, axis in axes.items():  # each default range is one the library accepts
        if "start" in axis:
            settings = {**defaults(), "mu": "inf", "t_end": 1.0}
            other = "delta_deg" if name != "delta_deg" else "spin"
            sweep = map_sweep(
                settings,
                {
                    "x": {
                        "param": name,
                        "start": axis["start"],
                        "stop": axis["stop"],
                        "num": 2,
                    },
                    "y": {"param": other, "start": 1, "stop": 2, "num": 2},
                },
                Caps(),
            )
            assert sweep.size == 4


def test_neutral_stability_cells_have_no_class():
    growth = np.array([[-0.5, 1e-15, 0.7], [0.0, -2e-16, 3.0]])
    assert _classes(growth).tolist() == [[0, None, 1], [None, None, 1]]


def test_copy_as_python_names_angles_in_degrees(server):
    status, data = run(server, roll_deg=0.5, pitch_deg=1.25)
    assert "roll_deg=0.5, pitch_deg=1.25" in data["python"]


def test_a_busy_port_is_one_line_and_exit_status_2():
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        t0 = time.monotonic()
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "rattlesweep.cli",
                "explore",
                "--no-browser",
                "--port",
                str(port),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        f"rattlesweep explore: port {port} is in use: choose "
        "another with --port, or --port 0 for any free port"
    )
    assert "warming" not in proc.stdout  # checked before the kernels are warmed
    assert time.monotonic() - t0 < 30


def test_the_command_line_help_describes_the_explorer():
    proc = subprocess.run(
        [sys.executable, "-m", "rattlesweep.cli", "explore", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0
    assert "reversal map" in proc.stdout and "first run" in proc.stdout


def test_show_in_a_plain_script_says_where_and_how_to_keep_it_up():
    proc = subprocess.run(
        [sys.executable, "-c", "from rattlesweep import explore; explore.show()"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0
    assert "serving at http://127.0.0.1:" in proc.stdout
    assert "rattlesweep explore" in proc.stdout and "explore.serve()" in proc.stdout


def _raw(server, request: bytes) -> bytes:
    """Send raw bytes to the server; its whole answer (the connection closed by it)."""
    import socket

    port = int(server.url.rsplit(":", 1)[1].strip("/"))
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(request)
        answer = b""
        while chunk := sock.recv(65536):
            answer += chunk
    return answer


@pytest.mark.parametrize(
    "length, message",
    [
        (b"-1", b"Content-Length '-1' is not a length"),
        (b"abc", b"Content-Length 'abc' is not a length"),
        (b"99999999999999999999", b"is not a length"),
        (b"2000000", b"request body over 1048576 bytes"),
    ],
)
def test_a_body_length_that_is_not_a_length_is_refused_before_reading(
    server, length, message
):
    """The server answers at once and closes, though the client keeps the connection
    open and sends nothing more: nothing waits for (or buffers) a body."""
    head = (
        b"POST /api/run HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        b"Content-Length: " + length + b"\r\n\r\n"
    )
    began = time.perf_counter()
    answer = _raw(server, head)
    assert time.perf_counter() - began < 5
    assert answer.split(b"\r\n", 1)[0] in (
        b"HTTP/1.1 400 Bad Request",
        b"HTTP/1.1 413 Request Entity Too Large",
    ), answer[:200]
    assert message in answer


@pytest.mark.parametrize(
    "body, message",
    [
        (b"[" * 100000 + b"]" * 100000, b"bad request: nested too deep"),
        (b'{"settings": [1, 2]}', b"bad request: settings must be a JSON object"),
        (b'{"map": "spin"}', b"bad request: map must be a JSON object"),
    ],
)
def test_bodies_of_the_wrong_shape_get_a_400(server, body, message):
    head = (
        b"POST /api/run HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n"
        b"Content-Length: " + str(len(body)).encode() + b"\r\n\r\n"
    )
    answer = _raw(server, head + body)
    assert answer.startswith(b"HTTP/1.1 400"), answer[:200]
    assert message in answer


@pytest.mark.parametrize("port", ["-1", "65536", "http"])
def test_a_port_that_is_no_port_is_refused_by_name(port, capsys):
    from rattlesweep.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["explore", "--port", port, "--no-browser"])
    assert exit_.value.code == 2
    assert (
        f"--port: must be a port number from 0 to 65535 (0: any free port), got '{port}'"
        in (capsys.readouterr().err)
    )
