"""Ctrl-C while a finished sweep's tiles are checked and merged: status 130 and the line
'rattlesweep: interrupted' (with the state of the output) every time, never a silent
status 0 from an interrupt that a library's cleanup swallowed."""

import signal
import subprocess
import time

from rattlesweep.cli import main
from rattlesweep.sweep._execution.run import RESULT_NAME
from sweep_helpers import start_sweep
from sweep_helpers import MANY_TILES_TOML
from test_safety_interrupt import EXIT_WITHIN


def test_ctrl_c_around_the_merge_always_ends_in_130_with_a_message(tmp_path):
    config = tmp_path / "many.toml"
    config.write_text(MANY_TILES_TOML)
    out = tmp_path / "out"
    assert main(["sweep", str(config), "--out", str(out), "--quiet"]) == 0
    merged = out / RESULT_NAME
    lock = out / ".rattlesweep.lock"
    during = 0
    # the process checks its 300 tiles, then reads them all and writes sweep.nc
    for delay in (0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.45):
        merged.unlink(missing_ok=True)
        proc = start_sweep(config, out, 2)
        deadline = time.monotonic() + 60
        while not lock.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.001)
        time.sleep(delay)
        finished = merged.exists()  # the merge was over before the signal
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=EXIT_WITHIN)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
        if proc.returncode == 0 and finished:
            continue
        during += 1
        assert proc.returncode == 130, (delay, proc.returncode, err)
        last = err.strip().splitlines()[-1]
        assert last.startswith("rattlesweep: interrupted; "), (delay, err)
        assert "Traceback" not in err
        if merged.exists():
            assert "rattlesweep resume" in last or "complete" in last
        else:
            assert f"rattlesweep resume {out}" in last
    assert during >= 4
