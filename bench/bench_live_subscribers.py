"""Slow live view subscribers against the publisher's memory and the API's latency.

``plotgate serve --foxglove-port P`` with N clients connected to the live view (through its
gate), each subscribed to ``/scene/gates.test`` and then never reading again (a receive
buffer of 4 KiB, so the sends back up at once). One HTTP client then sends gate tests one
at a time: each answer is drawn and offered to every stalled subscriber. Reported: the
publisher process's resident memory before the subscribers, after them, and after the
requests; the HTTP latency percentiles with the subscribers connected; the scenes the gate
dropped for slow clients.

The aim (issue 35): with 300 subscribers the publisher grows at most 150 MB and the other
clients' p50 stays under 100 ms.

    nice .venv/bin/python bench/bench_live_subscribers.py --subscribers 300 --requests 2000
    python bench/bench_live_subscribers.py --quick     # 10 subscribers, 100 requests (CI)

Ends with the ``SUMMARY`` lines of the front table (bench/README.md): the publisher's growth
and the HTTP p50 against the aims (judged at 300 subscribers only).
"""

import argparse
import json
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plotgate.service.table import ENDPOINTS  # noqa: E402
from tests.support.live_clients import stalled_subscriber  # noqa: E402
from tests.support.servers import free_port, serve  # noqa: E402

AIM_SUBSCRIBERS, AIM_GROWTH_MB, AIM_P50_MS = 300, 150, 100
"""Issue 35's aim: with 300 stalled subscribers, growth and p50 within these."""


def _publisher(server_pid: int) -> int:
    """The pid of the server's live view publisher (its spawned child)."""
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            text = status.read_text()
            cmdline = (status.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if f"\nPPid:\t{server_pid}\n" in text and b"spawn_main" in cmdline:
            return int(status.parent.name)
    raise RuntimeError("no publisher process")


def _rss_mb(pid: int) -> float:
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+)", text).group(1)) / 1024  # type: ignore[union-attr]


def _metric(text: str, name: str) -> float:
    found = re.search(rf"^{name} (\S+)$", text, re.M)
    return float(found.group(1)) if found else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subscribers", type=int, default=300)
    parser.add_argument("--requests", type=int, default=2000)
    parser.add_argument("--quick", action="store_true", help="10 subscribers, 100 requests (CI)")
    args = parser.parse_args()
    if args.quick:
        args.subscribers, args.requests = 10, 100
    port = free_port()
    env = {"PLOTGATE_LIVE_MAX_CLIENTS": str(args.subscribers + 10)}
    with (
        tempfile.TemporaryDirectory() as folder,
        serve(Path(folder), "--foxglove-port", str(port), env=env, ready_s=300) as (proc, url),
    ):
        publisher = _publisher(proc.pid)
        before = _rss_mb(publisher)
        stalled = [stalled_subscriber(port, "/scene/gates.test") for _ in range(args.subscribers)]
        connected = _rss_mb(publisher)
        body = ENDPOINTS["gates.test"].example_body
        latencies = []
        peak = connected
        with httpx.Client(base_url=url, timeout=60) as client:
            for i in range(args.requests):
                started = time.perf_counter()
                assert client.post("/v1/gates/test", json=body).status_code == 200
                latencies.append(time.perf_counter() - started)
                if i % 100 == 0:
                    peak = max(peak, _rss_mb(publisher))
            time.sleep(2)  # the publisher draws what is queued
            peak = max(peak, _rss_mb(publisher))
            metrics = client.get("/metrics").text
        for sock in stalled:
            sock.close()
    quantiles = statistics.quantiles(latencies, n=100)
    print(
        f"| {args.subscribers} | {args.requests} | {before:.0f} | {connected:.0f} | {peak:.0f} "
        f"| {peak - before:.0f} | {quantiles[49] * 1e3:.2f} | {quantiles[98] * 1e3:.2f} "
        f"| {_metric(metrics, 'plotgate_foxglove_client_dropped_total'):.0f} "
        f"| {_metric(metrics, 'plotgate_foxglove_published_total'):.0f} |"
    )
    judged = args.subscribers == AIM_SUBSCRIBERS
    workload = f"{args.subscribers} stalled live view subscribers, {args.requests} gate tests"
    print()
    summary(
        "live_subscribers.memory",
        workload + ": the publisher's growth",
        "—",
        f"{peak - before:.0f} MB",
        f"<= {AIM_GROWTH_MB} MB at {AIM_SUBSCRIBERS}",
        peak - before <= AIM_GROWTH_MB if judged else None,
    )
    summary(
        "live_subscribers.p50",
        workload + ": the HTTP client's p50",
        "—",
        f"{quantiles[49] * 1e3:.2f} ms",
        f"< {AIM_P50_MS} ms at {AIM_SUBSCRIBERS}",
        quantiles[49] * 1e3 < AIM_P50_MS if judged else None,
    )


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    main()
