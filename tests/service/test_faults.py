"""Faults: a recorder that cannot write refuses to answer (503), a bug answers 500, both recorded
where they can be."""

import json

from fastapi.testclient import TestClient

from plotgate.clients.recordings import read_recording
from plotgate.service import registry
from plotgate.service.app import create_app
from plotgate.service.recording import recorder
from plotgate.service.recording.files import RecordingFile
from tests.support.requests import GOOD


class _Disk:
    """A simulated disk that can fill up: the recording's writes and the readiness probe
    fail."""

    def __init__(self, monkeypatch) -> None:
        self.full = False
        real_write = RecordingFile.write
        real_temporary = recorder.temporary_beside

        def write(file, buffers):
            if self.full:
                raise OSError(28, "No space left on device")
            return real_write(file, buffers)

        def probe_file(target, *args, **kwargs):
            if self.full and ".plotgate-probe-" in str(target):
                raise OSError(28, "No space left on device")
            return real_temporary(target, *args, **kwargs)

        monkeypatch.setattr(RecordingFile, "write", write)
        monkeypatch.setattr(recorder, "temporary_beside", probe_file)


def test_unrecordable_exchange_is_refused_then_recovers(settings, monkeypatch):
    disk = _Disk(monkeypatch)
    with TestClient(create_app(settings)) as c:
        assert c.post("/v1/gates/test", json=GOOD).status_code == 200
        disk.full = True
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "lost"})
        assert r.status_code == 503
        assert r.headers["content-type"].startswith("application/problem+json")
        assert "No space left" in r.json()["detail"]
        assert c.get("/readyz").status_code == 503
        disk.full = False
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "back"})
        assert r.status_code == 200
        assert c.get("/readyz").status_code == 200
    files = sorted(settings.log_dir.glob("*.mcap"))
    assert len(files) >= 2  # a file that failed is abandoned and a new one opened
    answered = {ex.request_id for f in files for ex in read_recording(f).exchanges if ex.response}
    assert "back" in answered and "lost" not in answered


def test_a_bug_answers_500_and_is_recorded(settings, monkeypatch, swap_handler):
    def broken(request):
        raise RuntimeError("boom")

    swap_handler("gates.test", broken)
    monkeypatch.setattr("plotgate.service.routes.OPERATIONS", registry.OPERATIONS)
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "bug"})
    assert r.status_code == 500 and r.json()["type"] == "urn:plotgate:problem:internal"
    [f] = settings.log_dir.glob("*.mcap")
    [ex] = read_recording(f).exchanges
    assert ex.response["status"] == 500 and ex.response["error"]["request_id"] == "bug"
    assert json.loads(ex.body) == GOOD


def test_best_effort_recording_answers_and_counts_the_unrecorded(settings, monkeypatch):
    _Disk(monkeypatch).full = True
    best = settings.model_copy(update={"record_best_effort": True})
    with TestClient(create_app(best)) as c:
        r = c.post("/v1/gates/test", json=GOOD)
        assert r.status_code == 200 and r.json()["inside"] == [True, True]
        assert c.get("/readyz").status_code == 503  # readiness still tells the truth
        metrics = c.get("/metrics").text
    assert 'plotgate_unrecorded_total{operation="gates.test"} 1.0' in metrics


def test_readiness_comes_back_with_the_disk_without_a_request(settings, monkeypatch):
    disk = _Disk(monkeypatch)
    with TestClient(create_app(settings)) as c:
        disk.full = True
        assert c.post("/v1/gates/test", json=GOOD).status_code == 503
        assert c.get("/readyz").status_code == 503
        disk.full = False
        assert c.get("/readyz").status_code == 200  # probed: no request needed
        assert c.post("/v1/gates/test", json=GOOD).status_code == 200
