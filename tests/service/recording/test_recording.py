"""Every exchange is recorded: 2N messages for N requests, read back by two MCAP readers."""

import json
import logging
import time
from pathlib import Path

from fastapi.testclient import TestClient
from mcap.reader import make_reader
from mcap.writer import Writer

from plotgate.clients.cli import main
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.recording import recorder as recorder_module
from plotgate.service.recording import rotation_bytes
from tests.support.requests import BAD_COV, GOOD


def _session(settings: Settings, n: int = 12) -> list[str]:
    """Send n requests, every third one bad in a different way; return their ids."""
    ids = []
    with TestClient(create_app(settings)) as c:
        for i in range(n):
            rid = f"req-{i}"
            headers = {"x-request-id": rid, "content-type": "application/json"}
            if i % 6 == 2:
                content = b'{"gate": {"kind": "combined", '
            elif i % 6 == 5:
                content = json.dumps(BAD_COV).encode()
            else:
                content = json.dumps(GOOD).encode()
            path = "/v1/gates/pairs" if i == 7 else "/v1/gates/test"
            if i == 7:
                content = json.dumps(
                    {
                        "gate": GOOD["gate"],
                        "pairs": [
                            {"first": GOOD["first"], "second": c_} for c_ in GOOD["candidates"]
                        ],
                    }
                ).encode()
            c.post(path, content=content, headers=headers)
            ids.append(rid)
    return ids


def test_every_exchange_is_recorded(settings, mcap_check):
    ids = _session(settings)
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    assert path.name.startswith("plotgate-") and "-pid" in path.name

    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [(ch.topic, json.loads(m.data)) for _, ch, m in reader.iter_messages()]
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert len(messages) == 2 * len(ids)
    requests = [d["request_id"] for t, d in messages if t.endswith("/request")]
    responses = {d["request_id"]: d for t, d in messages if t.endswith("/response")}
    assert sorted(requests) == sorted(ids) and set(responses) == set(ids)
    assert responses["req-2"]["status"] == 400 and responses["req-5"]["status"] == 422
    assert responses["req-5"]["error"]["errors"][0]["field"] == "candidates[0].covariance"
    assert responses["req-0"]["result"]["inside"] == [True, True]
    request_2 = next(
        d for t, d in messages if t.endswith("/request") and d["request_id"] == "req-2"
    )
    assert request_2["raw"] == '{"gate": {"kind": "combined", '
    assert {s.encoding for s in summary.schemas.values()} == {"jsonschema"}
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    assert metadata["plotgate"]["git_commit"] == "test"
    assert {"plotgate_version", "numpy", "scipy", "settings"} <= metadata["plotgate"].keys()

    code, report = mcap_check(path)
    assert code == 0, report["errors"]
    assert report["ok"] and not report["truncated"]
    assert report["total_messages"] == 2 * len(ids)
    assert report["json"]["invalid"] == 0


def test_replay_unchanged_then_changed(settings, tmp_path, capsys):
    _session(settings)
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    assert json.loads(report.read_text())["unchanged"] == 12

    altered = tmp_path / "altered.mcap"
    _rewrite(path, altered, "req-4", lambda d: d["result"]["statistic"].__setitem__(1, 0.25))
    capsys.readouterr()
    assert main(["replay", str(altered)]) == 1
    out = capsys.readouterr().out
    assert "req-4" in out and "statistic[1]" in out and "1 changed" in out

    failing = tmp_path / "failing.mcap"
    _rewrite(
        path,
        failing,
        "req-5",
        lambda d: d["error"]["errors"][0].__setitem__("field", "first.covariance"),
    )
    assert main(["replay", str(failing)]) == 1
    assert "req-5" in capsys.readouterr().out


def test_replay_writes_the_new_session(settings, tmp_path, mcap_check):
    _session(settings, 6)
    out = tmp_path / "replayed.mcap"
    assert main(["replay", str(settings.log_dir), "--out", str(out)]) == 0
    code, report = mcap_check(out)
    assert code == 0 and report["total_messages"] == 12
    assert main(["replay", str(out)]) == 0


def test_rotation_by_size(tmp_path, mcap_check, monkeypatch):
    monkeypatch.setattr(recorder_module, "MIN_ROTATE_BYTES", 4096)  # 30 exchanges, files
    settings = Settings(log_dir=tmp_path / "rec", rotate_bytes=4096)
    _session(settings, 30)
    files = sorted(settings.log_dir.glob("*.mcap"))
    assert len(files) > 1
    for f in files:
        assert mcap_check(f)[0] == 0
    assert main(["replay", str(settings.log_dir)]) == 0


def test_a_rotation_size_below_the_floor_is_raised_to_it(tmp_path, caplog):
    """PLOTGATE_ROTATE_BYTES below a file's head made every commit a file of its own (897
    files, 15 requests/s instead of 1,740); it is raised to its floor, with a warning."""
    settings = Settings(log_dir=tmp_path / "rec", rotate_bytes=1)
    with caplog.at_level(logging.WARNING, "plotgate"), TestClient(create_app(settings)) as c:
        for _ in range(4):
            assert c.post("/v1/gates/test", json=GOOD).status_code == 200
    assert len(list(settings.log_dir.glob("*.mcap"))) == 1
    assert any("below its floor" in r.getMessage() for r in caplog.records)
    assert rotation_bytes(1) == recorder_module.MIN_ROTATE_BYTES
    assert rotation_bytes(2**30) == 2**30


def test_rotation_by_age(tmp_path, mcap_check):
    settings = Settings(log_dir=tmp_path / "rec", rotate_age_s=0.2)
    with TestClient(create_app(settings)) as c:
        for _ in range(3):
            assert c.post("/v1/gates/test", json=GOOD).status_code == 200
            time.sleep(0.3)
    files = sorted(settings.log_dir.glob("*.mcap"))
    assert len(files) == 3
    assert all(mcap_check(f)[0] == 0 for f in files)


def test_inspect(settings, capsys):
    _session(settings)
    assert main(["inspect", str(settings.log_dir)]) == 0
    out = capsys.readouterr().out
    assert "gates.test" in out and "status 400: 2" in out and "status 422: 2" in out


def _rewrite(src: Path, dst: Path, request_id: str, change) -> None:
    """Copy a recording, applying ``change`` to the response of ``request_id``."""
    with open(src, "rb") as f, open(dst, "wb") as out:
        writer = Writer(out)
        writer.start()
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in make_reader(f).iter_messages():
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id]
                )
            data = json.loads(message.data)
            if channel.topic.endswith("/response") and data["request_id"] == request_id:
                change(data)
            writer.add_message(
                channels[channel.id],
                message.log_time,
                json.dumps(data).encode(),
                message.publish_time,
            )
        writer.finish()
