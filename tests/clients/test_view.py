"""``plotgate view``: a recorded session of all 17 operations as a Foxglove scene whose every
message validates against Foxglove's published schemas, the originals kept; its exit codes."""

import json
import os
from pathlib import Path

import pytest

from plotgate.clients import recordings
from plotgate.clients.cli import main
from plotgate.clients.recordings import Reader
from plotgate.clients.view import view
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.scenes import LOG_TOPIC, SCENE_PREFIX, TRANSFORM_TOPIC, Encoded
from plotgate.service.table import ENDPOINTS
from tests.support.view_reference import content, reference

EXAMPLES = {name: e.example for name, e in ENDPOINTS.items()}


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A recording of every operation's example, a refused request (422) and a request
    never answered, as the service's recorder writes them."""
    folder = tmp_path_factory.mktemp("session")
    recorder = Recorder(folder, OPERATIONS.values()).start()
    bodies = list(EXAMPLES.items()) + [("gates.test", {"gate": {"kind": "ellipse"}})]
    for i, (operation, body) in enumerate(bodies):
        data = json.dumps(body).encode()
        answer = execute(OPERATIONS[operation], data)
        written = recorder.request(operation, request_record(f"r{i}", operation, data))
        record = response_record(f"r{i}", operation, answer.status, 0.01, answer.content)
        recorder.response(written, record)
        recorder.flush()
        recorder.forget(written)
    recorder.request("gates.pairs", request_record("lost", "gates.pairs", b"{}"))
    recorder.flush()
    recorder.close()
    return folder


def test_every_scene_message_validates_against_foxglove_schemas(session, tmp_path, foxglove_check):
    out = tmp_path / "scene.mcap"
    report = view(session, out, Encoded())
    assert report.exchanges == len(EXAMPLES) + 2
    code, checked = foxglove_check(out)
    assert code == 0, checked["invalid"]
    assert set(checked["byTopic"]) >= {SCENE_PREFIX + op for op in OPERATIONS} | {
        LOG_TOPIC,
        TRANSFORM_TOPIC,
    }
    assert checked["bySchema"]["foxglove.SceneUpdate"] == len(EXAMPLES) + 1
    assert checked["bySchema"]["foxglove.Log"] == 2  # the 422, the request never answered


def test_the_original_records_are_kept_byte_for_byte(session, tmp_path):
    out = tmp_path / "scene.mcap"
    report = view(session, out, Encoded())
    key = lambda ex: (ex.request_id, ex.request_bytes, ex.response_bytes)  # noqa: E731
    recorded = sorted(map(key, Reader(session)))
    copied = Reader(out)
    assert sorted(map(key, copied)) == recorded
    # the scene channels are read as scenes, not damage (issue 37)
    assert copied.files[0].damage_count == 0
    assert copied.files[0].scene_messages == report.scene_messages > 0


def test_the_readers_know_the_scene_topics_view_writes():
    assert recordings.SCENE_PREFIX == SCENE_PREFIX
    assert (recordings.LOG_TOPIC, recordings.TRANSFORM_TOPIC) == (LOG_TOPIC, TRANSFORM_TOPIC)


def test_inspect_cat_and_recover_read_a_view_file_without_damage(session, tmp_path, capsys):
    out = tmp_path / "scene.mcap"
    scenes = view(session, out, Encoded()).scene_messages
    assert main(["inspect", str(out)]) == 0
    printed = capsys.readouterr()
    assert "damaged" not in printed.out + printed.err
    assert f", {scenes} scene messages" in printed.out
    assert main(["cat", str(out)]) == 0
    assert capsys.readouterr().err == ""
    copy = tmp_path / "copy.mcap"
    assert main(["recover", str(out), "--out", str(copy), "--keep"]) == 0
    reader = Reader(copy)
    assert len(list(reader)) == len(list(Reader(out)))
    assert reader.files[0].damage_count == 0 and reader.files[0].scene_messages == scenes


def test_filters_take_what_inspect_takes(session, tmp_path):
    out = tmp_path / "gates.mcap"
    assert main(["view", str(session), "-o", str(out), "--operation", "gates.test"]) == 0
    assert {ex.operation for ex in Reader(out)} == {"gates.test"}


def test_bad_inputs_end_with_a_message_and_exit_2(session, tmp_path, capsys):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    out = tmp_path / "out.mcap"
    assert main(["view", str(empty), "-o", str(out)]) == 2
    assert not out.exists()  # nothing read, nothing written
    assert main(["view", str(tmp_path / "missing"), "-o", str(out)]) == 2
    [recording] = session.glob("*.mcap")
    assert main(["view", str(session), "-o", str(recording)]) == 2
    assert "is one of the recordings read" in capsys.readouterr().err
    missing = tmp_path / "no" / "dir.mcap"
    assert main(["view", str(session), "-o", str(missing)]) == 2
    assert f"plotgate view: {missing}: No such file or directory" in capsys.readouterr().err
    assert main(["view", str(session), "-o", str(tmp_path)]) == 2  # a folder: named as given
    assert f"plotgate view: {tmp_path}: exists and is a folder" in capsys.readouterr().err
    assert not list(tmp_path.glob(".*.partial"))


def test_a_cut_file_gives_its_intact_exchanges(tmp_path, capsys):
    recorder = Recorder(tmp_path / "live", OPERATIONS.values()).start()
    body = json.dumps(EXAMPLES["gates.test"]).encode()
    answer = execute(OPERATIONS["gates.test"], body)
    for i in range(10):
        written = recorder.request("gates.test", request_record(f"r{i}", "gates.test", body))
        record = response_record(f"r{i}", "gates.test", 200, 0.01, answer.content)
        recorder.response(written, record)
        recorder.flush()
        recorder.forget(written)
    [live] = (tmp_path / "live").glob("*.mcap")  # unchunked, no footer: being written
    data = live.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: data.index(b'"r7"') + 20])  # a killed server's file, cut mid-record
    recorder.close()
    out = tmp_path / "out.mcap"
    assert main(["view", str(cut), "-o", str(out)]) == 0
    assert sum(1 for ex in Reader(out) if ex.response_bytes is not None) == 7
    assert "7 exchanges" in capsys.readouterr().out  # r7 cut in its request: not read


def test_without_foxglove_sdk_view_says_how_to_get_it(session, tmp_path, monkeypatch, capsys):
    for name in list(os.sys.modules):
        if name == "foxglove" or name.startswith(("foxglove.", "plotgate.service.scenes")):
            monkeypatch.delitem(os.sys.modules, name)
    monkeypatch.setitem(os.sys.modules, "foxglove", None)  # import foxglove fails
    assert main(["view", str(session), "-o", str(tmp_path / "out.mcap")]) == 2
    assert "plotgate[view]" in capsys.readouterr().err


def test_the_layout_shows_every_scene_topic_top_down():
    layout = json.loads((Path(__file__).parents[2] / "docs/foxglove_layout.json").read_text())
    three = layout["configById"]["3D!plotgate"]
    assert set(three["topics"]) == {SCENE_PREFIX + op for op in OPERATIONS}
    assert three["cameraState"]["phi"] == 0 and three["followTf"] == "radar"  # from above
    assert layout["configById"]["RawMessages!plotgate"]["topicPath"] == LOG_TOPIC
    for path in layout["configById"]["Plot!plotgate"]["paths"]:
        topic = path["value"].split('"')[1]
        assert topic.split("/")[0] in OPERATIONS and topic.endswith("/response")


def _many(folder: Path, n: int) -> Path:
    """``n`` gates.test exchanges of assorted gates and plots, a second apart in places (the
    transforms), a few failed or odd: more than one batch of view's drawing."""
    recorder = Recorder(folder, OPERATIONS.values()).start()
    base = EXAMPLES["gates.test"]
    gates = [
        {"kind": "ellipse", "P_G": 0.9},
        {"kind": "ring", "v_min": 50.0, "v_max": 300.0, "tau": 2.0},
        {"kind": "expanded", "v_max": 300.0, "tau": 1.0},
        {"kind": "rectangular", "k": 3.0},
    ]
    t = 1_764_000_000_000_000_000
    for i in range(n):
        body = dict(base, gate=gates[i % len(gates)])
        if i % 17 == 5:
            body = {"gate": {"kind": "ellipse"}}  # refused: 422
        data = json.dumps(body).encode()
        answer = execute(OPERATIONS["gates.test"], data)
        t += 700_000_000 if i % 9 == 0 else 1_000_000
        written = recorder.request("gates.test", request_record(f"r{i}", "gates.test", data), t)
        record = response_record(f"r{i}", "gates.test", answer.status, 0.002, answer.content)
        recorder.response(written, record, t + 2_000_000)
        recorder.flush()
        recorder.forget(written)
    recorder.close()
    return folder


@pytest.mark.parametrize("recording", ["session", "many"])
def test_the_scenes_are_those_of_the_writer_before_issue_40(recording, session, tmp_path):
    folder = session if recording == "session" else _many(tmp_path / "many", 150)
    out, before = tmp_path / "scene.mcap", tmp_path / "reference.mcap"
    report = view(folder, out, Encoded())
    reference(folder, before)
    messages, statistics = content(out)
    assert (messages, statistics) == content(before)
    assert report.scene_messages == sum(m[0].startswith(("/scene/", "/log")) for m in messages)
