"""How long ``plotgate serve`` takes to answer ``/healthz``: from an empty kernel cache (a
first start: numba compiles every kernel) and from the cache that start wrote.

Each start is a new ``plotgate serve`` on a free loopback port, recording to a scratch
folder, with ``NUMBA_CACHE_DIR`` pointed at a scratch folder that is empty for the first
start; its stderr lines are printed with their times, so the announcement of the
compilation and its "kernels ready in N s" are timed too.

    python bench/bench_first_start.py --warm 2
"""

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.servers import free_port  # noqa: E402 - after the sys.path line

TIMEOUT_S = 900.0  # a hang, not a figure


def start(cache: Path, recordings: Path) -> float:
    """Seconds from launching ``plotgate serve`` to its first ``/healthz`` 200."""
    port = free_port()
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
    try:
        while time.monotonic() - started < TIMEOUT_S:
            assert server.poll() is None, f"plotgate serve stopped with {server.returncode}"
            try:
                if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                    return time.monotonic() - started
            except httpx.TransportError:
                pass
            time.sleep(0.1)
        raise TimeoutError(f"no /healthz answer in {TIMEOUT_S} s")
    finally:
        server.terminate()
        server.wait(timeout=60)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--warm", type=int, default=2, help="warm starts after the cold one")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="plotgate-first-start-") as scratch:
        cache, recordings = Path(scratch) / "numba-cache", Path(scratch) / "recordings"
        cache.mkdir()
        print(f"load average before: {os.getloadavg()[0]:.1f}")
        cold = start(cache, recordings)
        print(f"empty cache: /healthz after {cold:.1f} s")
        for _ in range(args.warm):
            print(f"warm cache: /healthz after {start(cache, recordings):.1f} s")
        print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
