"""A hostile run against live servers: what the README's reliability table reports.

Each category puts real ``plotgate serve`` processes (loopback only) or the ``plotgate``
tools through one kind of abuse and counts, per category: the cases tried, the answers of
5xx (or, for the tools and the client, anything that escaped as a traceback or a
non-plotgate exception), the hangs (no answer within :data:`HANG_S`), and the answered
exchanges missing from the recordings afterwards.

- ``bodies``: every operation's example body with each of its fields (the first item of
  each list) replaced by hostile values, removed, or joined by an unknown field; and
  bodies that are not JSON, nest deeply, or are empty;
- ``states``: a real initiation state, each field replaced by hostile values, its tracks
  duplicated, and a state sent with another configuration;
- ``auth``: a server with a key, every operation path in ten spellings, four methods and
  six wrong credentials: anything but 401 is a bypass;
- ``large``: the heaviest accepted and refused bodies while another process times
  ``/healthz`` (its worst latency is reported);
- ``folder deleted``, ``SIGKILL``, ``disk full``: eight clients of gate tests while the
  folder is deleted, the server killed, or its disk filled (a small tmpfs; root only):
  every exchange answered (after a deletion: answered and sent after it) must be on disk,
  and afterwards the folder holds no empty file and replays with exit 0. A read-only
  remount is not among them: the kernel refuses it ("busy") while the server's file is
  open for writing; the suite's unwritable-folder tests cover a folder that cannot be
  written;
- ``cluster``: a scheduler address whose port is silent, sends a banner, or speaks HTTP:
  a 503 within the cluster timeout, and the server stops on SIGTERM within 15 s;
- ``files``: the hostile MCAP corpus of the tests through inspect, cat, replay and
  recover, and a FIFO, a socket and an empty file named ``*.mcap``;
- ``client``: a local server answering 200 with HTML, truncated JSON, the wrong schema,
  NaN, deep nesting and an endless chunked body: every failure must be a
  ``PlotgateClientError``.

    python bench/hostile_run.py [--json bench/results/hostile.json] [--only CATEGORY ...]
"""

import argparse
import contextlib
import copy
import http.server
import json
import os
import random
import resource
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from plotgate.clients.recordings import read_recording  # noqa: E402
from plotgate.service.registry import OPERATIONS  # noqa: E402
from tests.support.servers import free_port, serve  # noqa: E402

HANG_S = 120.0
"""An answer slower than this counts as a hang."""
HOSTILE = [None, True, "x", -1, 0, 1e308, -1e308, 5e-324, 2**63, [], {}]
"""What each field of an example body is replaced by."""
JSON = {"content-type": "application/json"}
GATE_TEST = {
    "gate": {"kind": "combined", "tau": 5, "v_min": 100, "v_max": 500, "P_G": 0.9},
    "first": {"frame": "polar", "r": 50000, "az_deg": 0, "sigma_r": 200, "sigma_az_deg": 0.5},
    "candidates": [
        {"frame": "polar", "r": 51000, "az_deg": 0.5, "sigma_r": 200, "sigma_az_deg": 0.5}
    ],
}


@dataclass
class Row:
    """One category's counts."""

    category: str
    cases: int = 0
    failures: int = 0
    """5xx answers, or tracebacks and foreign exceptions of the tools and the client."""
    hangs: int = 0
    missing: int = 0
    """Answered exchanges not on disk afterwards."""
    note: str = ""
    examples: list[str] = field(default_factory=list)

    def fail(self, what: str) -> None:
        self.failures += 1
        if len(self.examples) < 5:
            self.examples.append(what)


def _recorded(folder: Path) -> set[str]:
    """Request ids of the exchanges with both records in ``folder``'s files."""
    ids: set[str] = set()
    for path in sorted(folder.glob("*.mcap")):
        if path.is_file() and path.stat().st_size:
            ids |= {ex.request_id for ex in read_recording(path).exchanges if ex.response}
    return ids


class _Sender:
    """Posts bodies from a few threads, counting 5xx and hangs and keeping the ids of the
    exchanges answered (so recorded: every answer but a refusal to record)."""

    def __init__(self, url: str, row: Row, headers: dict[str, str] | None = None) -> None:
        self.url, self.row, self.headers = url, row, {**JSON, **(headers or {})}
        self.answered: dict[str, float] = {}
        """Request id -> when it was sent (monotonic), for every exchange answered."""
        self.statuses: dict[int, int] = {}
        self._lock = threading.Lock()
        self._n = 0

    def post(self, http: httpx.Client, path: str, content: bytes) -> int | None:
        with self._lock:
            self._n += 1
            rid = f"{self.row.category.replace(' ', '-')}-{self._n}"
        sent = time.monotonic()
        try:
            r = http.post(path, content=content, headers={**self.headers, "x-request-id": rid})
        except httpx.TimeoutException:
            with self._lock:
                self.row.cases += 1
                self.row.hangs += 1
            return None
        with self._lock:
            self.row.cases += 1
            self.statuses[r.status_code] = self.statuses.get(r.status_code, 0) + 1
            if r.status_code >= 500 and r.status_code != 503:
                self.row.fail(f"{path} {r.status_code} {content[:120]!r}")
            elif r.status_code != 503:
                self.answered[rid] = sent
        return r.status_code

    def many(self, jobs: list[tuple[str, bytes]], threads: int = 4) -> None:
        def run(chunk: list[tuple[str, bytes]]) -> None:
            with httpx.Client(base_url=self.url, timeout=HANG_S) as http:
                for path, content in chunk:
                    self.post(http, path, content)

        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, [jobs[k::threads] for k in range(threads)]))


def _leaves(value: Any, path: tuple = ()) -> Iterator[tuple]:
    """Paths to every field of ``value``, a list standing for its first item."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield path + (key,)
            yield from _leaves(item, path + (key,))
    elif isinstance(value, list) and value:
        yield path + (0,)
        yield from _leaves(value[0], path + (0,))


def _set(body: Any, path: tuple, value: Any, delete: bool = False) -> Any:
    out = copy.deepcopy(body)
    target = out
    for key in path[:-1]:
        target = target[key]
    if delete:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return out


def _mutations(body: dict) -> Iterator[dict]:
    for path in _leaves(body):
        for value in HOSTILE:
            yield _set(body, path, value)
        if isinstance(path[-1], str):
            yield _set(body, path, None, delete=True)
            yield _set(body, path[:-1] + ("unknown_field",), 1)


def _garbage() -> list[bytes]:
    return [
        b"",
        b"{",
        b"null",
        b"[]",
        b'"x"',
        b"\xff\xfe\x00",
        b"[" * 100_000 + b"]" * 100_000,
        b'{"a":' * 50_000 + b"1" + b"}" * 50_000,
        b'{"gate": NaN}',
        b"{" + b'"k": 1,' * 200_000 + b'"k": 1}',
    ]


def bodies(work: Path) -> Row:
    row = Row("bodies")
    folder = work / "bodies"
    with serve(folder) as (_, url):
        sender = _Sender(url, row)
        jobs = [
            (op.path, json.dumps(m).encode())
            for op in OPERATIONS.values()
            for m in _mutations(op.endpoint.example)
        ]
        jobs += [(op.path, g) for op in OPERATIONS.values() for g in _garbage()]
        random.Random(24).shuffle(jobs)
        sender.many(jobs)
    row.missing = len(sender.answered.keys() - _recorded(folder))
    row.note = f"statuses {dict(sorted(sender.statuses.items()))}"
    return row


def _state(url: str) -> dict:
    scans = [
        {
            "t": float(k),
            "plots": [
                {
                    "frame": "cartesian",
                    "x": 5000.0 + 25 * k,
                    "y": 10_000.0,
                    "covariance": [[25.0, 0.0], [0.0, 25.0]],
                },
                {
                    "frame": "cartesian",
                    "x": 9000.0 - 20 * k,
                    "y": 2000.0 + 10 * k,
                    "covariance": [[25.0, 0.0], [0.0, 25.0]],
                },
                {
                    "frame": "cartesian",
                    "x": 1000.0 * k + 300.0,
                    "y": 400.0 * k,
                    "covariance": [[25.0, 0.0], [0.0, 25.0]],
                },
            ],
        }
        for k in range(3)
    ]
    body = {"config": {"v_max": 50.0}, "state": None, "scans": scans}
    r = httpx.post(url + "/v1/initiation/initiate", json=body, timeout=60)
    r.raise_for_status()
    return r.json()["state"]


def states(work: Path) -> Row:
    row = Row("states")
    folder = work / "states"
    with serve(folder) as (_, url):
        state = _state(url)
        scan = {
            "t": 3.0,
            "plots": [
                {
                    "frame": "cartesian",
                    "x": 5075.0,
                    "y": 10_000.0,
                    "covariance": [[25.0, 0.0], [0.0, 25.0]],
                }
            ],
        }

        def call(s: Any, config: dict | None = None) -> bytes:
            body = {"config": config or {"v_max": 50.0}, "state": s, "scans": [scan]}
            return json.dumps(body).encode()

        values = [*HOSTILE, 1e7, 1e-300, -1e-300, 1e300, 0.5, -0.5, 10**6]
        jobs = [(p, call(_set(state, p, v))) for p in _leaves(state) for v in values]
        jobs += [
            (p, call(_set(state, p, None, delete=True)))
            for p in _leaves(state)
            if isinstance(p[-1], str)
        ]
        for key in ("tracks", "initiators"):
            for times in (2, 100):
                if state.get(key):
                    copies = {
                        k: v * times if isinstance(v, list) else v for k, v in state[key].items()
                    }  # columns, each repeated
                    jobs.append(((), call({**state, key: copies})))
        jobs += [
            ((), call(state, {"v_max": 60.0})),
            ((), call(state, {"confirmation": "score", "clutter_density": 1e-6})),
        ]
        sender = _Sender(url, row)
        sender.many([("/v1/initiation/initiate", content) for _, content in jobs])
    row.missing = len(sender.answered.keys() - _recorded(folder))
    accepted = sender.statuses.get(200, 0)
    row.note = f"statuses {dict(sorted(sender.statuses.items()))} ({accepted} tampered accepted)"
    return row


_SPELLINGS = [
    "{p}",
    "{p}/",
    "{p}//",
    "{P}",
    "/{p}",
    "{p}?x=1",
    "{p}/.",
    "/v1/../{q}",
    "{p}%2F",
    "{p};x",
]
_CREDENTIALS = [
    {},
    {"x-api-key": "wrong"},
    {"x-api-key": ""},
    {"x-api-key": "SECRET"},
    {"authorization": "Bearer wrong"},
    {"authorization": "Basic c2VjcmV0"},
]


def auth(work: Path) -> Row:
    row = Row("auth")
    env = {"PLOTGATE_API_KEY": "secret"}
    with serve(work / "auth", env=env) as (_, url), httpx.Client(base_url=url, timeout=30) as h:
        paths = [op.path for op in OPERATIONS.values()] + ["/metrics", "/v1/nothing", "/v2/x"]
        for p in paths:
            for spelling in _SPELLINGS:
                target = spelling.format(p=p, P=p.upper(), q=p.removeprefix("/"))
                for method in ("POST", "GET", "PUT", "DELETE"):
                    for credentials in _CREDENTIALS:
                        r = h.request(
                            method,
                            target,
                            content=json.dumps(GATE_TEST),
                            headers={**JSON, **credentials},
                        )
                        row.cases += 1
                        if r.status_code != 401:
                            row.fail(f"{method} {target} {credentials} -> {r.status_code}")
    row.note = "anything but 401 without the key counts as a failure"
    return row


_WATCH = """
import sys, time, httpx
url, stop = sys.argv[1], sys.argv[2]
worst = 0.0
with httpx.Client(base_url=url, timeout=60) as http:
    while True:
        t = time.perf_counter(); http.get("/healthz"); worst = max(worst, time.perf_counter() - t)
        try:
            open(stop).close(); break
        except FileNotFoundError:
            time.sleep(0.005)
print(worst)
"""


def large(work: Path) -> Row:
    row = Row("large bodies")
    cart = {"frame": "cartesian", "x": 0.0, "y": 900.0, "covariance": [[1.0, 0.0], [0.0, 1.0]]}
    pair = {"first": {**cart, "y": 0.0}, "second": cart}
    gate = {"kind": "ring", "tau": 5, "v_min": 100, "v_max": 500}
    cases = {
        "gates.pairs 100,000": ("/v1/gates/pairs", {"gate": gate, "pairs": [pair] * 100_000}),
        "gates.pairs 100,001": ("/v1/gates/pairs", {"gate": gate, "pairs": [pair] * 100_001}),
        "gates.test 100,001": (
            "/v1/gates/test",
            {"gate": gate, "first": pair["first"], "candidates": [cart] * 100_001},
        ),
    }
    worst: dict[str, float] = {}
    folder = work / "large"
    with serve(folder) as (_, url):
        sender = _Sender(url, row)
        with httpx.Client(base_url=url, timeout=HANG_S) as http:
            for name, (path, body) in cases.items():
                content = json.dumps(body).encode()
                stop = work / f"stop-{len(worst)}"
                watch = subprocess.Popen(
                    [sys.executable, "-c", _WATCH, url, str(stop)], stdout=subprocess.PIPE
                )
                time.sleep(1.0)
                sender.post(http, path, content)
                stop.touch()
                worst[name] = float(watch.communicate(timeout=60)[0])
    row.missing = len(sender.answered.keys() - _recorded(folder))
    row.note = "worst /healthz: " + ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in worst.items())
    return row


def _load(url: str, row: Row, stop: threading.Event, clients: int = 8) -> _Sender:
    """Eight clients posting gate tests until ``stop``; returns what they saw answered."""
    sender = _Sender(url, row)
    body = json.dumps(GATE_TEST).encode()

    def client() -> None:
        with httpx.Client(base_url=url, timeout=HANG_S) as http:
            while not stop.is_set():
                try:
                    sender.post(http, "/v1/gates/test", body)
                except httpx.TransportError:
                    return  # the server was killed

    threads = [threading.Thread(target=client) for _ in range(clients)]
    for t in threads:
        t.start()
    sender.threads = threads  # type: ignore[attr-defined]
    return sender


def _finish(sender: _Sender, stop: threading.Event) -> None:
    stop.set()
    for t in sender.threads:  # type: ignore[attr-defined]
        t.join(timeout=HANG_S)


@contextlib.contextmanager
def _tmpfs(where: Path, size: str) -> Iterator[Path]:
    where.mkdir(parents=True, exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], check=True)
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def _fault(
    name: str, work: Path, during: Callable[[Path, Any], str], deletes: bool = False
) -> Row:
    """Load a server, apply ``during(folder, proc)`` mid-load, count what went missing:
    every exchange answered, or, when the fault ``deletes`` recorded files (an operator's
    ``rm -rf``), every one sent after it."""
    row = Row(name)
    mount = work / name.replace(" ", "-")
    with _tmpfs(mount, "64m") as fs:
        folder = fs / "recordings"
        stop = threading.Event()
        with serve(folder) as (proc, url):
            sender = _load(url, row, stop)
            time.sleep(2.0)
            row.note = during(folder, proc)
            fault_over = time.monotonic()
            time.sleep(2.0)
            _finish(sender, stop)
            if proc.poll() is None:
                row.note += after_fault(folder, url)
        counted = {
            rid for rid, sent in sender.answered.items() if not deletes or sent >= fault_over
        }
        row.missing = len(counted - _recorded(folder))
        statuses = dict(sorted(sender.statuses.items()))
        row.note += f"; {len(counted)} answered exchanges counted; statuses {statuses}"
        return row


def after_fault(folder: Path, url: str) -> str:
    """Once the fault is gone: does the server answer again, and does its folder replay?"""
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        if httpx.get(url + "/readyz", timeout=10).status_code == 200:
            break
        time.sleep(0.2)
    ready = httpx.get(url + "/readyz", timeout=10).status_code
    empty = sum(1 for p in folder.glob("*.mcap") if p.stat().st_size == 0)
    replay = subprocess.run(
        [sys.executable, "-m", "plotgate.clients.cli", "replay", str(folder)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    return f"; after: /readyz {ready}, {empty} empty files, replay exit {replay.returncode}"


def _delete(folder: Path, proc: Any) -> str:
    for _ in range(3):
        shutil.rmtree(folder, ignore_errors=True)
        time.sleep(0.5)
    return "folder deleted 3 times"


def _kill(folder: Path, proc: Any) -> str:
    proc.kill()
    proc.wait(timeout=30)
    return "SIGKILL mid-load"


def _fill(folder: Path, proc: Any) -> str:
    filler = folder.parent / "filler"
    subprocess.run(["dd", "if=/dev/zero", f"of={filler}", "bs=1M"], capture_output=True)
    time.sleep(3.0)
    empty = sum(1 for p in folder.glob("*.mcap") if p.stat().st_size == 0)
    filler.unlink()
    return f"disk full for 3 s ({empty} empty files meanwhile)"


def _silent(sock: socket.socket) -> None:
    while True:
        conn, _ = sock.accept()
        threading.Thread(target=lambda c=conn: (time.sleep(600), c.close()), daemon=True).start()


def _banner(sock: socket.socket) -> None:
    while True:
        conn, _ = sock.accept()
        conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")


def _http(sock: socket.socket) -> None:
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args: Any) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet, bind_and_activate=False)
    server.socket = sock
    server.serve_forever()


def cluster(work: Path) -> Row:
    row = Row("cluster")
    body = json.dumps({"scenario": {"scans": 4, "clutter": 5}, "runs": 30, "seed": 1}).encode()
    notes = []
    for name, peer in (("silent", _silent), ("banner", _banner), ("http", _http)):
        sock = socket.socket()
        sock.bind(("127.0.0.1", 0))
        sock.listen(16)
        threading.Thread(target=peer, args=(sock,), daemon=True).start()
        env = {
            "PLOTGATE_DASK_SCHEDULER": f"tcp://127.0.0.1:{sock.getsockname()[1]}",
            "PLOTGATE_DASK_TIMEOUT_S": "5",
        }
        folder = work / f"cluster-{name}"
        with serve(folder, env=env) as (proc, url):
            sender = _Sender(url, row)
            started = time.monotonic()
            with httpx.Client(base_url=url, timeout=HANG_S) as http:
                status = sender.post(http, "/v1/initiation/evaluate", body)
            took = time.monotonic() - started
            if status != 503:
                row.fail(f"{name}: {status}")
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=15)
                stopped = "stopped"
            except subprocess.TimeoutExpired:
                row.hangs += 1
                stopped = "did not stop within 15 s of SIGTERM"
        recorded = _recorded(folder)
        row.missing += len(sender.answered.keys() - recorded)
        notes.append(f"{name}: {status} in {took:.1f} s, {stopped}")
    row.note = "; ".join(notes)
    return row


def files(work: Path) -> Row:
    """The hostile corpus of the tests, and files that are no regular file."""
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app
    from plotgate.service.config import Settings
    from plotgate.service.registry import execute
    from tests.support.hostile import corpus

    row = Row("files")
    settings = Settings(log_dir=work / "sound", git_commit="hostile")
    with TestClient(create_app(settings)) as c:
        for i in range(6):
            c.post("/v1/gates/test", json=GATE_TEST, headers={"x-request-id": f"s{i}"})
    [sound] = settings.log_dir.glob("*.mcap")
    body = json.dumps(GATE_TEST).encode()
    good = (body, 200, execute(OPERATIONS["gates.test"], body).content)
    out = work / "files"
    corpus(sound.read_bytes(), good, out)
    os.mkfifo(out / "fifo.mcap")
    unix = socket.socket(socket.AF_UNIX)
    unix.bind(str(out / "socket.mcap"))
    (out / "empty.mcap").write_bytes(b"")
    jobs = [
        [command, str(path)]
        for path in sorted(out.iterdir())
        for command in ("inspect", "cat", "replay", "recover")
    ]
    spec = work / "jobs.json"
    spec.write_text(json.dumps(jobs))
    peak = 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.support.hostile", str(spec)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        r = json.loads(line)
        row.cases += 1
        peak = max(peak, r["peak_kb"])
        out_text = r["stdout"] + r["stderr"]
        if r["escaped"] or "Traceback" in out_text or r["code"] not in (0, 1, 2):
            row.fail(f"{r['args']}: {r['escaped'] or out_text[-300:]}")
    try:
        proc.wait(timeout=HANG_S * 4)
    except subprocess.TimeoutExpired:
        proc.kill()
        row.hangs += 1
    row.hangs += len(jobs) - row.cases
    unix.close()
    row.note = f"peak RSS of one run {peak / 1024:.0f} MB"
    return row


class _Answers(http.server.BaseHTTPRequestHandler):
    """Answers every POST with 200 and the body its path names."""

    protocol_version = "HTTP/1.1"

    def log_message(self, *args: Any) -> None:
        pass

    def do_POST(self) -> None:  # noqa: N802 - http.server's name
        self.rfile.read(int(self.headers.get("content-length", 0)))
        kind = self.path.split("/")[1]
        if kind == "endless":
            self.send_response(200)
            self.send_header("content-type", "application/json")
            self.send_header("transfer-encoding", "chunked")
            self.end_headers()
            piece = b"[" * 65536
            with contextlib.suppress(OSError):
                for _ in range(200_000):  # 13 GB at most
                    self.wfile.write(b"%x\r\n%s\r\n" % (len(piece), piece))
            return
        body = {
            "html": b"<html><body>hello</body></html>",
            "truncated": b'{"kind": "combined", "inside": [tr',
            "schema": b'{"something": "else"}',
            "nan": b'{"kind":"combined","statistic_name":"x","threshold":NaN,"inside":[true],'
            b'"statistic":[NaN],"stage":["ring"],"count_inside":1}',
            "deep": b"[" * 100_000 + b"]" * 100_000,
            "empty": b"",
        }[kind]
        self.send_response(200)
        self.send_header("content-type", "application/json")
        self.send_header("content-length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)


def client(work: Path) -> Row:
    from plotgate.clients import Client, PlotgateClientError
    from plotgate.service.schemas import GateTestRequest

    row = Row("client")
    server = http.server.ThreadingHTTPServer(("127.0.0.1", free_port()), _Answers)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    request = GateTestRequest.model_validate(GATE_TEST)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for kind in ("html", "truncated", "schema", "nan", "deep", "empty", "endless"):
        url = f"http://127.0.0.1:{server.server_address[1]}/{kind}"
        with Client(url, retries=0, timeout=HANG_S) as c:
            row.cases += 1
            try:
                c.test_gate(request.gate, request.first, request.candidates)
                row.fail(f"{kind}: accepted")
            except PlotgateClientError:
                pass
            except Exception as exc:  # noqa: BLE001 - what must never happen
                row.fail(f"{kind}: {type(exc).__module__}.{type(exc).__name__}")
    grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    server.shutdown()
    row.note = f"the client's peak RSS grew {grown:.0f} MB"
    return row


CATEGORIES: dict[str, Callable[[Path], Row]] = {
    "bodies": bodies,
    "states": states,
    "auth": auth,
    "large": large,
    "folder deleted": lambda w: _fault("folder deleted", w, _delete, deletes=True),
    "SIGKILL": lambda w: _fault("SIGKILL", w, _kill),
    "disk full": lambda w: _fault("disk full", w, _fill),
    "cluster": cluster,
    "files": files,
    "client": client,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="write the rows here")
    parser.add_argument("--only", nargs="*", choices=list(CATEGORIES), default=list(CATEGORIES))
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only:
            started = time.monotonic()
            row = CATEGORIES[name](Path(tmp))
            row.note += f" ({time.monotonic() - started:.0f} s)"
            rows.append(row)
            print(json.dumps(asdict(row)), file=sys.stderr, flush=True)
    print("| category | cases | 5xx or tracebacks | hangs | answered missing | notes |")
    print("|---|---:|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r.category} | {r.cases} | {r.failures} | {r.hangs} | {r.missing} | {r.note} |")
    if args.json:
        args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1) + "\n")


if __name__ == "__main__":
    main()
