"""The explorer's measured-data endpoints: a measurement read and checked against the
caps, and fits refused by name until they can run (the fit itself, through the page, is
in test_explore_browser.py)."""

import json

import numpy as np
import pytest

from rattlesweep.explore.settings import defaults

from explore_helpers import call, serving


@pytest.fixture(scope="module")
def server():
    yield from serving()


def test_a_measurement_is_checked_and_a_fit_is_refused_until_one_is_loaded(server):
    """The measurement endpoint: a Tracker export is read and its turning rate sent
    back (the heading's slope, here a steady -2 rad/s); one over the duration cap is
    refused by the measurement's control; a fit before any measurement, one naming a
    control the page cannot fit, and one while another fit runs are refused by name."""
    t = np.arange(0.0, 4.0, 1 / 30)
    heading = np.degrees(-2.0 * t)
    wrapped = (heading + 180.0) % 360.0 - 180.0
    text = "mass A\nt\tθ\n" + "".join(f"{a:.5f}\t{b:.4f}\n" for a, b in zip(t, wrapped))
    settings = {**defaults(), "preset": "kane_levinson"}

    status, body = call(server, "api/fit", {"settings": settings, "free": ["spin"]}, "m1")
    assert status == 400 and json.loads(body)["error"] == "fit: load a measurement first"

    status, body = call(server, "api/measurement", {"name": "a.txt", "text": text}, "m1")
    assert status == 200, body
    shown = json.loads(body)
    assert shown["kind"] == "heading" and shown["samples"] == len(t)
    rate = np.array([r for r in shown["rate"] if r is not None])
    np.testing.assert_allclose(rate, -2.0, atol=1e-3)

    long_t = np.arange(0.0, 25.0, 1 / 30)
    long_text = "mass A\nt\tθ\n" + "".join(f"{a:.5f}\t0\n" for a in long_t)
    status, body = call(
        server, "api/measurement", {"name": "b.txt", "text": long_text}, "m2"
    )
    answer = json.loads(body)
    assert status == 413 and answer["control"] == "measurement"
    assert "max_fit_t_end = 20 s" in answer["error"]

    status, body = call(server, "api/fit", {"settings": settings, "free": ["mass"]}, "m1")
    assert status == 400 and "'mass' cannot be fitted here" in json.loads(body)["error"]

    app = server.app
    assert app._fitting.acquire(blocking=False)  # a fit of another user is running
    try:
        status, body = call(
            server, "api/fit", {"settings": settings, "free": ["spin"]}, "m1"
        )
    finally:
        app._fitting.release()
    assert status == 503 and "another fit is running" in json.loads(body)["error"]


def test_gyroscope_data_offer_the_phone_s_yaw_and_late_data_are_refused(server):
    from rattlesweep.fitting.measurement import PHYPHOX_HEADER

    def text(t0):
        rows = [f"{t0 + 0.01 * k},0.1,0.0,-3.0,3.0" for k in range(300)]
        return PHYPHOX_HEADER + "\n" + "\n".join(rows) + "\n"

    status, body = call(
        server, "api/measurement", {"name": "g.csv", "text": text(0.0)}, "y"
    )
    assert status == 200 and "sensor_yaw_deg" in json.loads(body)["free"]
    status, body = call(
        server, "api/measurement", {"name": "g.csv", "text": text(12.3)}, "y"
    )
    answer = json.loads(body)
    assert status == 400 and answer["control"] == "measurement"
    assert (
        "the recording starts at t = 12.3 s: time zero must be the release"
        in answer["error"]
    )
