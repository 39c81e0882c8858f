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
from rattlesweep.sweep._config.params import result_name

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
sync_api = pytest.importorskip(
    "playwright.sync_api",
    reason="Playwright's Python package is not installed (the test extra installs it)",
)
pytestmark = pytest.mark.skipif(
    CHROMIUM is None,
    reason="no Chromium installed (Debian: apt-get install chromium; .ci/run installs it)",
)


@pytest.fixture(scope="module")
def shots(tmp_path_factory, request):
    where = Path(
        os.environ.get("RATTLESWEEP_SCREENSHOTS")
        or tmp_path_factory.mktemp("explore-screenshots")
    )
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
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
        )
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
    share = page.eval_on_selector(
        "#view",
        """c => {
        const g = document.createElement('canvas'); g.width = c.width; g.height = c.height;
        const x = g.getContext('2d'); x.drawImage(c, 0, 0);
        const d = x.getImageData(0, 0, c.width, c.height).data;
        let n = 0, hit = 0;
        for (let i = 0; i < d.length; i += 4 * 7) { n++; if (d[i] - d[i + 2] > 60) hit++; }
        return hit / n; }""",
    )
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
    page.wait_for_function(
        f"window.explorer.runs > {runs} && "
        "Math.abs(window.explorer.run.spin[0] - 0.5) < 1e-9",
        timeout=30_000,
    )
    assert page.input_value("#spin") == "0.5"
    page.wait_for_timeout(100)
    after = canvas_png(page, "#plot-spin")
    assert after != before
    page.screenshot(path=str(shots / "explore-spin-moved.png"))


def test_a_refused_value_shows_the_library_message_by_its_control(page):
    page.fill("#c", "-0.011")
    page.wait_for_function(
        "document.getElementById('err-c').textContent.length > 0", timeout=30_000
    )
    with pytest.raises(ValueError) as info:
        rs.Body.semi_ellipsoid(0.0475, 0.0095, -0.011, 0.01)
    assert page.inner_text("#err-c") == str(info.value)
    page.fill("#c", "0.011")
    page.wait_for_function(
        "document.getElementById('err-c').textContent === ''", timeout=30_000
    )


def test_clicking_a_map_point_loads_its_launch(page, shots):
    for sel, value in (
        ("#map-x-num", "7"),
        ("#map-y-num", "5"),
        ("#map-levels", "1"),
        ("#t_end", "3"),
    ):
        page.fill(sel, value)
    page.fill("#mu", "inf")
    page.click("#map-go")
    page.wait_for_function(
        "window.explorer.map && window.explorer.map.done", timeout=60_000
    )
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
    # the map stops at the first reversal; a run that goes on to capsize says so there
    status = run["summary"]["status"]
    assert status == "capsized"  # this launch reverses, then capsizes
    assert "run on, it capsized at" in page.inner_text("#map-note")
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
    page.eval_on_selector(
        "#scrub",
        f"""s => {{ s.value = {n // 2};
        s.dispatchEvent(new Event('input')); }}""",
    )
    t_mid = page.evaluate(f"window.explorer.run.t[{n // 2}]")
    assert page.inner_text("#clock") == f"{t_mid:.2f} s"
    assert canvas_png(page, "#plot-tilt") != cursor_before  # the cursor moved
    t0 = time.monotonic()
    page.click("#play")
    page.wait_for_function(
        f"window.explorer.run.t[window.explorer.frame] > {t_mid}", timeout=10_000
    )
    page.wait_for_timeout(500)
    t_now = page.evaluate("window.explorer.run.t[window.explorer.frame]")
    wall = time.monotonic() - t0
    # a tenth of real time: the run advanced by at most a tenth of the time it played
    assert t_mid < t_now <= t_mid + 0.1 * wall + 0.02


def test_copy_as_python_and_the_sweep_toml(page, tmp_path):
    page.click("#copy-python")
    page.wait_for_function(
        "document.getElementById('status').textContent === 'Python copied'"
    )
    code = page.evaluate("navigator.clipboard.readText()")
    assert code == page.evaluate("window.explorer.run.python")
    assert "rs.simulate(body, " in code
    with page.expect_download() as info:
        page.click("#download-toml")
    path = tmp_path / "map.toml"
    info.value.save_as(path)
    sweep = rs.Sweep.from_toml(path)
    # the sweep's dimensions are named as results name them (spin: launch_spin)
    assert sweep.dims == tuple(
        result_name(page.input_value(f"#map-{k}-param")) for k in "xy"
    )


def wait_run(page, runs, timeout=30_000):
    page.wait_for_function(
        f"window.explorer.runs > {runs} || window.explorer.lastError !== null",
        timeout=timeout,
    )


def set_control(page, sel, value):
    """Type a value into a control and wait until the page has the answer (a run or a
    refusal)."""
    runs, requests = page.evaluate("[window.explorer.runs, window.explorer.requests]")
    page.fill(sel, value)
    page.wait_for_function(
        f"window.explorer.requests > {requests} && "
        "document.getElementById('status').textContent !== 'running…'",
        timeout=30_000,
    )
    return runs


def test_a_run_that_ends_at_t0_shows_its_warning_and_the_page_keeps_playing(page, shots):
    set_control(page, "#mu", "0.3")  # its run done first: the next one is the spin's
    if page.inner_text("#play") == "play":
        page.click("#play")
    runs = set_control(page, "#spin", "1e6")  # lifts off at once
    assert page.evaluate("window.explorer.runs") == runs + 1
    run = page.evaluate("window.explorer.run")
    assert run["n"] == 1 and run["summary"]["status"] == "lifted_off"
    assert "lifted_off" in page.inner_text("#summary")
    assert "stopped at t = 0 s" in page.inner_text("#summary")
    page.wait_for_timeout(200)
    page.screenshot(path=str(shots / "explore-lifted-off.png"))
    # a good run afterwards plays
    set_control(page, "#spin", "-5")
    assert page.evaluate("window.explorer.run.n") > 100
    frame = page.evaluate("window.explorer.frame")
    page.wait_for_function(f"window.explorer.frame !== {frame}", timeout=10_000)
    assert page.errors == []


@pytest.mark.parametrize(
    "value, message",
    [
        ("inf", "spin must be a finite number (rad/s), got inf"),
        ("nan", "spin must be a finite number (rad/s), got nan"),
        ("1e300", "spin must be at most 1e+08 rad/s in size, got 1e+300"),
    ],
)
def test_a_spin_the_page_cannot_show_is_refused_by_its_control(page, value, message):
    set_control(page, "#spin", value)
    assert page.inner_text("#err-spin") == message
    assert "bad" in page.get_attribute("#spin", "class")
    assert page.inner_text("#status") != "running…"
    set_control(page, "#spin", "-5")
    assert page.inner_text("#err-spin") == ""
    assert page.errors == []


def test_a_broken_answer_leaves_the_page_usable(page):
    good = page.evaluate("window.explorer.runs")
    page.route(
        "**/api/run",
        lambda route: route.fulfill(
            status=200,
            content_type="application/json",
            body='{"t": [0, 1], "spin": [null, null], "summary": {}, "body": {"a": 1}}',
        ),
    )
    set_control(page, "#spin", "-4")
    assert "could not be drawn" in page.inner_text("#err-general")
    page.route(
        "**/api/run", lambda route: route.fulfill(status=502, body="Bad Gateway"), times=1
    )
    page.unroute("**/api/run")
    page.route("**/api/run", lambda route: route.fulfill(status=502, body="Bad Gateway"))
    set_control(page, "#spin", "-4.5")
    assert "502" in page.inner_text("#err-general")
    page.unroute("**/api/run")
    set_control(page, "#spin", "-5")
    assert page.evaluate("window.explorer.runs") > good
    assert page.inner_text("#err-general") == ""
    frame = page.evaluate("window.explorer.frame")
    page.wait_for_function(f"window.explorer.frame !== {frame}", timeout=10_000)
    assert page.errors == []


def test_caps_are_said_by_their_own_control(page):
    set_control(page, "#t_end", "1000")
    assert "max_t_end" in page.inner_text("#err-t_end")
    assert "bad" in page.get_attribute("#t_end", "class")
    set_control(page, "#t_end", "5")
    set_control(page, "#masses", "\n".join(["0.001, 0, 0, -0.001"] * 5))
    assert "max_point_masses" in page.inner_text("#err-masses")
    assert page.inner_text("#err-t_end") == ""
    assert "bad" in page.get_attribute("#masses", "class")
    set_control(page, "#masses", "")
    assert page.inner_text("#err-masses") == ""


def test_a_new_map_axis_gets_its_own_range_and_labels_are_human(page):
    page.select_option("#map-x-param", "mu")
    start, stop = (
        float(page.input_value("#map-x-start")),
        float(page.input_value("#map-x-stop")),
    )
    assert 0 <= start < stop <= 2
    page.select_option("#map-x-param", "a")
    a = float(page.input_value("#a"))
    assert float(page.input_value("#map-x-start")) == pytest.approx(0.5 * a, rel=0.01)
    assert float(page.input_value("#map-x-stop")) == pytest.approx(1.5 * a, rel=0.01)
    page.select_option("#map-x-param", "spin")
    assert (page.input_value("#map-x-start"), page.input_value("#map-x-stop")) == (
        "-30",
        "30",
    )
    options = page.eval_on_selector_all("#map-y-param option", "os => os.map(o => o.text)")
    assert "misalignment δ (deg)" in options and "spin (rad/s)" in options
    assert "μ kinetic" in options and not any("_" in o for o in options)
    presets = page.eval_on_selector_all("#preset option", "os => os.map(o => o.text)")
    assert not any("_" in p for p in presets)
    # the map header's rows do not wrap: "points" stays beside its box
    top = page.locator("#map-x-param").bounding_box()["y"]
    assert abs(page.locator("#map-x-num").bounding_box()["y"] - top) < 12


def test_a_preset_shows_its_body_and_the_view_frames_it(page, shots):
    page.select_option("#preset", "golden")
    page.wait_for_function("window.explorer.run.body.a > 1", timeout=30_000)
    golden = rs.Body.preset("golden")
    assert float(page.input_value("#a")) == pytest.approx(golden.a, rel=1e-5)
    assert (page.input_value("#b"), page.input_value("#c"), page.input_value("#mass")) == (
        "1",
        "1",
        "0.2",
    )
    assert page.eval_on_selector("#a", "e => e.readOnly")
    page.wait_for_timeout(100)
    assert page.evaluate("window.explorer.extentInView()") < 0.95
    page.screenshot(path=str(shots / "explore-golden.png"))
    page.select_option("#preset", "custom")
    page.wait_for_function("window.explorer.run.body.a < 1", timeout=30_000)
    assert page.input_value("#a") == "0.0475" and not page.eval_on_selector(
        "#a", "e => e.readOnly"
    )
    assert page.input_value("#mass") == "0.0109159"  # rounded for display
    assert page.evaluate("window.explorer.run.python").count("mass=0.010915856") == 1


def test_the_spin_arrow_grows_with_the_spin_and_stays_in_view(page, shots):
    page.click("#play") if page.inner_text("#play") == "pause" else None
    lengths = []
    for spin in ("-1", "-5", "-20"):
        set_control(page, "#spin", spin)
        page.eval_on_selector(
            "#scrub", "s => { s.value = 0; s.dispatchEvent(new Event('input')); }"
        )
        lengths.append(page.evaluate("window.explorer.arrowLength"))
        assert page.evaluate("window.explorer.extentInView()") < 0.95
        page.screenshot(path=str(shots / f"explore-arrow{spin}.png"))
    assert lengths[0] < lengths[1] < lengths[2]
    assert lengths[2] > 2 * lengths[0]
    set_control(page, "#spin", "-5")


def test_plots_do_not_zoom_onto_rounding(page):
    set_control(page, "#mu", "inf")
    frame = page.eval_on_selector("#plot-energy", "c => c._frame")
    energy = page.evaluate("window.explorer.run.energy")
    assert frame["hi"] - frame["lo"] >= 0.01 * max(abs(e) for e in energy if e is not None)
    slip = page.eval_on_selector("#plot-slip", "c => c._frame")
    assert slip["lo"] == 0  # slip speed starts at 0: a rolling run's 1e-9 m/s reads as 0
    assert "no slip" in page.inner_text("#summary")
    set_control(page, "#mu", "0.3")


def test_copied_feedback_and_python_in_degrees(page):
    page.click("#copy-python")
    page.wait_for_function("document.getElementById('copied').textContent === 'copied ✓'")
    code = page.evaluate("window.explorer.run.python")
    assert "roll_deg=0.5" in code and "roll=" not in code


def test_the_map_has_ticks_a_full_bar_and_no_stray_boundary(page):
    page.select_option("#map-x-param", "spin")
    page.select_option("#map-y-param", "delta_deg")
    for sel, value in (("#map-x-num", "9"), ("#map-y-num", "5"), ("#map-levels", "1")):
        page.fill(sel, value)
    set_control(page, "#t_end", "2")
    set_control(page, "#mu", "inf")
    page.click("#map-go")
    page.wait_for_function(
        "window.explorer.map && window.explorer.map.done && "
        "window.explorer.map.x.values.length === 17",
        timeout=60_000,
    )
    page.wait_for_timeout(300)
    ticks = page.evaluate("window.explorer.mapTicks")
    assert len(ticks["x"]) >= 4 and len(ticks["y"]) >= 3
    bar = page.eval_on_selector("#map-bar", "b => b.style.width")
    assert float(bar.rstrip("%")) == 100.0
    # spin 0 is neutral (growth zero to rounding): no boundary cells there
    m = page.evaluate("window.explorer.map")
    zero = m["x"]["values"].index(0.0)
    assert all(row[zero] is None for row in m["unstable"])
    assert page.errors == []


def test_a_measurement_is_drawn_and_fitted_into_the_controls(page, shots, tmp_path):
    """A phyphox export made by the model (spin -3 rad/s, roll 1 degree, damping 2e-4
    N m s, noise 0.02 rad/s), loaded through the page's file control: its rate is drawn
    over the spin plot; pressing fit puts fitted values whose intervals hold the truth
    into the controls, and the run follows them. A file of an unknown layout is refused
    by the measurement's control."""
    from rattlesweep.fitting.measurement import write_phyphox

    truth = {"spin": -3.0, "roll_deg": 1.0, "damping": 2e-4}
    run = rs.simulate(
        rs.Body.preset("kane_levinson"), t_end=4.0, record_every=1, mu=0.4, **truth
    )
    t = [0.01 * k for k in range(400)]
    import numpy as np

    rates = np.stack(
        [np.interp(t, run.time.values, run.omega.values[:, k]) for k in range(3)], 1
    )
    rates += np.random.default_rng(5).normal(0.0, 0.02, rates.shape)
    good = tmp_path / "Gyroscope rotation rate.csv"
    write_phyphox(good, np.array(t), rates)
    bad = tmp_path / "notes.csv"
    bad.write_text("colour,size\nred,3\n")

    page.select_option("#preset", "kane_levinson")
    for sel, value in (("#spin", "-2.5"), ("#roll_deg", "1.5"), ("#pitch_deg", "0")):
        page.fill(sel, value)
    for sel, value in (("#mu", "0.4"), ("#damping", "0.0001"), ("#mu_spin", "0")):
        page.fill(sel, value)
    page.fill("#mu_roll", "0")
    page.set_input_files("#measurement", str(bad))
    page.wait_for_function(
        "document.getElementById('err-measurement').textContent.length > 0",
        timeout=30_000,
    )
    assert "layout is not known" in page.inner_text("#err-measurement")
    assert page.is_disabled("#fit")

    runs = page.evaluate("window.explorer.runs")
    before = canvas_png(page, "#plot-spin")
    page.set_input_files("#measurement", str(good))
    page.wait_for_function(
        f"window.explorer.measured && window.explorer.runs > {runs}", timeout=30_000
    )
    page.wait_for_timeout(200)
    assert page.inner_text("#err-measurement") == ""
    assert page.input_value("#t_end") == "3.99"
    assert canvas_png(page, "#plot-spin") != before  # the dots drawn
    ticked = page.eval_on_selector_all(
        "#fit-free input:checked", "els => els.map(e => e.value)"
    )
    assert sorted(ticked) == sorted(truth)
    page.screenshot(path=str(shots / "explore-measurement.png"))

    page.click("#fit")
    page.wait_for_function("window.explorer.fit", timeout=180_000)
    fitted = page.evaluate("window.explorer.fit.fitted")
    for name, value in truth.items():
        f = fitted[name]
        assert f["determined"] and f["low"] <= value <= f["high"], (name, f)
        assert float(page.input_value(f"#{name}")) == pytest.approx(f["value"], rel=1e-5)
    assert "95 %" in page.inner_text("#fit-result")
    page.wait_for_function(
        "Math.abs(window.explorer.run.spin[0] - window.explorer.fit.fitted.spin.value)"
        " < 0.05",
        timeout=30_000,
    )
    page.screenshot(path=str(shots / "explore-fitted.png"))
    assert page.errors == []


def test_classroom_mode_hides_the_advanced_and_guides_a_first_experiment(page, shots):
    """The switch (or ``?classroom=1`` in the address) hides what a first lesson does not
    need, shows a first experiment, and leaves the timing out of the status line; the
    key to the 3-D view is always there."""
    advanced = ["#mu_spin", "#mu_roll", "#damping", "#masses", "#mu_static", "#caps"]
    assert page.is_visible("#view-key") and "path of the contact point" in page.inner_text(
        "#view-key"
    )
    assert all(page.is_visible(sel) for sel in advanced)
    assert not page.is_visible("#guide")
    page.check("#classroom")
    assert page.url.endswith("?classroom=1")
    assert not any(page.is_visible(sel) for sel in advanced)
    assert page.is_visible("#guide") and page.is_visible("#spin") and page.is_visible("#mu")
    set_control(page, "#spin", "5")
    assert page.inner_text("#status") == "ready"
    page.screenshot(path=str(shots / "explore-classroom.png"))
    page.reload()  # the address keeps it
    page.wait_for_function("window.explorer && window.explorer.ready", timeout=60_000)
    assert page.is_checked("#classroom") and not page.is_visible("#damping")
    page.uncheck("#classroom")
    assert "classroom" not in page.url and page.is_visible("#damping")
    set_control(page, "#spin", "-5")
    assert page.inner_text("#status").endswith(" ms")
    assert page.errors == []


def test_plot_ticks_are_round_human_numbers(page):
    """Each plot shows at least three round tick values; a toy's energy (under a
    hundredth of a joule) in mJ rather than in powers of ten."""
    set_control(page, "#mu", "0.3")
    for sel in ("#plot-spin", "#plot-tilt", "#plot-energy", "#plot-slip"):
        ticks = page.eval_on_selector(sel, "c => c._ticks")
        assert len(ticks) >= 3, (sel, ticks)
    energy = page.evaluate(
        "Math.max(...window.explorer.run.energy.filter(Number.isFinite))"
    )
    assert energy < 0.1
    ticks = page.eval_on_selector("#plot-energy", "c => c._ticks")
    assert max(abs(t) for t in ticks) >= 0.1  # shown in mJ
    assert all(len(str(t).replace("-", "").replace(".", "")) <= 4 for t in ticks)


def test_the_map_legend_lists_what_the_map_shows(page):
    page.select_option("#map-x-param", "spin")
    page.select_option("#map-y-param", "delta_deg")
    for sel, value in (("#map-x-num", "5"), ("#map-y-num", "3"), ("#map-levels", "0")):
        page.fill(sel, value)
    page.fill("#map-x-start", "2")
    page.fill("#map-x-stop", "10")
    page.fill("#map-y-start", "2")
    page.fill("#map-y-stop", "6")
    set_control(page, "#t_end", "1")
    set_control(page, "#mu", "inf")  # rolling: the map shows the linear stability
    page.click("#map-go")
    page.wait_for_function(
        "window.explorer.map && window.explorer.map.done && "
        "window.explorer.map.x.values.length === 5",
        timeout=60_000,
    )
    page.wait_for_timeout(200)
    m = page.evaluate("window.explorer.map")
    present = {m["outcome_names"][o] for row in m["outcome"] for o in row}
    legend = page.inner_text("#map-legend")
    for name in m["outcome_names"]:
        assert (name.replace("_", " ") in legend) == (name in present), (name, legend)
    unstable = any(u == 1 for row in m["unstable"] for u in row)
    assert unstable  # rolling, misaligned: steady spin is unstable somewhere
    assert ("hatched: steady spin unstable" in legend) == unstable
    assert page.errors == []


def test_the_default_map_works_for_a_preset_body(page):
    """A preset's misalignment is its own: choosing one turns a map axis over δ into μ,
    and the map computes."""
    page.select_option("#map-x-param", "spin")
    page.select_option("#map-y-param", "delta_deg")
    page.select_option("#preset", "kane_levinson")
    assert page.input_value("#map-y-param") == "mu"
    for sel, value in (("#map-x-num", "5"), ("#map-y-num", "3"), ("#map-levels", "0")):
        page.fill(sel, value)
    set_control(page, "#t_end", "1")
    page.click("#map-go")
    page.wait_for_function(
        "window.explorer.map && window.explorer.map.done && "
        "window.explorer.map.y.param === 'mu'",
        timeout=60_000,
    )
    assert page.inner_text("#err-map") == ""
    page.select_option("#preset", "custom")
    assert page.errors == []
