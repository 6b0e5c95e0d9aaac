"""Real servers for the tests and benchmarks that need one: ``plotgate serve`` in a
subprocess, any ASGI app under uvicorn in a thread, or a Dask cluster that loses a
worker."""

import contextlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import uvicorn

__all__ = ["free_port", "health_watch", "losing_a_worker", "serve", "serving"]


def free_port() -> int:
    """A loopback port nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def serve(
    log_dir: Path,
    *args: str,
    preexec_fn: Callable[[], None] | None = None,
    env: dict[str, str] | None = None,
    log: Path | None = None,
    source: Path | None = None,
    ready_s: float = 30.0,
    warm: bool = True,
) -> Iterator[tuple[subprocess.Popen, str]]:
    """Run ``plotgate serve`` as a subprocess on a loopback port until it is ready.

    ``preexec_fn`` runs in the child before the server starts (e.g. to set rlimits); ``env``
    adds environment variables (``PLOTGATE_*`` settings); ``log`` keeps the server's
    output (its logs, the access log included) in that file; ``source`` runs the server
    from another checkout (its folder goes first on ``PYTHONPATH``), by default this one;
    ``ready_s`` is the longest wait for ``/readyz`` (a bench on a loaded machine waits more).
    ``warm`` (the default) waits, up to :data:`WARM_S` more, until ``/readyz`` lists no
    operation still compiling, so a test's timings are of a server whose kernels are loaded
    (``serve`` answers while its warm-up loads them: :mod:`plotgate.service.warmup`).
    """
    port = free_port()
    stderr = open(log, "wb") if log is not None else subprocess.PIPE  # noqa: SIM115
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "plotgate.clients.cli",
            "serve",
            "--port",
            str(port),
            "--log-dir",
            str(log_dir),
            *args,
        ],
        cwd=source or Path(__file__).resolve().parents[2],
        env={**os.environ, **({"PYTHONPATH": str(source)} if source else {}), **(env or {})},
        stdout=stderr if log is not None else subprocess.DEVNULL,
        stderr=stderr,
        preexec_fn=preexec_fn,
    )
    if log is not None:
        stderr.close()  # the child has its own copy
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + ready_s
    try:
        while True:
            assert proc.poll() is None, (
                proc.stderr.read().decode() if proc.stderr else log.read_text() if log else ""
            )
            try:
                if httpx.get(url + "/readyz", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, f"server did not become ready in {ready_s:g} s"
            time.sleep(0.1)
        if warm:
            _until_warm(url, proc)
        yield proc, url
    finally:
        if proc.poll() is None:
            proc.terminate()
            proc.wait(timeout=30)
        if proc.stderr:
            proc.stderr.close()


WARM_S = 900.0
"""Longest wait for a started server's warm-up to load every operation's kernels, s (a
cold cache on a loaded two-core machine)."""


def _until_warm(url: str, proc: subprocess.Popen) -> None:
    deadline = time.monotonic() + WARM_S
    while True:
        assert proc.poll() is None, "the server exited during its warm-up"
        try:
            answer = httpx.get(url + "/readyz", timeout=5)
            compiling = answer.json().get("operations", {}).get("compiling", [])
        except (httpx.TransportError, ValueError):
            compiling = ["?"]  # busy loading a module: ask again
        else:
            if answer.status_code != 200:
                return  # not ready for another reason (recording): the test's own business
        if not compiling:
            return
        assert time.monotonic() < deadline, f"kernels not loaded in {WARM_S:g} s"
        time.sleep(0.2)


@contextlib.contextmanager
def serving(app: Any) -> Iterator[str]:
    """Serve the ASGI ``app`` with uvicorn in a thread on a free loopback port; yields its
    URL."""
    port = free_port()
    config = uvicorn.Config(
        app, host="127.0.0.1", port=port, lifespan="off", ws="none", log_level="warning"
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert thread.is_alive(), "the test server stopped before it started"
        assert time.monotonic() < deadline, "the test server did not start in 30 s"
        time.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=30)


_WATCH = """
import json, sys, time, httpx
url, stop_file = sys.argv[1], sys.argv[2]
latencies = []
with httpx.Client(base_url=url, timeout=60) as http:
    while len(latencies) < 100_000:
        started = time.perf_counter()
        assert http.get("/healthz").status_code == 200
        latencies.append(time.perf_counter() - started)
        if len(latencies) == 1:
            print("watching", flush=True)
        try:
            open(stop_file).close()
            break
        except FileNotFoundError:
            time.sleep(0.01)
print(json.dumps(latencies))
"""


@contextlib.contextmanager
def health_watch(url: str, folder: Path) -> Iterator[list[float]]:
    """Time ``/healthz`` of the server at ``url`` every 10 ms while the block runs.

    The requests come from another process, so the test's own sending does not delay
    them; the block starts once the first has been answered. The list yielded is filled,
    on leaving the block, with every latency in seconds. ``folder`` holds the stop file.
    """
    stop = folder / "health-watch.stop"
    stop.unlink(missing_ok=True)  # left by an earlier watch
    watcher = subprocess.Popen(
        [sys.executable, "-c", _WATCH, url, str(stop)], stdout=subprocess.PIPE, text=True
    )
    latencies: list[float] = []
    assert watcher.stdout is not None
    try:
        assert watcher.stdout.readline() == "watching\n", "the /healthz watcher did not start"
        yield latencies
    finally:
        stop.touch()
        out, _ = watcher.communicate(timeout=120)
        latencies += json.loads(out)


def losing_a_worker(work: Callable[[str], Any], after: float = 1.5) -> Any:
    """``work(scheduler_address)`` in a thread, on a LocalCluster of two single-threaded
    worker processes (loopback), one of which is SIGKILLed ``after`` seconds in, while
    ``work`` still runs (asserted); what ``work`` returned, within 300 s."""
    import signal

    from distributed import Client, LocalCluster

    outcome = {}
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        Client(local) as client,
    ):
        pids = list(client.run(os.getpid).values())
        thread = threading.Thread(
            target=lambda: outcome.setdefault("value", work(local.scheduler_address))
        )
        thread.start()
        time.sleep(after)  # some chunks done, some running
        assert thread.is_alive()  # killed mid-work, not after it
        os.kill(pids[0], signal.SIGKILL)
        thread.join(timeout=300)
        assert not thread.is_alive()
    return outcome["value"]
