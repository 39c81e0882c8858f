"""run_batch(parallel=True) called from several threads at once, each spreading its
blocks over threads of its own: every result equals the serial one, and a Ctrl-C during
a long parallel batch stops it between pieces."""

import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import threading
    import numpy as np
    import rattlesweep as rs

    toy = rs.Body.preset("toy")
    spins = np.linspace(1.0, 5.0, 64)
    serial = rs.run_batch(toy, spin=spins, t_end=0.05, parallel=False)
    results, errors = [], []

    def go():
        try:
            for _ in range(15):
                results.append(rs.run_batch(toy, spin=spins, t_end=0.05))
        except Exception as exc:
            errors.append(exc)

    threads = [threading.Thread(target=go) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert len(results) == 45
    for ds in results:
        assert (ds.final_spin.values == serial.final_spin.values).all()
    print("ok")
""")


def test_parallel_run_batch_from_three_threads():
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "ok"


INTERRUPTED = textwrap.dedent("""
    import os, signal, threading, time
    import numpy as np
    import rattlesweep as rs

    toy = rs.Body.preset("toy")
    spins = np.linspace(1.0, 5.0, 2048)
    rs.run_batch(toy, spin=spins[:64], t_end=0.01, threads=2)  # loaded, not timed
    began = time.perf_counter()
    rs.run_batch(toy, spin=spins, t_end=60.0, threads=2)
    whole = time.perf_counter() - began
    threading.Timer(whole / 4, os.kill, (os.getpid(), signal.SIGINT)).start()
    began = time.perf_counter()
    try:
        rs.run_batch(toy, spin=spins, t_end=60.0, threads=2)
    except KeyboardInterrupt:
        print(whole, time.perf_counter() - began)
""")


def test_a_ctrl_c_stops_a_parallel_batch_between_pieces():
    """The batch is cut into about 8 pieces per thread: a Ctrl-C a quarter of the way
    through ends it well before the whole batch's time."""
    proc = subprocess.run(
        [sys.executable, "-c", INTERRUPTED], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    whole, stopped = map(float, proc.stdout.split())
    assert stopped < 0.6 * whole, (whole, stopped)
