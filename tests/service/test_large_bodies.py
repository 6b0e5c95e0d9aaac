"""Large bodies are parsed, run and answered off the event loop, on a real served process:
``/healthz`` keeps answering (a generous hang-detecting bound, not a speed figure) while
the heaviest accepted ``gates.pairs`` body and bodies one item over the bound are
processed, every answer, accepted or refused, is the one an in-process
:func:`~plotgate.service.registry.execute` gives for the same bytes, and a worker process
killed with a body in it costs that one answer (503 worker-lost, recorded), not the next."""

import json
import os
import random
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import pytest

from plotgate.clients.recordings import read_recording
from plotgate.service.bodies import SLICE_BYTES
from plotgate.service.recording import request_record
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas.common import MAX_PLOTS
from tests.support.servers import health_watch, serve

HANG_S = 0.5
"""A /healthz answer slower than this is a stalled loop: it takes milliseconds, and at most
tens of them (74 ms measured) while the worker process answers a large body. Before, a
100,001-candidate body stalled it 0.75 s, the heaviest pairs body 3.2 s."""


def _plot(rng: random.Random, sensor: bool) -> dict:
    """A Cartesian plot; with its ``sensor``, it holds the most values a plot can hold."""
    plot = {
        "frame": "cartesian",
        "x": rng.uniform(-5e4, 5e4),
        "y": rng.uniform(-5e4, 5e4),
        "covariance": [[40000.0, 0.0], [0.0, 40000.0]],
    }
    if sensor:
        plot["sensor"] = [rng.uniform(-1e3, 1e3), rng.uniform(-1e3, 1e3)]
    return plot


def pairs_body(n: int, seed: int = 1) -> bytes:
    """``n`` pairs: up to the bound, each plot with its sensor (the heaviest body);
    beyond it, without, so the body holds fewer values than the heaviest valid one and
    only validation can refuse it."""
    rng = random.Random(seed)
    sensor = n <= MAX_PLOTS
    pairs = [{"first": _plot(rng, sensor), "second": _plot(rng, sensor)} for _ in range(n)]
    return json.dumps({"gate": {"kind": "ellipse", "P_G": 0.99}, "pairs": pairs}).encode()


def _candidates(n: int, seed: int = 2) -> bytes:
    """``n`` candidates, without their sensors (as :func:`pairs_body` beyond the bound)."""
    rng = random.Random(seed)
    body = {
        "gate": {"kind": "combined", "tau": 5, "v_min": 100, "v_max": 500, "P_G": 0.9},
        "first": _plot(rng, False),
        "candidates": [_plot(rng, False) for _ in range(n)],
    }
    return json.dumps(body).encode()


def _broken_covariance(n: int) -> bytes:
    """``n`` pairs, pairs[3].second's covariance one row short."""
    body = json.loads(pairs_body(n, seed=3))
    body["pairs"][3]["second"]["covariance"] = [[1.0, 0.0]]
    return json.dumps(body).encode()


def _malformed_text(size: int) -> bytes:
    """About ``size`` bytes of short non-ASCII strings, never closed: not JSON (a 400),
    so its request record keeps it as text, escaped character by character."""
    item = '"' + "é" * 50 + '"'
    return ('{"candidates": [' + ", ".join([item] * (size // (2 * len(item)))) + ",").encode()


BODIES = {  # name: (operation, body, status)
    "heaviest-pairs": ("gates.pairs", pairs_body(MAX_PLOTS), 200),
    "pairs-over-the-bound": ("gates.pairs", pairs_body(MAX_PLOTS + 1), 422),
    "candidates-over-the-bound": ("gates.test", _candidates(MAX_PLOTS + 1), 422),
    "large-broken-covariance": ("gates.pairs", _broken_covariance(2_000), 422),
    "large-malformed-text": ("gates.test", _malformed_text(40 * 2**20), 400),
}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """The answers of a served process to :data:`BODIES`, each with /healthz's latencies,
    seconds, timed while it was processed."""
    folder = tmp_path_factory.mktemp("large")
    answers = {}
    with (
        serve(folder / "recordings") as (_, url),
        httpx.Client(base_url=url, timeout=300) as http,
    ):
        for name, (operation, body, _) in BODIES.items():
            path = OPERATIONS[operation].path
            headers = {"content-type": "application/json", "x-request-id": name}
            with health_watch(url, folder) as latencies:
                r = http.post(path, content=body, headers=headers)
            latencies.sort()
            p99 = latencies[int(0.99 * (len(latencies) - 1))]
            print(f"{name}: /healthz max {latencies[-1] * 1e3:.0f} ms, p99 {p99 * 1e3:.0f} ms")
            answers[name] = r, latencies
    return answers


@pytest.mark.parametrize("name", BODIES)
def test_health_answers_while_a_large_body_is_processed(served, name):
    response, latencies = served[name]
    assert response.status_code == BODIES[name][2], response.text[:300]
    assert max(latencies) < HANG_S, f"/healthz took {max(latencies):.3f} s"


@pytest.mark.parametrize("name", BODIES)
def test_a_large_body_is_answered_as_in_process(served, name):
    response, _ = served[name]
    operation, body, status = BODIES[name]
    expected = execute(OPERATIONS[operation], body, request_id=name)
    assert response.status_code == expected.status == status
    assert response.content == expected.content


def test_refusals_name_the_request_own_field(served):
    fields = {
        name: [e["field"] for e in r.json().get("errors", [])] for name, (r, _) in served.items()
    }
    assert fields["pairs-over-the-bound"] == ["pairs"]
    assert fields["candidates-over-the-bound"] == ["candidates"]
    assert fields["large-broken-covariance"] == ["pairs[3].second.cartesian.covariance[1]"]
    assert len(served["heaviest-pairs"][0].json()["inside"]) == MAX_PLOTS


def _workers(server: int) -> list[int]:
    """The pids of the server's worker processes, one a lane (multiprocessing's resource
    tracker, also a child, is not one)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            command = (stat.parent / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue  # gone meanwhile
        if parent == server and b"spawn_main" in command:
            found.append(int(stat.parent.name))
    assert found, f"the server {server} has no worker process"
    return found


def _busy_worker(server: int, pending, deadline_s: float = 120) -> int:
    """The worker that starts parsing a body (its CPU time grows by half a second)."""
    idle = {pid: _cpu_s(pid) for pid in _workers(server)}
    deadline = time.monotonic() + deadline_s
    while True:
        for pid, was in idle.items():
            if _cpu_s(pid) > was + 0.5:
                return pid
        assert time.monotonic() < deadline and not pending.done()
        time.sleep(0.05)


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_a_worker_killed_mid_body_costs_that_answer_only(tmp_path):
    path = OPERATIONS["gates.pairs"].path
    small = pairs_body(2_000)  # over INLINE_BODY_BYTES: the worker's
    heaviest = BODIES["heaviest-pairs"][1]
    with (
        serve(tmp_path / "recordings") as (proc, url),
        httpx.Client(base_url=url, timeout=300) as http,
        ThreadPoolExecutor(1) as sender,
    ):
        assert http.post(path, content=small).status_code == 200  # the workers start
        pending = sender.submit(http.post, path, content=heaviest, headers={"x-request-id": "k"})
        os.kill(_busy_worker(proc.pid, pending), signal.SIGKILL)  # parsing the heaviest body
        killed = pending.result(timeout=300)
        assert http.post(path, content=heaviest).status_code == 200  # a new worker
        assert http.post(path, content=small).status_code == 200  # the other lane's
    # a fault, not an answer: 503 with its cause, recorded, set aside by replay
    assert killed.status_code == 503 and killed.headers["retry-after"]
    assert killed.json()["type"] == "urn:plotgate:problem:worker-lost"
    assert "died" in killed.json()["detail"]
    recorded = {
        ex.request_id: ex
        for f in (tmp_path / "recordings").glob("*.mcap")
        for ex in read_recording(f).exchanges
    }
    assert recorded["k"].response is not None and recorded["k"].response["status"] == 503


def test_the_worker_dies_with_a_killed_server(tmp_path):
    path = OPERATIONS["gates.pairs"].path
    with (
        serve(tmp_path / "recordings") as (proc, url),
        httpx.Client(base_url=url, timeout=300) as http,
        ThreadPoolExecutor(1) as sender,
    ):
        assert http.post(path, content=pairs_body(2_000)).status_code == 200  # the workers start
        pending = sender.submit(http.post, path, content=BODIES["heaviest-pairs"][1])
        workers = _workers(proc.pid)
        _busy_worker(proc.pid, pending)  # one is parsing the heaviest body
        proc.kill()
        proc.wait(timeout=30)
        with pytest.raises(httpx.TransportError):
            pending.result(timeout=60)
        deadline = time.monotonic() + 30
        for worker in workers:
            while Path(f"/proc/{worker}").exists() and _state(worker) != "Z":
                assert time.monotonic() < deadline, "a worker outlived its server by 30 s"
                time.sleep(0.05)


def _state(pid: int) -> str:
    """A process's state letter (Z: a zombie, dead but not yet reaped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"


@pytest.mark.parametrize("cut", [0, 1, 2, 3])
def test_a_large_text_record_keeps_every_character_cut_by_a_slice(cut):
    # a 4-byte character and an invalid byte straddle each slice boundary, offset by cut
    head = b"x" * (SLICE_BYTES - cut)
    body = head + '\U0001f4e1 caf\u00e9 "q" \\'.encode() + b"\xff\xc3" + head + b"\x01\xe9"
    record = json.loads(request_record("r", "gates.test", body, strict_json=False))
    assert record["raw"] == body.decode("utf-8", "backslashreplace")
