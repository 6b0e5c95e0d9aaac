"""How soon ``plotgate serve`` answers from an empty kernel cache (a first start: numba
compiles every kernel) and from the cache that start wrote: its first ``/healthz``, the
README's first gate test answered 200, and every operation's kernels ready (``/readyz``
listing none still compiling), with the latency of ``/healthz`` meanwhile.

Each start is a new ``plotgate serve`` on a free loopback port, recording to a scratch
folder, with ``NUMBA_CACHE_DIR`` pointed at a scratch folder that is empty for the first
start; its stderr lines (the warm-up's progress) are printed with their times. The load
average is printed before and after: on a shared machine the compile times scale with it.

    python bench/bench_first_start.py --warm 1
    python bench/bench_first_start.py --warm 0 --ready-within 120  # the first two only
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.support.servers import free_port  # noqa: E402 - after the sys.path line

TIMEOUT_S = 1800.0  # a hang, not a figure (--ready-within sets a shorter wait)
POLL_S = 0.2


def first_gate_test() -> dict[str, object]:
    """The README's first call (``curl ... /v1/gates/test``), read from the README."""
    readme = (ROOT / "README.md").read_text()
    match = re.search(r"curl -s \S+/v1/gates/test .*?-d '(\{.*?\})'", readme, re.DOTALL)
    assert match, "the README's first gate test was not found"
    body: dict[str, object] = json.loads(match.group(1))
    return body


def start(cache: Path, recordings: Path, ready_within_s: float) -> dict[str, float]:
    """Seconds from launching ``plotgate serve`` to its first ``/healthz`` 200, to the
    README's gate test answered 200 and to every operation ready (absent when not within
    ``ready_within_s``); the largest and the median ``/healthz`` latency until then, ms."""
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    command = [sys.executable, "-m", "plotgate.clients.cli", "serve", "--port", str(port)]
    started = time.monotonic()
    server = subprocess.Popen(
        [*command, "--log-dir", str(recordings)],
        env={**os.environ, "NUMBA_CACHE_DIR": str(cache)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )

    def echo() -> None:
        assert server.stderr is not None
        for line in server.stderr:
            print(f"  [{time.monotonic() - started:6.1f} s] {line.rstrip()}", flush=True)

    threading.Thread(target=echo, daemon=True).start()
    times: dict[str, float] = {}
    gate: dict[str, float] = {}

    def call_gate() -> None:  # waits for its kernels, as a user's first call would
        r = httpx.post(f"{url}/v1/gates/test", json=first_gate_test(), timeout=TIMEOUT_S)
        assert r.status_code == 200, r.text
        gate["s"] = time.monotonic() - started

    latencies: list[float] = []
    try:
        while time.monotonic() - started < ready_within_s and "ready" not in times:
            assert server.poll() is None, f"plotgate serve stopped with {server.returncode}"
            sent = time.monotonic()
            try:
                health = httpx.get(f"{url}/healthz", timeout=30)
            except httpx.TransportError:
                time.sleep(POLL_S)
                continue
            if health.status_code == 200:
                latencies.append((time.monotonic() - sent) * 1e3)
                if "healthz" not in times:
                    times["healthz"] = time.monotonic() - started
                    threading.Thread(target=call_gate, daemon=True).start()
                ready = httpx.get(f"{url}/readyz", timeout=30).json()
                if not ready["operations"]["compiling"]:
                    times["ready"] = time.monotonic() - started
            time.sleep(POLL_S)
        while "s" not in gate and time.monotonic() - started < TIMEOUT_S:
            time.sleep(0.05)
        times["gate_test"] = gate["s"]
        times["healthz_max_ms"] = max(latencies)
        times["healthz_median_ms"] = statistics.median(latencies)
        return times
    finally:
        server.terminate()
        server.wait(timeout=60)


def _line(label: str, t: dict[str, float], ready_within_s: float) -> str:
    ready = f"{t['ready']:.1f} s" if "ready" in t else f"not within {ready_within_s:.0f} s"
    return (
        f"{label}: /healthz after {t['healthz']:.1f} s, the README's gate test 200 after "
        f"{t['gate_test']:.1f} s, every kernel ready after {ready}; /healthz "
        f"latency meanwhile median {t['healthz_median_ms']:.0f} ms, max "
        f"{t['healthz_max_ms']:.0f} ms"
    )


def _load() -> str:
    return " ".join(f"{v:.1f}" for v in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--warm", type=int, default=1, help="warm starts after the cold one")
    parser.add_argument(
        "--ready-within",
        type=float,
        default=TIMEOUT_S,
        help=f"longest wait for every kernel, s (default {TIMEOUT_S:g}); a cold start cut "
        "short leaves the warm starts part of the cache to load",
    )
    args = parser.parse_args()
    within = args.ready_within
    with tempfile.TemporaryDirectory(prefix="plotgate-first-start-") as scratch:
        cache, recordings = Path(scratch) / "numba-cache", Path(scratch) / "recordings"
        cache.mkdir()
        print(f"load average before (1, 5, 15 min): {_load()}")
        print(_line("empty cache", start(cache, recordings, within), within), flush=True)
        print(f"load average (1, 5, 15 min): {_load()}")
        for _ in range(args.warm):
            print(_line("warm cache", start(cache, recordings, within), within), flush=True)
        print(f"load average after (1, 5, 15 min): {_load()}")


if __name__ == "__main__":
    main()
