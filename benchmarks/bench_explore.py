"""Load on `rattlesweep explore`: simulated classroom sessions changing a control once a
second.

Starts ``rattlesweep explore --no-browser --port 0`` as its own process, then drives
``--sessions`` sessions (default 30) from threads of this process: each changes the
spin (a new value each time) once a second, at its own phase, for ``--seconds`` (default
60), and waits for the updated run to arrive and be parsed (``json.loads`` of the whole
run). Prints the median and 95th percentile of the time from the change to the parsed
run (and how much of it the run waited for a worker), the number of changes superseded
or refused, the runs per second served, the server's CPU time per run (what it costs an
otherwise idle machine, whatever else loads this one) and its peak resident memory
(VmHWM).

    .venv/bin/python benchmarks/bench_explore.py            # 30 sessions x 60 s
    .venv/bin/python benchmarks/bench_explore.py --quick    # 30 sessions x 10 s
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request


def peak_rss_mib(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) of a process so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def session(
    url: str, name: str, seconds: float, settings: dict, out: list, lock: threading.Lock
) -> None:
    rng = random.Random(name)
    time.sleep(rng.random())  # its own phase within the second
    start = time.monotonic()
    k = 0
    # a browser of its own: the server's session token comes back in a cookie
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor())
    while time.monotonic() - start < seconds:
        due = start + k
        k += 1
        body = json.dumps(
            {
                "session": name,
                "settings": {**settings, "spin": round(rng.uniform(-20, 20), 2)},
            }
        ).encode()
        req = urllib.request.Request(
            url + "api/run",
            data=body,
            headers={"Content-Type": "application/json", "Accept-Encoding": "gzip"},
        )
        t0 = time.perf_counter()
        try:
            with opener.open(req, timeout=60) as r:
                raw = r.read()
                if r.headers.get("Content-Encoding") == "gzip":
                    import gzip

                    raw = gzip.decompress(raw)
                data = json.loads(raw)
                status = r.status
                timing = dict(
                    part.strip().split(";dur=")
                    for part in r.headers.get("Server-Timing", "").split(",")
                    if part.strip()
                )
        except urllib.error.HTTPError as e:
            status, data, timing = e.code, None, {}
        dt = time.perf_counter() - t0
        with lock:
            out.append(
                (
                    status,
                    dt,
                    len(data["t"]) if data else 0,
                    float(timing.get("queue", "nan")) / 1000,
                    float(timing.get("compute", "nan")) / 1000,
                )
            )
        time.sleep(max(0.0, due + 1.0 - time.monotonic()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sessions", type=int, default=30)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--quick", action="store_true", help="10 s instead of 60")
    ap.add_argument(
        "--t-end", type=float, default=5.0, help="run length (s) of each change"
    )
    args = ap.parse_args()
    seconds = 10.0 if args.quick else args.seconds
    proc = subprocess.Popen(
        [sys.executable, "-m", "rattlesweep.cli", "explore", "--no-browser", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        url = None
        for line in proc.stdout:
            if "serving at" in line:
                url = line.split("serving at ")[1].split()[0]
                break
        if url is None:
            raise SystemExit("the server did not start")
        with urllib.request.urlopen(url + "api/config") as r:
            settings = {**json.loads(r.read())["defaults"], "t_end": args.t_end}
        out: list = []
        lock = threading.Lock()
        threads = [
            threading.Thread(
                target=session, args=(url, f"s{i}", seconds, settings, out, lock)
            )
            for i in range(args.sessions)
        ]
        cpu0 = cpu_seconds(proc.pid)
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        cpu = cpu_seconds(proc.pid) - cpu0
        peak = peak_rss_mib(proc.pid)
    finally:
        proc.terminate()
        proc.wait(30)

    def pct(values: list, q: float) -> float:
        values = sorted(v for v in values if v == v)
        return (
            values[min(len(values) - 1, int(q * len(values)))] if values else float("nan")
        )

    ok = sorted(row[1] for row in out if row[0] == 200)
    other = [row[0] for row in out if row[0] != 200]
    p95 = pct(ok, 0.95)
    queue = [row[3] for row in out if row[0] == 200]
    compute = [row[4] for row in out if row[0] == 200]
    print(
        f"cores: {len(os.sched_getaffinity(0))}; load average before the end: "
        f"{os.getloadavg()[0]:.2f}"
    )
    print(
        f"{args.sessions} sessions x {seconds:g} s, one change a second, runs of "
        f"t_end = {args.t_end:g} s ({out[0][2] if out else 0} samples sent each)"
    )
    print(
        f"changes: {len(out)}, runs received: {len(ok)} ({len(ok) / wall:.1f}/s), "
        f"superseded or refused: {len(other)}"
    )
    print(
        f"change -> updated run parsed by the client: median "
        f"{1000 * statistics.median(ok):.0f} ms, 95th percentile {1000 * p95:.0f} ms, "
        f"max {1000 * ok[-1]:.0f} ms"
    )
    print(
        f"  of which waiting for a worker: median {1000 * pct(queue, 0.5):.0f} ms, 95th "
        f"percentile {1000 * pct(queue, 0.95):.0f} ms; simulating and packing: median "
        f"{1000 * pct(compute, 0.5):.0f} ms, 95th percentile "
        f"{1000 * pct(compute, 0.95):.0f} ms (the rest: HTTP, threads, the client)"
    )
    print(
        f"server CPU time: {cpu:.1f} s over {wall:.1f} s ({cpu / wall:.2f} cores busy on "
        f"average, {1000 * cpu / max(1, len(ok)):.1f} ms per run: the load it puts on "
        "an otherwise idle machine)"
    )
    print(f"server peak memory (VmHWM): {peak:.0f} MiB")


if __name__ == "__main__":
    main()
