"""run_batch(parallel=True) called from several threads at once, under numba's workqueue
threading layer (the one numba falls back to without TBB or OpenMP, which is not
thread-safe): the calls take turns, and every result equals the serial one."""

import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import threading
    import numba
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
    assert numba.threading_layer() == "workqueue", numba.threading_layer()
    assert not errors, errors
    assert len(results) == 45
    for ds in results:
        assert (ds.final_spin.values == serial.final_spin.values).all()
    print("ok")
""")


def test_parallel_run_batch_from_three_threads_under_workqueue():
    env = {**os.environ, "NUMBA_THREADING_LAYER": "workqueue", "NUMBA_NUM_THREADS": "2"}
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=300
    )
    # without the lock numba aborts the process: "The workqueue threading layer is not
    # threadsafe and may not be accessed concurrently by multiple threads"
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "ok"
