"""`rattlesweep explore` in a real headless Chromium (Debian's ``chromium``) driven by
Playwright: the page loads and draws, moving the spin control re-runs the launch and
changes the spin plot, a refused value shows the library's message by its control, and
clicking a map point loads that launch into the run view.

Screenshots go to ``$RATTLESWEEP_SCREENSHOTS`` (default: a temporary directory); the
path is printed. Skipped, saying why, without Chromium or Playwright."""

import base64
import math
import os
import shutil
import time
from pathlib import Path

import pytest

import rattlesweep as rs
from rattlesweep.explore import start, warm
from rattlesweep.sweep.params import result_name

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
sync_api = pytest.importorskip("playwright.sync_api",
                               reason="Playwright's Python package is not installed "
                                      "(the test extra installs it)")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium installed (Debian: apt-get install chromium; "
                             ".ci/run installs it)")


@pytest.fixture(scope="module")
def shots(tmp_path_factory, request):
    where = Path(os.environ.get("RATTLESWEEP_SCREENSHOTS")
                 or tmp_path_factory.mktemp("explore-screenshots"))
    where.mkdir(parents=True, exist_ok=True)
    capman = request.config.pluginmanager.getplugin("capturemanager")
    with capman.global_and_fixture_disabled():
        print(f"\nexplore screenshots: {where}")
    return where


@pytest.fixture(scope="module")
def page():
    warm()
    server = start(workers=2)
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        context = browser.new_context(viewport={"width": 1500, "height": 1000})
        context.grant_permissions(["clipboard-read", "clipboard-write"])
        pg = context.new_page()
        errors = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(server.url)
        pg.wait_for_function("window.explorer && window.explorer.ready", timeout=60_000)
        pg.errors = errors
        yield pg
        browser.close()
    server.shutdown()
    server.server_close()


def canvas_png(page, selector):
    url = page.eval_on_selector(selector, "c => c.toDataURL('image/png')")
    return base64.b64decode(url.split(",", 1)[1])


def test_the_page_loads_and_draws_the_run(page, shots):
    state = page.evaluate("window.explorer.run.summary")
    assert state["status"] == "ok"
    # the 3-D view drew the (orange) body: a share of its pixels is far redder than blue
    share = page.eval_on_selector("#view", """c => {
        const g = document.createElement('canvas'); g.width = c.width; g.height = c.height;
        const x = g.getContext('2d'); x.drawImage(c, 0, 0);
        const d = x.getImageData(0, 0, c.width, c.height).data;
        let n = 0, hit = 0;
        for (let i = 0; i < d.length; i += 4 * 7) { n++; if (d[i] - d[i + 2] > 60) hit++; }
        return hit / n; }""")
    assert 0.005 < share < 0.5
    assert "Limits of this server" in page.inner_text("#controls")
    assert "30" in page.inner_text("#caps")  # the run-length cap, said in the page
    page.screenshot(path=str(shots / "explore-page.png"))
    assert page.errors == []


def test_moving_the_spin_control_changes_the_spin_plot(page, shots):
    before = canvas_png(page, "#plot-spin")
    runs = page.evaluate("window.explorer.runs")
    page.focus("#spin-slider")
    for _ in range(10):  # the slider's step is 0.5 rad/s: from -5 to 0 ... to +0
        page.keyboard.press("ArrowRight")
    page.keyboard.press("ArrowRight")
    page.wait_for_function(f"window.explorer.runs > {runs} && "
                           "Math.abs(window.explorer.run.spin[0] - 0.5) < 1e-9",
                           timeout=30_000)
    assert page.input_value("#spin") == "0.5"
    page.wait_for_timeout(100)
    after = canvas_png(page, "#plot-spin")
    assert after != before
    page.screenshot(path=str(shots / "explore-spin-moved.png"))


def test_a_refused_value_shows_the_library_message_by_its_control(page):
    page.fill("#c", "-0.011")
    page.wait_for_function("document.getElementById('err-c').textContent.length > 0",
                           timeout=30_000)
    with pytest.raises(ValueError) as info:
        rs.Body.semi_ellipsoid(0.0475, 0.0095, -0.011, 0.01)
    assert page.inner_text("#err-c") == str(info.value)
    page.fill("#c", "0.011")
    page.wait_for_function("document.getElementById('err-c').textContent === ''",
                           timeout=30_000)


def test_clicking_a_map_point_loads_its_launch(page, shots):
    for sel, value in (("#map-x-num", "7"), ("#map-y-num", "5"), ("#map-levels", "1"),
                       ("#t_end", "3")):
        page.fill(sel, value)
    page.fill("#mu", "inf")
    page.click("#map-go")
    page.wait_for_function("window.explorer.map && window.explorer.map.done",
                           timeout=60_000)
    m = page.evaluate("window.explorer.map")
    nx, ny = len(m["x"]["values"]), len(m["y"]["values"])
    box = page.locator("#map-canvas").bounding_box()
    # the cell in column i, row j (from the bottom), in the canvas's own frame
    i, j = nx - 3, 2  # a point of the declared grid: simulated, not filled
    x0, x1, y0, y1 = 52, box["width"] - 8, 8, box["height"] - 34
    cx = x0 + (i + 0.5) * (x1 - x0) / nx
    cy = y1 - (j + 0.5) * (y1 - y0) / ny
    runs = page.evaluate("window.explorer.runs")
    page.mouse.click(box["x"] + cx, box["y"] + cy)
    spin, delta = m["x"]["values"][i], m["y"]["values"][j]
    page.wait_for_function(f"window.explorer.runs > {runs}", timeout=30_000)
    run = page.evaluate("window.explorer.run")
    assert run["spin"][0] == pytest.approx(spin)
    assert float(page.input_value("#delta_deg")) == pytest.approx(delta)
    assert f"delta=math.radians({float(delta)!r})" in run["python"]
    # the run view shows that launch: its outcome is the map's at that point
    reversed_run = run["summary"]["n_reversals"] >= 1
    assert reversed_run == (m["outcome"][j][i] in (1, 2))
    assert not math.isnan(run["summary"]["final_spin"])
    page.wait_for_timeout(300)
    page.screenshot(path=str(shots / "explore-map-click.png"))
    assert page.errors == []


def test_pause_scrub_and_slow_motion(page):
    page.select_option("#speed", "0.1")
    if page.inner_text("#play") == "pause":
        page.click("#play")
    assert page.inner_text("#play") == "play"
    frame = page.evaluate("window.explorer.frame")
    page.wait_for_timeout(300)
    assert page.evaluate("window.explorer.frame") == frame  # paused: the frame stays
    cursor_before = canvas_png(page, "#plot-tilt")
    n = page.evaluate("window.explorer.run.n")
    page.eval_on_selector("#scrub", f"""s => {{ s.value = {n // 2};
        s.dispatchEvent(new Event('input')); }}""")
    t_mid = page.evaluate(f"window.explorer.run.t[{n // 2}]")
    assert page.inner_text("#clock") == f"{t_mid:.2f} s"
    assert canvas_png(page, "#plot-tilt") != cursor_before  # the cursor moved
    t0 = time.monotonic()
    page.click("#play")
    page.wait_for_function(f"window.explorer.run.t[window.explorer.frame] > {t_mid}",
                           timeout=10_000)
    page.wait_for_timeout(500)
    t_now = page.evaluate("window.explorer.run.t[window.explorer.frame]")
    wall = time.monotonic() - t0
    # a tenth of real time: the run advanced by at most a tenth of the time it played
    assert t_mid < t_now <= t_mid + 0.1 * wall + 0.02


def test_copy_as_python_and_the_sweep_toml(page, tmp_path):
    page.click("#copy-python")
    page.wait_for_function("document.getElementById('status').textContent === 'Python copied'")
    code = page.evaluate("navigator.clipboard.readText()")
    assert code == page.evaluate("window.explorer.run.python")
    assert "rs.simulate(body, " in code
    with page.expect_download() as info:
        page.click("#download-toml")
    path = tmp_path / "map.toml"
    info.value.save_as(path)
    sweep = rs.Sweep.from_toml(path)
    # the sweep's dimensions are named as results name them (spin: launch_spin)
    assert sweep.dims == tuple(result_name(page.input_value(f"#map-{k}-param")) for k in "xy")
