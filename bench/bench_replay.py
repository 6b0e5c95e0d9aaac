"""How fast a recording is replayed, against how fast the server answered it.

The recording is written by the service itself: ``plotgate serve`` on a free loopback port,
recording into a temporary folder, is sent ``--exchanges`` gates.test requests of
bench_reading's shape (one first mark, 100 candidates) over ``--connections`` keep-alive
connections, then stopped (its clean shutdown finishes the files). Sending them gives the
server's own answering rate for these requests, two ways:

- by the wall clock of the sending (the client shares the machine's two cores);
- by the server's CPU time (/proc): its cost per request, whatever the load.

Then, best of ``--repeat`` each:

- **reading**: :class:`plotgate.clients.recordings.Reader` over the folder, every exchange
  parsed, checked and paired;
- **in-process replay**: :func:`plotgate.clients.replay.replay`, the ``plotgate replay`` code
  path, in this process (imports already paid); and again with the rules of
  ``docs/replay_tolerances.toml`` (``--tolerances``: a rule looked up per field walked);
- **plotgate replay**: the command in a subprocess, as a user runs it: wall time with its
  imports, and its peak RSS;
- **fleet replay**: :func:`plotgate.clients.fleet.fleet_replay` on ``--workers`` local Dask
  workers, cluster start included, its report checked equal to the in-process one
  (bench/bench_fleet_replay.py times it at scale, against 1 worker).

    python bench/bench_replay.py [--exchanges 15000 --connections 4 --repeat 3] [--quick]

``--quick`` replays 500 exchanges, best of two (the first pays the imports; CI: it asserts
no times). The last line is the front table's row (``SUMMARY {json}``): the in-process
replay's wall-clock rate against the server's (the sending's wall-clock) in the same run;
the aim is at least the server's rate, and at least 1,329 exchanges/s (three times the rate
before issue 25).
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import httpx

from plotgate.clients.recordings import Reader
from plotgate.clients.replay import ReplayReport, replay
from plotgate.clients.tolerances import load_rules

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.support.servers import serve  # noqa: E402 - after the sys.path line

OPERATION, PATH = "gates.test", "/v1/gates/test"
AIM = 1_329
"""Exchanges per second of wall-clock the in-process replay aims at, at least (issue 40)."""


def body() -> bytes:
    """bench_reading's request: an ellipse gate, one first mark, 100 candidates."""
    plots = [
        {"frame": "cartesian", "x": 100.0 * i, "y": 5e4, "covariance": [[1e4, 0], [0, 1e4]]}
        for i in range(100)
    ]
    gate = {"kind": "ellipse", "P_G": 0.9}
    return json.dumps({"gate": gate, "first": plots[0], "candidates": plots}).encode()


def cpu_seconds(pid: int) -> float:
    """User plus system CPU seconds of process ``pid`` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def send(url: str, exchanges: int, connections: int) -> float:
    """Post ``exchanges`` requests over ``connections`` keep-alive connections; the wall
    seconds it took. Every answer must be 200."""
    content, counts = body(), [exchanges // connections] * connections
    counts[0] += exchanges - sum(counts)
    failures: list[str] = []

    def post(count: int) -> None:
        with httpx.Client(base_url=url, timeout=60) as http:
            for _ in range(count):
                answer = http.post(PATH, content=content)
                if answer.status_code != 200:
                    failures.append(answer.text[:200])
                    return

    threads = [threading.Thread(target=post, args=(n,)) for n in counts]
    started = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    seconds = time.perf_counter() - started
    if failures:
        raise SystemExit(f"the server refused a request: {failures[0]}")
    return seconds


def record(folder: Path, exchanges: int, connections: int) -> dict[str, float]:
    """Write the recording with the service; the wall seconds of sending and the server's
    CPU seconds answering."""
    folder.mkdir(parents=True, exist_ok=True)
    with serve(folder, log=folder.parent / "server.log", ready_s=300.0) as (proc, url):
        cpu_before = cpu_seconds(proc.pid)
        wall = send(url, exchanges, connections)
        cpu = cpu_seconds(proc.pid) - cpu_before
    return {"wall": wall, "cpu": cpu}


def best(run: Callable[[], object], repeat: int) -> tuple[float, float, object]:
    """Wall and CPU seconds of the run with the least CPU time, and its result."""
    times, result = [], None
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        result = run()
        times.append((time.process_time() - cpu, time.perf_counter() - wall))
    cpu, wall = min(times)
    return wall, cpu, result


def command(folder: Path) -> tuple[float, float, float]:
    """``plotgate replay FOLDER`` in a subprocess: wall and CPU seconds (imports included)
    and peak RSS in MiB."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "-m", "plotgate.clients.cli", "replay", str(folder)],
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - started
    if run.returncode != 0:
        raise SystemExit(f"plotgate replay exited {run.returncode}: {run.stdout[-500:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return seconds, cpu, after.ru_maxrss / 1024


def fleet_replay(folder: Path, workers: int) -> ReplayReport:
    """Fleet replay of ``folder`` on ``workers`` local Dask workers (cluster start
    included)."""
    from plotgate.clients.fleet import fleet_replay as on_cluster

    return on_cluster(folder, local_workers=workers)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=15_000)
    parser.add_argument("--connections", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workers", type=int, default=2, help="fleet replay's Dask workers")
    parser.add_argument("--quick", action="store_true", help="500 exchanges, best of 2 (CI)")
    args = parser.parse_args()
    if args.quick:
        args.exchanges, args.repeat = 500, 2
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "recordings"
        server = record(folder, args.exchanges, args.connections)
        files = sorted(folder.glob("*.mcap"))
        size = sum(f.stat().st_size for f in files)
        n = args.exchanges
        print(f"{n} exchanges in {len(files)} files, {size / 2**20:.1f} MiB")
        rows = [
            (f"server, sent over {args.connections} connections", server["wall"], server["cpu"]),
        ]
        wall, cpu, count = best(lambda: sum(1 for _ in Reader(folder)), args.repeat)
        assert count == n, f"read {count} exchanges of {n}"
        rows.append(("reading (Reader, parsed and paired)", wall, cpu))
        wall, cpu, report = best(lambda: replay(folder, progress=False), args.repeat)
        assert isinstance(report, ReplayReport) and report.unchanged == n, report
        rows.append(("in-process replay (replay())", wall, cpu))
        rules = load_rules(ROOT / "docs" / "replay_tolerances.toml", 1e-9, 1e-12)
        wall, cpu, ruled = best(lambda: replay(folder, progress=False, rules=rules), args.repeat)
        assert isinstance(ruled, ReplayReport) and ruled.unchanged == n, ruled
        rows.append(("in-process replay, docs/replay_tolerances.toml", wall, cpu))
        wall, cpu, rss = command(folder)
        rows.append((f"plotgate replay, imports included (peak RSS {rss:.0f} MiB)", wall, cpu))
        wall, cpu, fleet = best(lambda: fleet_replay(folder, args.workers), 1)
        assert fleet.text() == report.text(), "the fleet's report is not the serial one"
        rows.append((f"fleet replay ({args.workers} local workers; CPU: this process)", wall, cpu))
        table(rows, n)
        summary(n, server["wall"], rows[2][1], rows[2][2])


def summary(n: int, server_wall: float, wall: float, cpu: float) -> None:
    """The front table's row: in-process replay against the server, by the wall clock."""
    rate, server = n / wall, n / server_wall
    row = {
        "row": "replay",
        "workload": f"in-process replay (plotgate replay's path) of {n:,} gates.test "
        "exchanges recorded by plotgate serve (wall)",
        "peer": f"the server answering them over HTTP: {server:,.0f} exchanges/s (wall)",
        "measured": f"{rate:,.0f} exchanges/s, {rate / server:.2f}x the server "
        f"({n / cpu:,.0f}/s of CPU)",
        "aim": f">= 1.00x the server and >= {AIM:,}/s",
        "met": rate >= server and rate >= AIM,
    }
    print("SUMMARY " + json.dumps(row))


def table(rows: list[tuple[str, float, float]], n: int) -> None:
    """Each stage's seconds and rates, and its CPU rate against the server's (the server's
    CPU time is its own; the client that sent the requests is not counted)."""
    print("| stage | wall s | CPU s | exchanges/s (wall) | exchanges/s (CPU) | vs server (CPU) |")
    print("|---|---:|---:|---:|---:|---:|")
    server = n / rows[0][2]
    for name, wall, cpu in rows:
        print(
            f"| {name} | {wall:.2f} | {cpu:.2f} | {n / wall:,.0f} | {n / cpu:,.0f} "
            f"| {n / cpu / server:.2f}x |"
        )


if __name__ == "__main__":
    main()
