"""Hostile bodies and slow clients against a live server: /healthz latency, peak memory,
connections held. Optionally against an older checkout in the same run (before/after).

For each server (this checkout, and ``--before DIR``: another checkout of plotgate, e.g.
``git worktree add /tmp/before a77bbb9``), one ``plotgate serve`` subprocess:

1. each absurd body of tests/service/test_adversarial_bodies.py (about 60 MiB) is posted
   while another process times ``GET /healthz`` every 5 ms; the worst and the 99th
   percentile are reported per body, and the server's peak RSS (VmHWM) over all of them;
2. the heaviest legal body (a gate test with 100,000 Cartesian candidates, 8.9 MB) the
   same way;
3. ``--half-sent`` connections send half a body and stop; after the body deadline (2 s)
   plus 3 s, how many the server still holds open.

    python bench/bench_bodies.py [--before DIR] [--half-sent 2000]
    python bench/bench_bodies.py --quick     # no legal body, 100 half-sent connections (CI)

Ends with the ``SUMMARY`` lines of the front table (bench/README.md), for this checkout:
/healthz's worst wait during the absurd bodies, the peak RSS against the body size, and the
half-sent connections still held.
"""

import argparse
import json
import resource
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.service.test_adversarial_bodies import SHAPES  # noqa: E402
from tests.support.servers import serve  # noqa: E402

_WATCH = """
import sys, time, httpx
url, stop_file = sys.argv[1], sys.argv[2]
times = []
with httpx.Client(base_url=url, timeout=30) as http:
    while True:
        started = time.perf_counter()
        http.get("/healthz")
        times.append(time.perf_counter() - started)
        try:
            open(stop_file).close()
            break
        except FileNotFoundError:
            time.sleep(0.005)
print(" ".join(map(str, times)))
"""


def _peak_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise KeyError("VmHWM")


def _post_timed(url: str, body: bytes, tmp: Path) -> tuple[int, float, float, float]:
    """Status, seconds to answer, worst and p99 /healthz latency (ms) meanwhile."""
    stop = tmp / "stop"
    stop.unlink(missing_ok=True)
    watcher = subprocess.Popen(
        [sys.executable, "-c", _WATCH, url, str(stop)], stdout=subprocess.PIPE, text=True
    )
    time.sleep(0.3)
    started = time.perf_counter()
    try:
        status = httpx.post(
            url + "/v1/gates/test",
            content=body,
            timeout=600,
            headers={"content-type": "application/json"},
        ).status_code
    except httpx.HTTPError as exc:
        status = type(exc).__name__
    took = time.perf_counter() - started
    stop.touch()
    times = sorted(float(t) * 1e3 for t in watcher.communicate()[0].split())
    return status, took, times[-1], times[int(0.99 * (len(times) - 1))]


def _held(url: str, n: int) -> int:
    """Open ``n`` connections that send half a body; how many are open 5 s later."""
    port = int(url.rsplit(":", 1)[1])
    body = b'{"gate": {"kind": "ring", "tau": 1, "v_max": 1}, "first": {}}'
    head = (
        b"POST /v1/gates/test HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\n"
        b"content-length: %d\r\n\r\n" % len(body)
    )
    conns = []
    for _ in range(n):
        conn = socket.create_connection(("127.0.0.1", port))
        conn.sendall(head + body[: len(body) // 2])
        conns.append(conn)
    time.sleep(5.0)
    held = 0
    for conn in conns:
        conn.setblocking(False)
        try:
            while conn.recv(65536):
                pass
        except BlockingIOError:
            held += 1  # open, nothing more to read
        except OSError:
            pass
        conn.close()
    return held


def _legal_body() -> bytes:
    plot = {"frame": "cartesian", "x": 1.5, "y": 2.5, "covariance": [[1.0, 0.0], [0.0, 1.0]]}
    return json.dumps(
        {
            "gate": {"kind": "ring", "tau": 1.0, "v_max": 1.0},
            "first": plot,
            "candidates": [plot] * 100_000,
        }
    ).encode()


def _run(name: str, src: Path, half_sent: int, legal: bool = True) -> dict[str, float]:
    """Print the server's table; return its figures (the worst /healthz wait in ms over the
    absurd bodies, the peak RSS in MiB and as a multiple of the body size, held bodies)."""
    with (
        tempfile.TemporaryDirectory() as tmp,
        serve(
            Path(tmp) / "recordings",
            env={"PLOTGATE_BODY_TIMEOUT_S": "2"},
            log=Path(tmp) / "server.log",
            source=src,
        ) as (proc, url),
    ):
        print(f"\n### {name} ({src})\n")
        print("| body | MiB | status | answered in, s | /healthz worst, ms | p99, ms |")
        print("|---|---:|---:|---:|---:|---:|")
        sizes, worsts = [], []
        for shape, (body, _) in SHAPES.items():
            status, took, worst, p99 = _post_timed(url, body, Path(tmp))
            sizes.append(len(body))
            worsts.append(worst)
            print(
                f"| {shape} | {len(body) / 2**20:.0f} | {status} | {took:.2f} | "
                f"{worst:.0f} | {p99:.0f} |"
            )
        peak = _peak_mib(proc.pid)
        if legal:
            body = _legal_body()
            status, took, worst, p99 = _post_timed(url, body, Path(tmp))
            print(
                f"| legal: 100,000 candidates | {len(body) / 2**20:.1f} | {status} | "
                f"{took:.2f} | {worst:.0f} | {p99:.0f} |"
            )
        print(
            f"\npeak RSS over the absurd bodies: {peak:.0f} MiB = "
            f"{peak * 2**20 / statistics.mean(sizes):.1f} x the body size"
        )
        print(f"peak RSS after the legal body too: {_peak_mib(proc.pid):.0f} MiB")
        held = _held(url, half_sent) if half_sent else 0
        if half_sent:
            print(f"half-sent bodies still held 5 s later: {held} of {half_sent}")
    ratio = peak * 2**20 / statistics.mean(sizes)
    return {"worst_ms": max(worsts), "peak_mib": peak, "ratio": ratio, "held": held}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, help="an older plotgate checkout to compare")
    parser.add_argument("--half-sent", type=int, default=2000)
    parser.add_argument(
        "--quick", action="store_true", help="no legal body, 100 half-sent connections (CI)"
    )
    args = parser.parse_args()
    if args.quick:
        args.half_sent = 100
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, max(soft, 4 * args.half_sent)), hard))
    before = None if args.before is None else _run("before", args.before.resolve(), args.half_sent)
    after = _run("after", ROOT, args.half_sent, legal=not args.quick)
    print()
    peer = f"the checkout {args.before}, same run" if before else "—"

    def vs(key: str, unit: str) -> str:
        return f"{after[key]:.{1 if unit == 'x' else 0}f}{unit}" + (
            f" (peer {before[key]:.{1 if unit == 'x' else 0}f}{unit})" if before else ""
        )

    absurd = f"{len(SHAPES)} absurd bodies of about 60 MiB posted to a live server"
    summary("bodies.healthz", absurd + ": GET /healthz's worst wait", peer, vs("worst_ms", " ms"),
            "—", None)  # fmt: skip
    summary("bodies.peak_rss", absurd + ": the server's peak RSS over the body size", peer,
            vs("ratio", "x"), "—", None)  # fmt: skip
    summary(
        "bodies.half_sent",
        f"{args.half_sent} connections that send half a body: held 5 s after the 2 s deadline",
        peer,
        vs("held", ""),
        "0",
        after["held"] == 0,
    )


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    main()
