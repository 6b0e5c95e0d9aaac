"""The service hot path against a bare FastAPI app doing the same work, in one run.

Servers on loopback, each one worker on uvloop:

* ``bare``: :mod:`bench.bare_app` on uvicorn (httptools), the same strict parse, operation
  handler and JSON answer, and nothing else: the bar a user feels;
* ``off``: ``plotgate serve --no-record``;
* ``on``: ``plotgate serve``, recording every exchange;
* ``rotating``: ``plotgate serve`` recording, its files rotating at the 4 MiB floor
  (``PLOTGATE_ROTATE_BYTES``), so that files rotate and are compacted by the child
  process all through the run (every 2-3 s at these rates): the p99 while a file compacts;
* ``granian``: plotgate's app, recording, on Granian (``granian --interface asgi
  --factory``, one worker, uvloop) instead of uvicorn: the server itself, against ``on``.

``wrk`` (Debian package ``wrk``: a C load generator, so the client is not the bottleneck on
a two-core machine) posts the README's combined-gate test (3 candidates) at 1, 10 and 50
concurrent connections, closed loop. Every server is started once and all run side by
side (idle but for the one under load); in each of ``--rounds`` rounds each client count
is run on every server in turn for ``--seconds``, the order turning every round. A ratio
is the median over the rounds of the two servers' ratio in the same round, so the load of
a shared machine, which drifts over seconds, divides out; rates, p99s and CPU per request
are medians too. Then, unless ``--quick``:

* **open loop**: at a half and a quarter of the recording server's saturated rate (its
  best at 10 clients), 50 connections each wait an exponential time between requests
  (wrk's ``delay()``), so requests arrive as a Poisson stream at about that rate (each
  connection also waits for its answer, which at these latencies slows the arrivals by
  a few percent); its p99;
* **two workers**: ``plotgate serve --workers 2`` (recording), closed loop at 10 and 50
  clients, against one worker: the scaling on this machine, where wrk shares the cores;
* **live view** (``--live``, which runs this stage alone): ``plotgate serve`` recording,
  against the same with ``--foxglove-port`` and one Foxglove client subscribed to the
  operation's scene topic (``tests/interop/live.mjs``, niced: a viewer runs on another
  machine, not on the server's two cores), rounds alternating, best of each at every
  client count; the aim is at least 0.98x. The publisher's drops are read from /metrics;
* **layers** (``--layers``, which runs this stage alone): the three apps driven in process
  as ASGI callables (no HTTP server, no socket; one request at a time on uvloop), rounds
  alternating, CPU per request: ``off`` minus ``bare`` is what plotgate's layers add
  (request ids, guards, the warm-up gate, body deadlines, metrics), ``on`` minus ``off``
  what recording adds; bench/bench_record_writers.py splits the latter step by step;
* **profile** (``--profile``): py-spy samples the recording server under
  ``--profile-clients`` clients (10 by default) and the top entries, inclusive and self,
  are printed.

Besides requests per second and latency it reports the server's CPU time per request
(from /proc: the server's processes, its workers and compaction children included), the
load-independent cost. ``--quick`` (CI: no time asserted) runs ``bare``, ``on`` and
``granian`` for one round of 1 s per client count. The last lines are the
front table's rows (``SUMMARY {json}``): recording against bare at 1, 10 and 50 clients,
the p99 at 50 (recording and rotating) against bare, and Granian against uvicorn.

    python bench/bench_service.py [--seconds 10 --connections 1,10,50 --rounds 3 --profile]
        [--profile-clients 1] [--live] [--quick]
"""

import argparse
import collections
import contextlib
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.support.servers import free_port, serve  # noqa: E402 - after the sys.path line

BODY = b"""{"gate": {"kind": "combined", "tau": 5, "v_min": 100, "v_max": 500, "P_G": 0.9},
  "first": {"frame": "polar", "r": 50000, "az_deg": 0, "sigma_r": 200, "sigma_az_deg": 0.5},
  "candidates": [
    {"frame": "polar", "r": 51000, "az_deg": 0.5, "sigma_r": 200, "sigma_az_deg": 0.5},
    {"frame": "cartesian", "x": 0, "y": 52600, "covariance": [[40000, 0], [0, 40000]]},
    {"frame": "cartesian", "x": 0, "y": 60000, "covariance": [[40000, 0], [0, 40000]]}
  ]}"""
"""The README's combined-gate test: one first mark, three candidates."""

POST = """wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
local f = io.open("{body}", "rb"); wrk.body = f:read("*a"); f:close()
"""
POISSON = """
function delay()
  return -math.log(1 - math.random()) * {mean_ms}
end
"""
SERVERS = ("bare", "off", "on", "rotating", "granian")
QUICK_SERVERS = ("bare", "on", "granian")
ROTATE_BYTES = 4 * 2**20
"""The ``rotating`` server's files: the floor of ``PLOTGATE_ROTATE_BYTES``."""


def _cpu_seconds(pid: int) -> float:
    """CPU time of ``pid`` and of its descendants: those alive (Granian's worker, a
    compaction) and those ended and reaped (their time is then their parent's)."""
    parents: dict[int, int] = {}
    ticks: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, IndexError, ValueError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            child = int(stat.parent.name)
            parents[child] = int(fields[1])
            ticks[child] = sum(int(f) for f in fields[11:15])  # own and reaped children's
    tree, grew = {pid}, True
    while grew:
        found = {child for child, parent in parents.items() if parent in tree} - tree
        tree |= found
        grew = bool(found)
    return sum(ticks.get(p, 0) for p in tree) / os.sysconf("SC_CLK_TCK")


def _ms(text: str) -> float:
    match = re.fullmatch(r"([\d.]+)(us|ms|s|m)", text)
    if match is None:
        raise ValueError(f"unexpected wrk latency {text!r}")
    value, unit = match.groups()
    return float(value) * {"us": 1e-3, "ms": 1.0, "s": 1e3, "m": 6e4}[unit]


def _wrk(
    url: str, script: Path, seconds: int, connections: int, warm_up: bool = False
) -> dict[str, float]:
    """One wrk run (a 10 s timeout: a loaded machine's p99 is not an error); an answer
    that is not 2xx or a socket error raises, except while warming up."""
    out = subprocess.run(
        ["wrk", "-t1", f"-c{connections}", f"-d{seconds}s", "--latency", "--timeout", "10s"]
        + ["-s", str(script), url],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    if warm_up:
        return {}
    if "Non-2xx" in out or "Socket errors" in out:
        raise RuntimeError(f"wrk saw errors:\n{out}")

    def field(pattern: str) -> str:
        match = re.search(pattern, out, re.M)
        if match is None:
            raise RuntimeError(f"no {pattern!r} in wrk's output:\n{out}")
        return match.group(1)

    return {
        "requests": float(field(r"(\d+) requests in")),
        "rate": float(field(r"Requests/sec:\s+([\d.]+)")),
        "p50": _ms(field(r"^\s*50%\s+(\S+)")),
        "p99": _ms(field(r"^\s*99%\s+(\S+)")),
    }


@contextlib.contextmanager
def _bare() -> Iterator[tuple[subprocess.Popen, str]]:
    port = free_port()
    proc = subprocess.Popen(
        [
            *(sys.executable, "-m", "uvicorn", "--factory", "bench.bare_app:create_app"),
            *("--port", str(port), "--loop", "uvloop", "--http", "httptools"),
            *("--no-access-log", "--log-level", "warning"),
        ],
        cwd=ROOT,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            with contextlib.suppress(httpx.TransportError):
                if httpx.post(url + "/v1/gates/test", content=BODY).status_code == 200:
                    break
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the bare app did not start")
            time.sleep(0.2)
        yield proc, url
    finally:
        proc.terminate()
        proc.wait(timeout=30)


@contextlib.contextmanager
def _granian(folder: Path) -> Iterator[tuple[subprocess.Popen, str]]:
    """plotgate's app, recording, on Granian: one worker, uvloop, HTTP/1."""
    port = free_port()
    proc = subprocess.Popen(
        [
            *(sys.executable, "-m", "granian", "--interface", "asgi", "--factory"),
            *("--host", "127.0.0.1", "--port", str(port), "--workers", "1"),
            *("--loop", "uvloop", "--http", "1", "--no-ws", "--log-level", "warning"),
            "plotgate.service.app:create_app",
        ],
        cwd=ROOT,
        env={**os.environ, "PLOTGATE_LOG_DIR": str(folder), "PLOTGATE_RECORD": "true"},
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            with contextlib.suppress(httpx.TransportError):
                answer = httpx.get(url + "/readyz", timeout=5)
                if answer.status_code == 200 and not answer.json()["operations"]["compiling"]:
                    break
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("granian did not start")
            time.sleep(0.2)
        yield proc, url
    finally:
        proc.terminate()
        proc.wait(timeout=60)


def _server(kind: str, folder: Path, *flags: str):
    if kind == "bare":
        return _bare()
    if kind == "granian":
        return _granian(folder / kind)
    if kind == "rotating":
        return serve(folder / kind, *flags, env={"PLOTGATE_ROTATE_BYTES": str(ROTATE_BYTES)})
    return serve(folder / kind, *(["--no-record"] if kind == "off" else []), *flags)


def _summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None):
    """One row of bench/README.md's front table, as ``bench/run_all.py`` reads it."""
    fields = {"row": row, "workload": workload, "peer": peer, "measured": measured}
    print("SUMMARY " + json.dumps({**fields, "aim": aim, "met": met}))


def _summaries(best: dict[tuple[int, str], dict[str, float]], levels: list[int]) -> None:
    """The front table's rows: recording against bare, its p99, Granian against uvicorn."""
    for c in levels:
        ratio, cpu = best[c, "on"]["rate/bare"], 1 / best[c, "on"]["cpu/bare"]
        _summary(
            f"service.recording.c{c}",
            f"gates.test (combined, 3 candidates), recording on, {c} client(s), requests/s "
            "(and bare's CPU per request over ours, the load-independent figure)",
            "bare FastAPI app on uvicorn, same work",
            f"{ratio:.2f}x bare (by CPU per request {cpu:.2f}x)",
            ">= 0.95x",
            min(ratio, cpu) >= 0.95,  # both: a shared machine's noise lifts either alone
        )
    top = max(levels)
    kinds = [kind for kind in ("on", "rotating") if (top, kind) in best]
    p99 = {kind: best[top, kind]["p99/bare"] for kind in kinds}
    _summary(
        f"service.recording.p99.c{top}",
        f"gates.test, recording on, {top} clients, p99; rotating: files rotating at 4 MiB "
        "and compacted meanwhile",
        "bare FastAPI app on uvicorn, same work",
        ", ".join(f"{kind} {ratio:.2f}x bare" for kind, ratio in p99.items()),
        "<= 1.5x",
        max(p99.values()) <= 1.5,
    )
    for c in levels:
        ratio = best[c, "granian"]["rate/on"]
        cpu = best[c, "granian"]["cpu/on"]
        _summary(
            f"service.granian.c{c}",
            f"plotgate serve's app, recording, {c} client(s), on Granian",
            "the same app on uvicorn (httptools), same run",
            f"{ratio:.2f}x uvicorn, CPU {cpu:.2f}x",
            "adopted as default only if faster with the same behaviour",
            None,
        )


def _profile(pid: int, seconds: int, url: str, script: Path, clients: int) -> str:
    """py-spy's samples of ``pid`` under ``clients`` clients, folded into the top entries."""
    if not shutil.which("py-spy"):
        return "py-spy not found: pip install py-spy"
    with tempfile.NamedTemporaryFile(suffix=".txt") as raw:
        load = subprocess.Popen(
            ["wrk", "-t1", f"-c{clients}", f"-d{seconds + 2}s", "-s", str(script), url],
            stdout=subprocess.DEVNULL,
        )
        time.sleep(1)
        subprocess.run(
            ["py-spy", "record", "-p", str(pid), "-d", str(seconds), "-r", "500"]
            + ["-f", "raw", "-o", raw.name, "--nonblocking"],
            capture_output=True,
            check=True,
        )
        load.wait()
        inclusive: collections.Counter[str] = collections.Counter()
        own: collections.Counter[str] = collections.Counter()
        total = 0
        for line in Path(raw.name).read_text().splitlines():
            stack, _, count = line.rpartition(" ")
            n = int(count)
            total += n
            names = [re.sub(r" \((?:.*/)?([^/]*?):\d+\)$", r" (\1)", f) for f in stack.split(";")]
            for name in set(names):
                inclusive[name] += n
            own[names[-1]] += n
    lines = [f"{total} samples; inclusive:"]
    lines += [f"  {100 * n / total:5.1f}% {name}" for name, n in inclusive.most_common(40)]
    lines += ["self:"]
    lines += [f"  {100 * n / total:5.1f}% {name}" for name, n in own.most_common(20)]
    return "\n".join(lines)


def _layers_app(kind: str, folder: Path):
    """The ``kind`` app as an ASGI callable, built as its server builds it."""
    if kind == "bare":
        from bench.bare_app import create_app as bare_app

        return bare_app()
    from plotgate.service.app import create_app
    from plotgate.service.config import Settings

    return create_app(Settings(log_dir=folder / kind, record=kind == "on"))


async def _drive(app, requests: int) -> None:
    """``requests`` gate tests, one at a time, straight into the ASGI app."""
    import asyncio

    scope = {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": "/v1/gates/test",
        "raw_path": b"/v1/gates/test",
        "root_path": "",
        "query_string": b"",
        "headers": [
            (b"host", b"127.0.0.1"),
            (b"content-type", b"application/json"),
            (b"content-length", b"%d" % len(BODY)),
        ],
        "client": ("127.0.0.1", 1),
        "server": ("127.0.0.1", 2),
    }
    message = {"type": "http.request", "body": BODY, "more_body": False}
    statuses = set()

    async def receive() -> dict:
        return message

    async def send(sent: dict) -> None:
        if sent["type"] == "http.response.start":
            statuses.add(sent["status"])

    for _ in range(requests):
        await app({**scope, "state": {}}, receive, send)
        await asyncio.sleep(0)  # a turn of the loop between requests, as a server has
    if statuses != {200}:
        raise RuntimeError(f"the in-process app answered {statuses}")


async def _layer_cpu(kind: str, folder: Path, requests: int) -> float:
    """CPU s per request of the ``kind`` app in process, its lifespan running, warm."""
    import asyncio

    app = _layers_app(kind, folder)
    async with app.router.lifespan_context(app):
        await _drive(app, 200)
        warmup = getattr(app.state, "warmup", None)
        while warmup is not None and (
            warmup.report()["compiling"] or (warmup.thread and warmup.thread.is_alive())
        ):
            await asyncio.sleep(0.2)
        await _drive(app, 1000)
        started = time.process_time()
        await _drive(app, requests)
        return (time.process_time() - started) / requests


def _layers(args: argparse.Namespace, folder: Path) -> None:
    """The app layers' CPU per request in process: bare, off, on (best of the rounds)."""
    import uvloop

    requests = 500 if args.quick else 3000
    best: dict[str, float] = {}
    for _ in range(args.rounds):
        for kind in ("bare", "off", "on"):
            cpu = uvloop.run(_layer_cpu(kind, folder, requests))
            best[kind] = min(best.get(kind, cpu), cpu)
    print(f"in process, no HTTP server: CPU us per request, best of {args.rounds} rounds")
    print("| app | us | vs bare |")
    print("|---|---:|---:|")
    for kind, cpu in best.items():
        print(f"| {kind} | {cpu * 1e6:.1f} | {cpu / best['bare']:.3f}x |")
    print(f"plotgate's layers (off - bare): {(best['off'] - best['bare']) * 1e6:.1f} us")
    print(f"recording (on - off): {(best['on'] - best['off']) * 1e6:.1f} us")


@contextlib.contextmanager
def _subscribed(port: int) -> Iterator[None]:
    """One Foxglove client subscribed to ``/scene/gates.test`` on ``port`` until the end."""
    client = subprocess.Popen(
        ["nice", "-n", "19", "node", str(ROOT / "tests/interop/live.mjs")]
        + [f"ws://127.0.0.1:{port}", "/scene/gates.test", str(10**9), str(10**6)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    drain = None
    try:
        assert client.stdout is not None
        assert "subscribed" in client.stdout.readline(), "the Foxglove client did not subscribe"
        # cat drains the messages, so the client never blocks on its output
        drain = subprocess.Popen(["cat"], stdin=client.stdout, stdout=subprocess.DEVNULL)
        yield
    finally:
        client.kill()  # first: cat ends with the client's output
        client.wait()
        if drain is not None:
            drain.wait(timeout=30)
        if client.stdout is not None:
            client.stdout.close()


def _live(args: argparse.Namespace, folder: Path, script: Path, levels: list[int]) -> None:
    """The live view's cost: recording with and without it (one client subscribed)."""
    best: dict[tuple[int, str], dict[str, float]] = {}
    dropped = ""
    for _ in range(args.rounds):
        for kind in ("on", "live"):
            port = free_port()
            flags = ("--foxglove-port", str(port)) if kind == "live" else ()
            with _server("on", folder, *flags) as (proc, url):
                with _subscribed(port) if kind == "live" else contextlib.nullcontext():
                    _wrk(url + "/v1/gates/test", script, 2, max(levels), warm_up=True)
                    for c in levels:
                        cpu = _cpu_seconds(proc.pid)
                        run = _wrk(url + "/v1/gates/test", script, args.seconds, c)
                        run["cpu_ms"] = (_cpu_seconds(proc.pid) - cpu) / run["requests"] * 1e3
                        if (c, kind) not in best or run["rate"] > best[c, kind]["rate"]:
                            best[c, kind] = run
                    if kind == "live":
                        metrics = httpx.get(url + "/metrics").text
                        dropped = "\n".join(
                            line for line in metrics.splitlines() if "plotgate_foxglove" in line
                        )
    print(
        f"wrk -t1 -d{args.seconds}s, best of {args.rounds} rounds, recording; live: with "
        "--foxglove-port and one client subscribed"
    )
    print("\n| clients | server | requests/s | live / on | p50 ms | p99 ms | CPU ms/req |")
    print("|---:|---|---:|---:|---:|---:|---:|")
    for c in levels:
        for kind in ("on", "live"):
            r = best[c, kind]
            ratio = r["rate"] / best[c, "on"]["rate"]
            print(
                f"| {c} | {kind} | {r['rate']:,.0f} | {ratio:.3f}x | {r['p50']:.2f} | "
                f"{r['p99']:.2f} | {r['cpu_ms']:.3f} |"
            )
    print(f"\nthe last live round's /metrics:\n{dropped}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=int, default=3)
    parser.add_argument("--connections", default="1,10,50", help="concurrent clients")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--profile", action="store_true", help="py-spy the recording server")
    parser.add_argument("--profile-clients", type=int, default=10)
    parser.add_argument(
        "--live", action="store_true", help="only the live view's cost (--foxglove-port)"
    )
    parser.add_argument(
        "--layers", action="store_true", help="only the app layers' CPU, in process"
    )
    parser.add_argument(
        "--quick", action="store_true", help="one 1 s round of bare, on and granian"
    )
    args = parser.parse_args()
    servers = QUICK_SERVERS if args.quick else SERVERS
    if args.quick:
        args.seconds, args.rounds = 1, 1
    if not shutil.which("wrk"):
        sys.exit("wrk not found: apt-get install wrk")
    levels = [int(c) for c in args.connections.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "body.json").write_bytes(BODY)
        script = folder / "post.lua"
        script.write_text(POST.format(body=folder / "body.json"))
        if args.live:
            _live(args, folder, script, levels)
            return
        if args.layers:
            _layers(args, folder)
            return
        best = _closed_loop(args, folder, script, levels, servers)
        if args.quick:
            _report(args, levels, servers, best, {}, {}, "")
            return
        saturated = _saturated(best, levels)
        open_loop: dict[tuple[int, str], dict[str, float]] = {}
        for kind in ("bare", "off", "on"):
            with _server(kind, folder) as (_, url):
                _wrk(url + "/v1/gates/test", script, 2, 10, warm_up=True)
                for share in (2, 4):
                    paced = folder / f"paced{share}.lua"
                    mean_ms = 5e4 * share / saturated
                    paced.write_text(script.read_text() + POISSON.format(mean_ms=mean_ms))
                    run = _wrk(url + "/v1/gates/test", paced, args.seconds, 50)
                    open_loop[share, kind] = run
        workers: dict[tuple[int, int], dict[str, float]] = {}
        for count in (1, 2):
            with _server("on", folder, "--workers", str(count)) as (_, url):
                _wrk(url + "/v1/gates/test", script, 2, 50, warm_up=True)
                for c in (10, 50):
                    workers[count, c] = _wrk(url + "/v1/gates/test", script, args.seconds, c)
        profile = ""
        if args.profile:
            with _server("on", folder) as (proc, url):
                _wrk(url + "/v1/gates/test", script, 2, 10, warm_up=True)
                profile = _profile(
                    proc.pid, args.seconds, url + "/v1/gates/test", script, args.profile_clients
                )
    _report(args, levels, servers, best, open_loop, workers, profile)


def _closed_loop(
    args: argparse.Namespace,
    folder: Path,
    script: Path,
    levels: list[int],
    servers: tuple[str, ...],
) -> dict[tuple[int, str], dict[str, float]]:
    """Every server started once, then ``--rounds`` rounds: at each client count each
    server in turn (the order turning every round) for ``--seconds``. Per (clients,
    server): the medians over the rounds of its rate, p99 and CPU per request, and of its
    ratios to ``bare`` (and to ``on``) *in the same round*, so that the load of a shared
    machine, which drifts over seconds, divides out."""
    runs: dict[tuple[int, int, str], dict[str, float]] = {}
    with contextlib.ExitStack() as stack:
        started = {kind: stack.enter_context(_server(kind, folder)) for kind in servers}
        for _, url in started.values():
            _wrk(url + "/v1/gates/test", script, 1 if args.quick else 2, 10, warm_up=True)
        for r in range(args.rounds):
            order = servers[r % len(servers) :] + servers[: r % len(servers)]
            for c in levels:
                for kind in order:
                    proc, url = started[kind]
                    cpu = _cpu_seconds(proc.pid)
                    run = _wrk(url + "/v1/gates/test", script, args.seconds, c)
                    run["cpu_ms"] = (_cpu_seconds(proc.pid) - cpu) / run["requests"] * 1e3
                    runs[r, c, kind] = run
    rounds = range(args.rounds)
    table: dict[tuple[int, str], dict[str, float]] = {}
    for c in levels:
        for kind in servers:
            mine = [runs[r, c, kind] for r in rounds]
            row = {key: statistics.median(run[key] for run in mine) for key in mine[0]}
            for peer in ("bare", "on"):
                if peer in servers:
                    row[f"rate/{peer}"] = statistics.median(
                        runs[r, c, kind]["rate"] / runs[r, c, peer]["rate"] for r in rounds
                    )
                    row[f"p99/{peer}"] = statistics.median(
                        runs[r, c, kind]["p99"] / runs[r, c, peer]["p99"] for r in rounds
                    )
                    row[f"cpu/{peer}"] = statistics.median(
                        runs[r, c, kind]["cpu_ms"] / runs[r, c, peer]["cpu_ms"] for r in rounds
                    )
            table[c, kind] = row
    return table


def _saturated(best: dict[tuple[int, str], dict[str, float]], levels: list[int]) -> float:
    """The recording server's saturated rate: its best at 10 clients (or the most)."""
    return best[10 if 10 in levels else max(levels), "on"]["rate"]


def _report(
    args: argparse.Namespace,
    levels: list[int],
    servers: tuple[str, ...],
    best: dict[tuple[int, str], dict[str, float]],
    open_loop: dict[tuple[int, str], dict[str, float]],
    workers: dict[tuple[int, int], dict[str, float]],
    profile: str,
) -> None:
    print(
        f"wrk -t1 -d{args.seconds}s, medians of {args.rounds} rounds, the README's combined-gate "
        f"test ({len(BODY)} bytes); one worker each, uvloop; uvicorn with httptools but "
        "granian"
    )
    print(
        "\n| clients | server | requests/s | vs bare | p50 ms | p99 ms | p99 vs bare"
        " | CPU ms/req | CPU vs bare |"
    )
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for c in levels:
        for kind in servers:
            r = best[c, kind]
            print(
                f"| {c} | {kind} | {r['rate']:,.0f} | {r['rate/bare']:.3f}x | "
                f"{r['p50']:.2f} | {r['p99']:.2f} | {r['p99/bare']:.2f}x | "
                f"{r['cpu_ms']:.3f} | {r['cpu/bare']:.3f}x |"
            )
    print()
    for c in levels:
        if "off" in servers:
            cost = 1 - best[c, "on"]["rate/bare"] / best[c, "off"]["rate/bare"]
            print(f"{c} clients: recording costs {cost:.1%} of the throughput (on vs off)")
        server = best[c, "granian"]["rate/on"]
        print(f"{c} clients: Granian serves {server:.2f}x uvicorn's rate (plotgate, recording)")
    if not open_loop:
        _summaries(best, levels)
        return
    print(
        "\nopen loop, Poisson arrivals at a half and a quarter of "
        f"{_saturated(best, levels):,.0f}/s "
        "(recording, 10 clients), 50 connections:"
    )
    print("| share | server | requests/s | p50 ms | p99 ms |")
    print("|---|---|---:|---:|---:|")
    for (share, kind), r in open_loop.items():
        print(f"| 1/{share} | {kind} | {r['rate']:,.0f} | {r['p50']:.2f} | {r['p99']:.2f} |")
    print("\nplotgate serve --workers N, recording:")
    print("| workers | clients | requests/s | scaling | p99 ms |")
    print("|---:|---:|---:|---:|---:|")
    for (count, c), r in sorted(workers.items()):
        scaling = r["rate"] / workers[1, c]["rate"]
        print(f"| {count} | {c} | {r['rate']:,.0f} | {scaling:.2f}x | {r['p99']:.2f} |")
    if profile:
        print(f"\npy-spy, recording server under {args.profile_clients} clients:\n" + profile)
    _summaries(best, levels)


if __name__ == "__main__":
    main()
