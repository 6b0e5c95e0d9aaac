"""A server killed with SIGKILL mid-stream loses no exchange a client saw answered."""

import json
import threading
import time

import httpx

from plotgate.clients import Client
from plotgate.clients.recordings import read_recording
from plotgate.service.schemas import CombinedGate, GateTestRequest
from tests.support.requests import GOOD
from tests.support.servers import serve


def test_sigkill_keeps_every_answered_exchange(tmp_path, mcap_check):
    answered: list[str] = []
    stop = threading.Event()
    body = json.dumps(GOOD).encode()

    def load(url: str, worker: int) -> None:
        with httpx.Client(base_url=url, timeout=10) as http:
            for i in range(100_000):
                if stop.is_set():
                    return
                rid = f"w{worker}-{i}"
                try:
                    r = http.post(
                        "/v1/gates/test",
                        content=body,
                        headers={"x-request-id": rid, "content-type": "application/json"},
                    )
                except httpx.TransportError:
                    return
                if r.status_code == 200:
                    answered.append(rid)

    with serve(tmp_path) as (proc, url):
        threads = [threading.Thread(target=load, args=(url, k)) for k in range(8)]
        for t in threads:
            t.start()
        deadline = time.monotonic() + 60
        while len(answered) < 300 and time.monotonic() < deadline:
            time.sleep(0.02)
        proc.kill()  # mid-stream: eight clients are still sending
        proc.wait(timeout=10)
        stop.set()
        for t in threads:
            t.join(timeout=30)

    [path] = sorted(tmp_path.glob("*.mcap"))
    rec = read_recording(path)
    assert not rec.complete and rec.stopped_by is not None
    recorded = {ex.request_id for ex in rec.exchanges if ex.response is not None}
    assert len(answered) >= 300
    missing = set(answered) - recorded
    assert not missing, f"{len(missing)} answered exchanges missing, e.g. {sorted(missing)[:5]}"

    code, report = mcap_check(path)
    assert code == 1 and report["truncated"]
    assert report["recovered_messages"] >= 2 * len(answered)

    # plotgate recover: a complete, indexed copy the independent checker accepts, holding
    # every answered exchange; the original is set aside, so replay reads each once
    from plotgate.clients.cli import main

    assert main(["recover", str(path)]) == 0
    copy = path.with_name(f"{path.stem}.recovered.mcap")
    assert not path.exists() and path.with_name(path.name + ".partial").exists()
    code, report = mcap_check(copy)
    assert code == 0 and report["ok"] and not report["truncated"], report["errors"]
    fixed = read_recording(copy)
    assert fixed.complete and not set(answered) - {
        ex.request_id for ex in fixed.exchanges if ex.response is not None
    }
    assert fixed.metadata["plotgate"] == rec.metadata["plotgate"]
    assert sorted(p.name for p in tmp_path.glob("*.mcap")) == [copy.name]


def test_sync_client_against_a_live_server(tmp_path):
    request = GateTestRequest.model_validate(GOOD)
    assert isinstance(request.gate, CombinedGate)
    with serve(tmp_path) as (_, url), Client(url) as client:
        assert client.ready()
        result = client.test_gate(request.gate, request.first, request.candidates)
    assert result.inside == [True, True]
    assert result.stage == ["ring", "outer_ellipse"]


def test_replay_reads_a_truncated_file(tmp_path, capsys):
    from plotgate.clients.cli import main

    body = json.dumps(GOOD).encode()
    with serve(tmp_path) as (proc, url), httpx.Client(base_url=url) as http:
        for _ in range(20):
            http.post("/v1/gates/test", content=body, headers={"content-type": "application/json"})
        proc.kill()
        proc.wait(timeout=10)
    capsys.readouterr()
    assert main(["replay", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "unfinished (no footer" in out and "40 messages read" in out and "20 unchanged" in out


def test_workers_write_their_own_files(tmp_path):
    body = json.dumps(GOOD).encode()
    ids = [f"r{i}" for i in range(60)]
    with serve(tmp_path, "--workers", "2") as (_, url):
        for rid in ids:  # a new connection each time, so both workers take requests
            r = httpx.post(
                url + "/v1/gates/test",
                content=body,
                headers={"content-type": "application/json", "x-request-id": rid},
            )
            assert r.status_code == 200
    files = sorted(tmp_path.glob("*.mcap"))
    pids = {f.name.split("-pid")[1].split("-")[0] for f in files}
    assert len(pids) == len(files) >= 1  # a worker that served requests has its own file
    recordings = [read_recording(f) for f in files]
    assert all(rec.complete for rec in recordings)
    answered = sorted(ex.request_id for rec in recordings for ex in rec.exchanges if ex.response)
    assert answered == sorted(ids)


def test_replay_against_a_live_server(tmp_path, capsys):
    from plotgate.clients.cli import main

    body = json.dumps(GOOD).encode()
    recorded = tmp_path / "recorded"
    with serve(recorded) as (_, url), httpx.Client(base_url=url) as http:
        for content in (body, b"{not json", json.dumps(dict(GOOD, first={})).encode()):
            http.post(
                "/v1/gates/test", content=content, headers={"content-type": "application/json"}
            )
    with serve(tmp_path / "replayed") as (_, url):
        capsys.readouterr()
        assert main(["replay", str(recorded), "--server", url]) == 0
    assert "3 compared: 3 unchanged" in capsys.readouterr().out


def test_sigterm_finishes_in_flight_requests_and_finalizes_the_file(tmp_path):
    import signal

    result: dict[str, int] = {}
    slow = {"scenario": {"clutter": 50}, "runs": 150, "seed": 1}  # about a second

    def call(url: str) -> None:
        r = httpx.post(
            url + "/v1/initiation/evaluate",
            json=slow,
            timeout=60,
            headers={"x-request-id": "in-flight"},
        )
        result["status"] = r.status_code

    with serve(tmp_path) as (proc, url):
        thread = threading.Thread(target=call, args=(url,))
        thread.start()
        time.sleep(0.3)  # the request is being computed
        proc.send_signal(signal.SIGTERM)
        thread.join(timeout=60)
        # uvicorn shuts down gracefully, then re-raises the signal: exit by SIGTERM
        assert proc.wait(timeout=30) in (0, -signal.SIGTERM)
    assert result == {"status": 200}
    [path] = sorted(tmp_path.glob("*.mcap"))
    rec = read_recording(path)
    assert rec.complete  # summary, index and footer written on the way out
    [exchange] = rec.exchanges
    assert exchange.request_id == "in-flight" and exchange.response["status"] == 200


def test_work_past_the_graceful_timeout_is_answered_503_and_recorded(tmp_path):
    """SIGTERM while an operation computes for longer than PLOTGATE_GRACEFUL_SHUTDOWN_S:
    uvicorn would cancel the request at the end and answer a bare 500, unrecorded. A
    second before, the request is answered 503 ``shutting-down`` (a client retries it
    elsewhere), both records are on disk, and the server stops within its grace."""
    import signal

    # a long in-process Monte Carlo (a worker thread: initiation.evaluate is slow)
    body = {"scenario": {"clutter": 250}, "runs": 4_000, "seed": 1}
    outcome: dict[str, httpx.Response] = {}
    env = {  # past the one-core default cap on purpose: this is work that outlives the grace
        "PLOTGATE_GRACEFUL_SHUTDOWN_S": "3",
        "PLOTGATE_LIMITS": '{"initiation.evaluate": {"runs x scans x plots": 10000000}}',
    }
    log = tmp_path / "serve.log"

    def post(url: str) -> None:
        outcome["r"] = httpx.post(
            url + "/v1/initiation/evaluate",
            json=body,
            headers={"x-request-id": "cut-off"},
            timeout=120,
        )

    with serve(tmp_path / "recordings", env=env, log=log) as (proc, url):
        thread = threading.Thread(target=post, args=(url,), daemon=True)
        thread.start()
        time.sleep(2.0)  # received and computing
        stopping = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) in (0, -signal.SIGTERM)
        stopped = time.monotonic()
        thread.join(timeout=30)
    assert stopped - stopping < 3 + 10  # the grace, and a loaded machine's margin
    r = outcome["r"]
    assert r.status_code == 503 and r.headers["retry-after"] == "1", r.text
    assert r.json()["type"] == "urn:plotgate:problem:shutting-down"
    assert "timeout graceful shutdown exceeded" not in log.read_text()
    [path] = sorted((tmp_path / "recordings").glob("*.mcap"))
    [exchange] = read_recording(path).exchanges
    assert exchange.request_id == "cut-off" and exchange.response["status"] == 503
