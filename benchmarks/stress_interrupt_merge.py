"""Stress check (not a test): Ctrl-C around the end of a sweep's tiles never hangs it.

Runs ``rattlesweep sweep`` of 300 tiles of 2 short launches (a tile every few
milliseconds) in a subprocess, sends SIGINT at a random instant between 0.05 s before
and 0.3 s after its last tile is written (where the final merge into ``sweep.nc``
starts), and counts the runs that do not exit within ``--hang-after`` seconds (a hang).
A hung process gets SIGUSR1 first, which makes it print every thread's stack
(``faulthandler``) before it is killed; the stacks are printed here.

The last tile's instant: the tiles directory is polled; for a negative offset the
signal is sent when the rate of tiles so far predicts the last one that much later.
The offset actually achieved (signal time minus the last tile file's modification
time) is reported too.

    python benchmarks/stress_interrupt_merge.py --runs 125 --parallel 2

Prints one line per run and a summary: runs, hangs, exit statuses, offsets.
"""

from __future__ import annotations

import argparse
import collections
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from sweep_helpers import MANY_TILES_TOML as CONFIG  # noqa: E402  (the test's sweep)

TILES = 300

# the CLI's entry point, with every thread's stack printed on SIGUSR1
CHILD = (
    "import faulthandler, signal, sys; "
    "faulthandler.register(signal.SIGUSR1, all_threads=True); "
    "from rattlesweep.cli import run; run()"
)


def one_run(
    root: Path, config: Path, offset: float, hang_after: float, workers: int
) -> dict:
    """One sweep interrupted ``offset`` s from its last tile; what happened."""
    out = Path(tempfile.mkdtemp(dir=root))
    shutil.rmtree(out)
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, "sweep", str(config), "--out", str(out)]
        + ["--workers", str(workers), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    tiles = out / "tiles"
    seen: list[tuple[float, int]] = []  # (time, tiles on disk) at each change
    deadline = time.monotonic() + 120
    sent = None
    while proc.poll() is None and time.monotonic() < deadline:
        n = len(list(tiles.glob("tile-*.nc"))) if tiles.is_dir() else 0
        now = time.monotonic()
        if not seen or n != seen[-1][1]:
            seen.append((now, n))
        if offset >= 0 and n == TILES:
            time.sleep(offset)
            sent = time.time()
            break
        if offset < 0 and len(seen) > 5 and n > TILES // 2:
            (t0, n0), (t1, n1) = seen[len(seen) // 2], seen[-1]
            per_tile = (t1 - t0) / max(n1 - n0, 1)
            if (TILES - n) * per_tile <= -offset:
                sent = time.time()
                break
        time.sleep(0.001)
    if sent is None:  # ended before the signal
        proc.communicate()
        return {"offset": offset, "status": proc.returncode, "hang": False, "late": True}
    proc.send_signal(signal.SIGINT)
    t_signal = time.monotonic()
    hang = False
    try:
        stdout, stderr = proc.communicate(timeout=hang_after)
    except subprocess.TimeoutExpired:
        hang = True
        proc.send_signal(signal.SIGUSR1)
        time.sleep(2)
        proc.kill()
        stdout, stderr = proc.communicate()
    stopped = time.monotonic() - t_signal
    mtimes = [p.stat().st_mtime for p in tiles.glob("tile-*.nc")] if tiles.is_dir() else []
    achieved = sent - max(mtimes) if len(mtimes) == TILES else None
    result = {
        "offset": offset,
        "achieved": achieved,
        "status": proc.returncode,
        "hang": hang,
        "stopped_s": stopped,
        "merged": (out / "sweep.nc").exists(),
        "last_err": (stderr.strip().splitlines() or [""])[-1],
        "stderr": stderr if hang else "",
    }
    if not hang:
        shutil.rmtree(out, ignore_errors=True)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=50, help="interrupts in all")
    parser.add_argument("--parallel", type=int, default=1, help="processes at once")
    parser.add_argument("--workers", type=int, default=2, help="threads per sweep")
    parser.add_argument("--hang-after", type=float, default=20.0)
    parser.add_argument("--seed", type=int, default=None)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    root = Path(tempfile.mkdtemp(prefix="stress-interrupt-"))
    config = root / "many.toml"
    config.write_text(CONFIG)
    offsets = [rng.uniform(-0.05, 0.3) for _ in range(args.runs)]
    results: list[dict] = []
    lock = threading.Lock()

    def worker() -> None:
        while True:
            with lock:
                if not offsets:
                    return
                offset = offsets.pop()
            r = one_run(root, config, offset, args.hang_after, args.workers)
            with lock:
                results.append(r)
                achieved = "    ?" if r.get("achieved") is None else f"{r['achieved']:+.3f}"
                print(
                    f"{len(results):4d} offset {r['offset']:+.3f} achieved {achieved} "
                    f"status {r['status']} hang {r['hang']} "
                    f"stopped {r.get('stopped_s', 0):.2f} s  {r.get('last_err', '')}",
                    flush=True,
                )
                if r["hang"]:
                    print(r["stderr"], flush=True)

    t0 = time.monotonic()
    threads = [threading.Thread(target=worker) for _ in range(args.parallel)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    interrupted = [r for r in results if not r.get("late")]
    statuses = collections.Counter(r["status"] for r in interrupted)
    achieved = sorted(r["achieved"] for r in interrupted if r.get("achieved") is not None)
    print(
        f"\n{len(interrupted)} interrupts ({len(results) - len(interrupted)} runs ended "
        f"before the signal) in {time.monotonic() - t0:.0f} s: "
        f"{sum(r['hang'] for r in interrupted)} hangs (no exit within "
        f"{args.hang_after:g} s); statuses {dict(statuses)}; merged file present in "
        f"{sum(r['merged'] for r in interrupted)}; slowest stop "
        f"{max((r['stopped_s'] for r in interrupted), default=0):.2f} s"
    )
    stops = sorted(r["stopped_s"] for r in interrupted)
    if stops:
        print(
            f"seconds from the signal to the exit: median {stops[len(stops) // 2]:.2f}, "
            f"95th percentile {stops[int(0.95 * (len(stops) - 1))]:.2f}, "
            f"most {stops[-1]:.2f}"
        )
    kinds = collections.Counter(  # the last line, less paths and counts
        re.sub(r"\d+", "N", re.sub(r"`?\S*/\S*", "OUT", r["last_err"])) for r in interrupted
    )
    print("last lines:", dict(kinds))
    if achieved:
        print(
            f"achieved offsets from the last tile: {achieved[0]:+.3f} .. "
            f"{achieved[-1]:+.3f} s, median {achieved[len(achieved) // 2]:+.3f} s"
        )
    shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
