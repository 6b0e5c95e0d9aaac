"""The recordings folder deleted or replaced while serving (an operator's ``rm -rf``, a
volume unmounted), and writes that fail: the server never answers an exchange whose records
are not on disk, it writes lost records again to a new file (the folder created again),
refuses with 503 only when that fails too, and readiness comes back by itself, with no
traffic."""

import asyncio
import contextlib
import json
import shutil
import threading
import time
from collections import Counter
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from plotgate.clients.recordings import read_recording
from plotgate.service.app import create_app
from plotgate.service.recording import Recorder, RecordingError, request_record, response_record
from plotgate.service.recording.files import RecordingFile
from plotgate.service.registry import OPERATIONS
from tests.support.requests import GOOD
from tests.support.servers import serve

CLIENTS, EACH = 10, 60
RECOVERY_S = 2.5
"""Stated recovery time: the probe interval (1 s) plus slack for a loaded 2-core machine."""


def _answered(folder: Path) -> dict[str, dict]:
    """Request id -> request record, for every exchange with both records on disk."""
    return {
        ex.request_id: ex.request
        for f in sorted(folder.glob("*.mcap"))
        for ex in read_recording(f).exchanges
        if ex.response is not None
    }


def _remove(folder: Path) -> None:
    """``rm -rf`` that wins the race against a server creating files in the folder."""
    while folder.exists():
        shutil.rmtree(folder, ignore_errors=True)


def test_folder_deleted_under_load_loses_no_answered_exchange(tmp_path):
    folder = tmp_path / "recordings"
    body = json.dumps(GOOD).encode()
    sent_after: set[str] = set()  # sent once the deletion had finished
    answered: set[str] = set()
    statuses: Counter[int] = Counter()
    lock = threading.Lock()
    deleted = threading.Event()

    def client(k: int, url: str) -> None:
        with httpx.Client(base_url=url, timeout=60) as http:
            for i in range(EACH):
                rid = f"c{k}-{i}"
                after = deleted.is_set()
                r = http.post(
                    "/v1/gates/test",
                    content=body,
                    headers={"content-type": "application/json", "x-request-id": rid},
                )
                with lock:
                    statuses[r.status_code] += 1
                    if r.status_code == 200:
                        answered.add(rid)
                        if after:
                            sent_after.add(rid)
                    else:
                        assert r.status_code == 503, r.text
                        assert r.headers["retry-after"] == "1"

    with serve(folder) as (_, url):
        threads = [threading.Thread(target=client, args=(k, url)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        while len(answered) < CLIENTS * EACH // 4:
            time.sleep(0.01)
        _remove(folder)
        deleted.set()
        for t in threads:
            t.join(timeout=300)
        on_disk = _answered(folder)  # the open file included: every flush reached the OS
        # idle now: delete it again and let nothing but the server's own probe bring it back
        _remove(folder)
        gone_at = time.monotonic()
        while not folder.is_dir():
            assert time.monotonic() - gone_at < RECOVERY_S, "the folder was not re-created"
            time.sleep(0.02)
        assert httpx.get(url + "/readyz").status_code == 200
        last = httpx.post(
            url + "/v1/gates/test",
            content=body,
            headers={"content-type": "application/json", "x-request-id": "last"},
        )
        assert last.status_code == 200
    assert statuses[200] >= CLIENTS * EACH * 0.9, statuses  # refusals are rare races at most
    assert len(sent_after) > CLIENTS  # the fault happened mid-load
    missing = sent_after - set(on_disk)
    assert not missing, f"{len(missing)} answered exchanges not on disk: {sorted(missing)[:5]}"
    assert _answered(folder)["last"]["body"] == GOOD


def test_in_flight_exchange_is_written_again_after_its_file_is_deleted(tmp_path):
    folder = tmp_path / "recordings"
    recorder = Recorder(folder, OPERATIONS.values()).start()
    early = recorder.request("gates.test", b'{"request_id": "early", "operation": "gates.test"}')
    recorder.flush()
    shutil.rmtree(folder)
    recorder.response(
        early,
        b'{"request_id": "early", "operation": "gates.test", '
        b'"status": 200, "duration_s": 0.1, "result": {}}',
    )
    recorder.flush()
    recorder.close()
    [path] = folder.glob("*.mcap")
    [exchange] = read_recording(path).exchanges
    assert exchange.request_id == "early" and exchange.response["status"] == 200
    assert recorder.rewritten == 2


def test_unwritable_folder_answers_503_with_retry_after_then_recovers(settings):
    folder = settings.log_dir
    with TestClient(create_app(settings)) as c:
        assert c.post("/v1/gates/test", json=GOOD).status_code == 200
        while not folder.is_file():  # the mount point is gone, a file in its place
            _remove(folder)
            with contextlib.suppress(IsADirectoryError):  # the server's probe was quicker
                folder.write_text("not a folder")
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "refused"})
        assert r.status_code == 503 and r.headers["retry-after"] == "1"
        assert r.json()["type"] == "urn:plotgate:problem:recording-unavailable"
        ready = c.get("/readyz")
        assert ready.status_code == 503 and ready.headers["retry-after"] == "1"
        folder.unlink()
        gone_at = time.monotonic()
        while not folder.is_dir():  # the server's own probe, no request
            assert time.monotonic() - gone_at < RECOVERY_S
            time.sleep(0.02)
        assert c.get("/readyz").status_code == 200
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "back"})
        assert r.status_code == 200
    on_disk = _answered(folder)
    assert "back" in on_disk and "refused" not in on_disk


class _FailingFlushes:
    """The recording file's writes failing the next ``n`` times (a disk that refuses one)."""

    def __init__(self, monkeypatch, n: int) -> None:
        self.n = n
        real = RecordingFile.write

        def write(file, buffers):
            if self.n > 0:
                self.n -= 1
                raise OSError(5, "Input/output error")
            return real(file, buffers)

        monkeypatch.setattr(RecordingFile, "write", write)


def _exchange(recorder: Recorder, rid: str):
    head = b'{"request_id": "%s", "operation": "gates.test"' % rid.encode()
    exchange = recorder.request("gates.test", head + b"}")
    recorder.response(exchange, head + b', "status": 200, "duration_s": 0.1, "result": {}}')
    return exchange


def test_a_failed_write_is_written_again_to_a_new_file(tmp_path, monkeypatch):
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()
    _exchange(recorder, "before")
    recorder.flush()
    failing = _FailingFlushes(monkeypatch, 1)
    _exchange(recorder, "during")
    recorder.flush()  # fails once, then writes both records again to a new file
    assert failing.n == 0 and recorder.ready and recorder.rewritten == 2
    recorder.close()
    files = sorted(tmp_path.glob("*.mcap"))
    assert len(files) == 2
    answered = [
        ex.request_id
        for f in files
        for ex in read_recording(f).exchanges
        if ex.response is not None
    ]
    assert sorted(answered) == ["before", "during"]


def test_two_failed_writes_refuse_the_answers_waiting_on_them(tmp_path, monkeypatch):
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()

    async def answer() -> None:
        exchange = await recorder.arequest("gates.test", b'{"request_id": "x"}')
        await recorder.aresponse(exchange, b'{"request_id": "x", "status": 200}')

    _FailingFlushes(monkeypatch, 2)
    with pytest.raises(RecordingError, match="Input/output error"):
        asyncio.run(answer())
    assert not recorder.ready
    assert recorder.probe() and recorder.ready  # the folder itself is fine
    recorder.close()


def test_a_request_written_before_a_rotation_is_written_again_when_the_folder_goes(tmp_path):
    """A slow operation's request flushed to a file that then rotated (by age): the folder
    removed before it is answered, its request is written again beside its response."""
    op = OPERATIONS["gates.test"]
    folder = tmp_path / "rec"

    async def session() -> Recorder:
        rec = Recorder(folder, OPERATIONS.values(), max_age_s=0.2).start()
        slow = await rec.arequest(op.name, request_record("SLOW", op.name, b"{}", True))
        await asyncio.sleep(0.3)  # flushed to file 1, now past its age
        fast = await rec.arequest(op.name, request_record("FAST", op.name, b"{}", True))
        await rec.aresponse(fast, response_record("FAST", op.name, 200, 0.001, b"{}"))
        assert rec.rotations == 1
        shutil.rmtree(folder)
        await rec.aresponse(slow, response_record("SLOW", op.name, 200, 0.3, b"{}"))
        rec.close()
        return rec

    rec = asyncio.run(session())
    assert rec.rewritten >= 1
    assert "SLOW" in _answered(folder)


def test_bytes_written_never_goes_down_across_a_rotation(tmp_path):
    """A rotated file's bytes stay counted while it is compacted (a Prometheus counter
    must not go down): bytes_written counts what was written, before compaction."""
    op = OPERATIONS["gates.test"]

    async def session() -> tuple[Recorder, list[int]]:
        rec = Recorder(tmp_path / "rec", OPERATIONS.values(), max_bytes=1).start()
        seen = []
        for i in range(12):
            ex = await rec.arequest(op.name, request_record(f"r{i}", op.name, b"{}", True))
            await rec.aresponse(ex, response_record(f"r{i}", op.name, 200, 0.001, b"{}"))
            seen.append(rec.bytes_written)
        rec.close()
        seen.append(rec.bytes_written)
        return rec, seen

    rec, seen = asyncio.run(session())
    assert seen == sorted(seen), seen
    assert rec.rotations > 0 and rec.compacting == []
    assert len(list((tmp_path / "rec").glob("*.mcap"))) == len(rec.files)


def test_a_file_in_place_of_the_moved_folder_makes_readyz_503_not_500(settings, tmp_path):
    """The folder moved away (its open file with it, still linked) and a file put in its
    place: the recorder's check of its file's name meets ENOTDIR, which is a move, not a
    bug; /readyz says 503 until the folder is back, and the moved file keeps its records."""
    folder, moved = settings.log_dir, tmp_path / "moved"
    with TestClient(create_app(settings)) as c:
        assert (
            c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "a"}).status_code == 200
        )
        folder.rename(moved)
        folder.write_text("not a folder")
        ready = c.get("/readyz")
        assert ready.status_code == 503 and ready.headers["retry-after"] == "1"
        assert ready.headers["content-type"] == "application/problem+json"
        r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "refused"})
        assert r.status_code == 503
        folder.unlink()
        assert c.get("/readyz").status_code == 200
        assert (
            c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "b"}).status_code == 200
        )
    assert set(_answered(moved)) == {"a"} and set(_answered(folder)) == {"b"}


def test_serve_into_a_file_is_a_message_and_exit_2(tmp_path, capsys, monkeypatch):
    """A file where the recordings folder should be: one line and exit 2 before the
    server starts, not the app's start-up traceback and uvicorn's exit 3."""
    from plotgate.clients.cli import main
    from tests.support.servers import free_port

    for name in ("PLOTGATE_HOST", "PLOTGATE_PORT", "PLOTGATE_LOG_DIR"):  # serve sets them
        monkeypatch.setenv(name, "")
    folder = tmp_path / "recordings"
    folder.write_text("not a folder")
    code = main(
        ["serve", "--host", "127.0.0.1", "--port", str(free_port()), "--log-dir", str(folder)]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert (
        err.startswith(f"plotgate serve: cannot create the folder {folder}: ")
        and "Traceback" not in err
    )
