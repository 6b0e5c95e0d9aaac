"""plotgate replay as a regression gate: its exit code (0 unchanged, 1 changed, 2 nothing
comparable or unusable input), the tally (exchanges = compared + not compared, compared =
unchanged + changed, each exchange once, across files), and no traceback on any of it."""

import json
import os
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given
from hypothesis import settings as hsettings
from hypothesis import strategies as st
from mcap.writer import Writer

from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.clients.replay import (
    BODY_TIMEOUT,
    CLIENT_GONE,
    NEVER_ANSWERED,
    OVER_CAPS,
    REFUSED_FOR_THE_SERVER,
    replay,
)
from plotgate.service import registry
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.problems import ProblemError, problem_json
from plotgate.service.recording import request_record, response_record
from plotgate.service.recording.files import RecordingFile
from plotgate.service.registry import OPERATIONS, execute
from tests.support.recorded import write_files
from tests.support.requests import BAD_COV, GOOD

OP = "gates.test"
GOOD_BODY = json.dumps(GOOD).encode()
BAD_BODY = json.dumps(BAD_COV).encode()


def _answers() -> dict[str, tuple[bytes, int, bytes]]:
    """What this build answers, by kind of exchange: (body, status, answer)."""
    good, bad = execute(OPERATIONS[OP], GOOD_BODY), execute(OPERATIONS[OP], BAD_BODY)
    changed = json.loads(good.content)
    changed["statistic"][0] += 1.0
    return {
        "ok": (GOOD_BODY, good.status, good.content),
        "refused": (BAD_BODY, bad.status, bad.content),
        "changed": (GOOD_BODY, good.status, json.dumps(changed).encode()),
    }


KINDS = ("ok", "refused", "changed", "never", "timeout")
T0, MS = 1_700_000_000 * 10**9, 10**6


@st.composite
def sessions(draw):
    """Exchanges of each kind, overlapping in time, ids reused only once an earlier
    exchange of that id is answered, some request records written twice, cut into files."""
    n = draw(st.integers(1, 14))
    kinds = draw(st.lists(st.sampled_from(KINDS), min_size=n, max_size=n))
    delays = draw(st.lists(st.integers(1, 40), min_size=n, max_size=n))
    pool = draw(st.lists(st.sampled_from("abc"), min_size=n, max_size=n))
    twice = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    answers = _ANSWERS
    events, open_until, count = [], {}, {k: 0 for k in KINDS}
    count["twice"] = 0
    for i, (kind, delay_ms, rid) in enumerate(zip(kinds, delays, pool, strict=True)):
        t, delay = T0 + (i + 1) * 10 * MS, delay_ms * MS
        if open_until.get(rid, 0) >= t:
            rid = f"{rid}-{i}"
        answered = kind not in ("never",)
        open_until[rid] = t + delay if answered else T0 * 2
        count[kind] += 1
        if kind == "timeout":
            events.append((t, "request", request_record(rid, OP, GOOD_BODY[:20], False)))
            problem = (
                b'{"type": "urn:plotgate:problem:request-timeout", "title": "t", '
                b'"status": 408, "detail": "d", "errors": [{"field": "body", '
                b'"reason": "r"}]}'
            )
            events.append((t + delay, "response", response_record(rid, OP, 408, 30.0, problem)))
            continue
        body, status, answer = answers["ok" if kind == "never" else kind]
        request = request_record(rid, OP, body)
        events.append((t, "request", request))
        if twice[i]:
            events.append((t, "request", request))  # written again after a lost file
            count["twice"] += 1
        if answered:
            events.append((t + delay, "response", response_record(rid, OP, status, 0.001, answer)))
    events.sort(key=lambda e: e[0])
    cuts = set(draw(st.lists(st.integers(0, len(events) - 1), max_size=6)))
    return events, cuts, count


_ANSWERS = _answers()


@hsettings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(session=sessions())
def test_the_tally_adds_up_and_counts_each_exchange_once(tmp_path_factory, session):
    events, cuts, count = session
    folder = tmp_path_factory.mktemp("session")
    write_files(folder, events, cuts)
    report = replay(folder, progress=False)
    exchanges = sum(count[k] for k in KINDS)
    assert report.exchanges == exchanges
    assert report.compared == count["ok"] + count["refused"] + count["changed"]
    assert report.compared == report.unchanged + report.changed
    assert report.changed == count["changed"]
    assert report.compared + sum(report.not_compared.values()) == exchanges
    assert report.not_compared.get(NEVER_ANSWERED, 0) == count["never"]
    assert report.not_compared.get(BODY_TIMEOUT, 0) == count["timeout"]
    assert report.written_twice == count["twice"]
    assert len({(c.file, c.request_id, c.time) for c in report.changes}) == count["changed"]
    code = report.exit_code()
    assert code == (1 if count["changed"] else 0 if report.compared else 2)


def _session(settings, bodies: list[bytes]) -> Path:
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        for i, body in enumerate(bodies):
            c.post(
                "/v1/gates/test",
                content=body,
                headers={"x-request-id": f"r{i}", "content-type": "application/json"},
            )
    return settings.log_dir


def test_nothing_comparable_is_exit_2_unless_allowed(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["replay", str(empty)]) == 2
    assert "nothing was compared" in capsys.readouterr().out
    assert main(["replay", str(empty), "--allow-empty"]) == 0
    json_file = tmp_path / "session.json"
    json_file.write_text('{"request_id": "x"}')
    assert main(["replay", str(json_file)]) == 2
    assert main(["replay", str(json_file), "--allow-empty"]) == 2  # not a recording at all
    out = capsys.readouterr().out
    assert "not an MCAP file" in out and "no MCAP recording among the paths given" in out
    assert main(["replay", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err
    assert "no such file or folder" in err and len(err.strip().splitlines()) == 1
    assert main(["replay", str(empty), "--operation", "gates.test", "--since", "yesterday"]) == 2
    assert "not a time" in capsys.readouterr().err


def test_unchanged_changed_and_unreadable(settings, tmp_path, capsys):
    folder = _session(settings, [GOOD_BODY, BAD_BODY, b'{"gate": '])
    report = tmp_path / "report.json"
    assert main(["replay", str(folder), "--report", str(report)]) == 0
    tally = json.loads(report.read_text())
    assert (tally["exchanges"], tally["compared"], tally["unchanged"]) == (3, 3, 3)
    altered = tmp_path / "altered"
    events = [(t, kind, data) for t, kind, data in _events(folder)]
    events = [
        (t, k, d.replace(b'"inside":[true,true]', b'"inside":[true,false]')) for t, k, d in events
    ]
    write_files(altered, events, set())
    assert main(["replay", str(altered)]) == 1
    out = capsys.readouterr().out
    assert "CHANGED gates.test r0 inside[1]" in out and "1 changed" in out
    (altered / "junk.mcap").write_bytes(b"not a recording")
    assert main(["replay", str(altered)]) == 1  # a file that is not a recording is a note
    assert "junk.mcap is not an MCAP file (it does not start" in capsys.readouterr().out
    (altered / "junk.mcap").unlink()
    os.mkfifo(altered / "junk.mcap")
    assert main(["replay", str(altered)]) == 2  # 2 wins over 1: the input is not all usable


def _events(folder: Path) -> list[tuple[int, str, bytes]]:
    from mcap.reader import make_reader

    out = []
    for f in sorted(folder.glob("*.mcap")):
        with open(f, "rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages():
                out.append((message.log_time, channel.topic.rpartition("/")[2], message.data))
    return out


def test_a_recorded_500_replays_by_the_contract_without_a_traceback(
    settings, monkeypatch, capsys, swap_handler
):
    op = registry.OPERATIONS[OP]

    def broken(request):
        raise RuntimeError("boom")

    swap_handler(OP, broken)
    folder = _session(settings, [GOOD_BODY, BAD_BODY])
    capsys.readouterr()
    # the bug is still there: the same 500 again, unchanged
    assert main(["replay", str(folder)]) == 0
    captured = capsys.readouterr()
    assert "2 compared: 2 unchanged, 0 changed" in captured.out
    assert "RuntimeError: boom" in captured.out  # said, as a note
    assert "Traceback" not in captured.out + captured.err
    # the bug is fixed: the recorded 500 now answers 200, a change
    monkeypatch.setitem(registry.OPERATIONS, OP, op)
    assert main(["replay", str(folder)]) == 1
    captured = capsys.readouterr()
    assert "CHANGED gates.test r0 status: recorded 500, replayed 200" in captured.out
    assert "Traceback" not in captured.out + captured.err


def test_an_operation_this_build_lacks_is_a_change(tmp_path):
    events = [
        (1, "request", b'{"request_id": "x", "operation": "gates.gone", "body": {}}'),
        (
            2,
            "response",
            b'{"request_id": "x", "operation": "gates.gone", "status": 200, '
            b'"duration_s": 0.1, "result": {}}',
        ),
    ]
    folder = tmp_path / "gone"
    folder.mkdir()
    with open(folder / "a.mcap", "wb") as stream:
        writer = Writer(stream)
        writer.start()
        channels = {
            k: writer.register_channel(f"gates.gone/{k}", "json", 0)
            for k in ("request", "response")
        }
        for t, kind, data in events:
            writer.add_message(channels[kind], t, data, t)
        writer.finish()
    report = replay(folder, progress=False)
    assert (report.compared, report.changed) == (1, 1) and report.exit_code() == 1
    assert report.changes[0].replayed == "not an operation of this build"


def test_body_timeouts_are_not_compared(tmp_path):
    folder = tmp_path / "timeouts"
    problem = execute(OPERATIONS[OP], GOOD_BODY).content
    write_files(
        folder,
        [
            (1, "request", request_record("half", OP, GOOD_BODY[:30], False)),
            (
                2,
                "response",
                response_record(
                    "half",
                    OP,
                    408,
                    30.0,
                    (
                        b'{"type": "urn:plotgate:problem:request-timeout", '
                        b'"title": "Request timeout", '
                        b'"status": 408, "detail": "body: ...", "errors": [{"field": "body", '
                        b'"reason": "did not arrive"}]}'
                    ),
                ),
            ),
            (3, "request", request_record("whole", OP, GOOD_BODY)),
            (4, "response", response_record("whole", OP, 200, 0.01, problem)),
        ],
        set(),
    )
    report = replay(folder, progress=False)
    assert report.not_compared == {BODY_TIMEOUT: 1}
    assert (report.compared, report.unchanged, report.exit_code()) == (1, 1, 0)


def test_timeout_and_work_caps(settings, monkeypatch, capsys, swap_handler):
    folder = _session(settings, [GOOD_BODY, GOOD_BODY])
    op = registry.OPERATIONS[OP]

    def slow(request):
        time.sleep(30)

    swap_handler(OP, slow)
    capsys.readouterr()
    started = time.monotonic()
    assert main(["replay", str(folder), "--timeout", "0.2"]) == 1
    assert time.monotonic() - started < 20  # each exchange was stopped
    assert "no answer within 0.2 s (--timeout)" in capsys.readouterr().out
    monkeypatch.setitem(registry.OPERATIONS, OP, op)

    monkeypatch.setenv("PLOTGATE_LIMITS", json.dumps({OP: {"candidates": 1}}))
    report_path = settings.log_dir.parent / "report.json"
    assert main(["replay", str(folder), "--report", str(report_path)]) == 2
    assert json.loads(report_path.read_text())["not_compared"] == {OVER_CAPS: 2}
    assert main(["replay", str(folder), "--no-limits"]) == 0
    monkeypatch.setenv("PLOTGATE_LIMITS", json.dumps({"gates.nothing": {"x": 1}}))
    assert main(["replay", str(folder)]) == 2
    assert "PLOTGATE_LIMITS" in capsys.readouterr().err


def test_filters_pick_operations_and_times(settings, tmp_path):
    with TestClient(create_app(settings)) as c:
        c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "early"})
        time.sleep(0.05)
        middle = time.time()
        time.sleep(0.05)
        c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "late"})
        c.post(
            "/v1/identification/pair",
            json={
                "passive_bearings_deg": [1.0, 1.1, 0.9, 1.0],
                "active_bearings_deg": [1.0, 1.05],
                "delta_deg": 0.5,
            },
            headers={"x-request-id": "pair"},
        )
    folder = settings.log_dir
    report = tmp_path / "r.json"

    def compared(*args: str) -> int:
        main(["replay", str(folder), "--report", str(report), *args])
        return json.loads(report.read_text())["compared"]

    assert compared() == 3
    assert compared("--operation", "gates.test") == 2
    assert compared("--operation", "identification.pair,gates.test") == 3
    assert compared("--since", str(middle)) == 2
    assert compared("--until", str(middle)) == 1
    assert compared("--operation", "gates.test", "--since", str(middle)) == 1


def test_empty_and_foreign_files_are_skipped_and_decide_nothing(settings, tmp_path, capsys):
    """A full disk once left an empty file per refused request among sound recordings:
    replay exited 2 ("not an MCAP file") though every exchange replayed unchanged."""
    folder = _session(settings, [GOOD_BODY, BAD_BODY])
    for i in range(5):
        (folder / f"plotgate-29990101T000000.000000Z-pid1-{i:04d}.mcap").touch()
    (folder / "notes.mcap").write_text("not a recording\n")
    report = tmp_path / "report.json"
    assert main(["replay", str(folder), "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert out.count("is empty (0 bytes), not an MCAP file: skipped") == 5
    assert "notes.mcap is not an MCAP file" in out
    tally = json.loads(report.read_text())
    assert (tally["compared"], tally["unchanged"], tally["recordings"]) == (2, 2, 1)
    assert len(tally["skipped"]) == 6 and not tally["unreadable"]
    only_empty = tmp_path / "only-empty"
    only_empty.mkdir()
    (only_empty / "a.mcap").touch()
    assert main(["replay", str(only_empty), "--allow-empty"]) == 2  # not one recording


def _conflicting(folder: Path) -> None:
    """r0 recorded twice at one time with different bodies (and answers): the recorder
    writes a record again only byte for byte, so this is a recording that contradicts
    itself."""
    answers = _answers()
    events = []
    for n, kind in enumerate(("ok", "changed")):
        body, status, content = answers[kind]
        if n:
            body = body.replace(b"[", b"[ ", 1)  # another body: the same id, the same time
        events.append((T0, "request", request_record("r0", OP, body)))
        events.append((T0 + MS, "response", response_record("r0", OP, status, 0.001, content)))
    write_files(folder, events, {1})


def test_a_request_id_conflict_is_reported_by_file_and_offset_and_exits_1(tmp_path, capsys):
    folder = tmp_path / "conflict"
    _conflicting(folder)
    report = tmp_path / "report.json"
    assert main(["replay", str(folder), "--report", str(report)]) == 1
    out = capsys.readouterr().out
    tally = json.loads(report.read_text())
    assert tally["written_twice"] == 0 and tally["conflict_count"] == 2  # request, response
    assert (tally["exchanges"], tally["compared"], tally["unchanged"]) == (1, 1, 1)
    first, second = sorted(folder.glob("*.mcap"))
    request_conflict = tally["conflicts"][0]
    assert request_conflict.startswith(f"{OP} r0 at ") and "the request record" in request_conflict
    assert f"{second} at offset " in request_conflict and f"{first} at offset " in request_conflict
    assert "CONFLICT" in out and "2 conflicting records (exit 1)" in out


def test_a_full_disk_under_replay_out_is_a_message_and_exit_2(
    settings, tmp_path, monkeypatch, capsys
):
    """--out on a disk that fills after the first exchange: the flush that fails is not
    silent, and the run ends with the file and the reason, exit 2, not as a bug."""
    folder = _session(settings, [GOOD_BODY, GOOD_BODY, GOOD_BODY])
    real, calls = RecordingFile.write, []

    def write(file, buffers):
        calls.append(1)
        if len(calls) > 2:  # the new file's schemas, then the first exchange
            raise OSError(28, "No space left on device")
        return real(file, buffers)

    monkeypatch.setattr(RecordingFile, "write", write)
    out = tmp_path / "out" / "session.mcap"
    out.parent.mkdir()
    assert main(["replay", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{out}: the replayed session cannot be written: " in err, err
    assert "No space left on device" in err and "internal error" not in err
    monkeypatch.undo()
    [kept] = read_recording(out).exchanges  # the exchange flushed before is not truncated
    assert kept.replay_of == "r0"


def test_a_recorded_cap_refusal_is_refused_again_and_compared(settings, monkeypatch):
    """A server's 422 for a work size over its cap is compared in process under the same
    caps (it used to be set aside as over the caps, never compared); an answer recorded
    under higher caps is still set aside."""
    monkeypatch.setenv("PLOTGATE_LIMITS", json.dumps({OP: {"candidates": 1}}))
    capped = settings.model_copy(update={"limits": Settings().limits})
    folder = _session(capped, [GOOD_BODY])
    report = replay(folder, progress=False, limits=Settings().limits)
    assert (report.compared, report.unchanged, report.not_compared) == (1, 1, {})
    higher = settings.model_copy(update={"log_dir": settings.log_dir.parent / "higher"})
    report = replay(_session(higher, [GOOD_BODY]), progress=False, limits=Settings().limits)
    assert (report.compared, report.not_compared) == (0, {OVER_CAPS: 1})


@pytest.mark.parametrize(
    ("kind", "status", "reason"),
    [("shutting-down", 503, REFUSED_FOR_THE_SERVER), ("client-disconnected", 499, CLIENT_GONE)],
)
def test_an_answer_that_says_nothing_of_the_operation_is_set_aside(tmp_path, kind, status, reason):
    """A 503 (recording, cluster or shutdown) says what the server could not do then, and a
    499 (the client went away, its work cancelled) answered nothing: replayed in process
    either would answer 200 and read as a change. Each is counted apart, with its reason."""
    body, _, content = _answers()["ok"]
    problem = problem_json(ProblemError(kind, status, kind), OPERATIONS[OP].path, "r0")
    events = [
        (T0, "request", request_record("r0", OP, body)),
        (T0 + MS, "response", response_record("r0", OP, status, 0.001, problem)),
        (T0 + 2 * MS, "request", request_record("r1", OP, body)),
        (T0 + 3 * MS, "response", response_record("r1", OP, 200, 0.001, content)),
    ]
    write_files(tmp_path / "rec", events, set())
    report = replay(tmp_path / "rec", progress=False)
    assert (report.compared, report.unchanged) == (1, 1)
    assert report.not_compared == {reason: 1}


def test_a_file_that_is_not_a_recording_is_named_once(tmp_path, capsys):
    """A PNG given to replay: one line says it is not MCAP (the report's line for the
    file), not one per stream and list."""
    png = tmp_path / "figure.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    assert main(["replay", str(png)]) == 2
    captured = capsys.readouterr()
    assert (captured.out + captured.err).count("is not an MCAP file") == 1
    os.mkfifo(tmp_path / "fifo.mcap")
    assert main(["replay", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert (captured.out + captured.err).count("not a regular file") == 1
