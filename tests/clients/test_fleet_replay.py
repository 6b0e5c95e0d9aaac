"""plotgate replay on Dask (--dask / --local-workers): the report and the exit code are the
serial replay's byte for byte, whatever the parts (files, chunk ranges), the workers, a
worker killed mid-replay; a scheduler that does not answer is exit 2 with a message.

Recordings are written directly (mcap's writer with the recorder's channels and records,
small chunks so files cut into many chunk ranges): rotations that split exchanges, records
written twice, conflicts, reused ids, replays of originals, exchanges never answered or
whose request is lost, 408s, 503s, changed answers, refusals, damaged and truncated files.
"""

import json
import os
import random
import signal
import threading
import time
from pathlib import Path

import pytest

from plotgate.clients.cli import main
from plotgate.clients.fleet import Judging, WorkerCannotRead, fleet_replay, read_part
from plotgate.clients.parts import Part, parts
from plotgate.clients.recordings import Filters, recording_files
from plotgate.clients.replay import replay
from plotgate.service.recording import request_record, response_record
from plotgate.service.registry import OPERATIONS, execute
from tests.support.hostile import corpus
from tests.support.recorded import OP, write_files
from tests.support.servers import free_port

T0, MS = 1_700_000_000 * 10**9, 10**6


def _body(candidates: int, y: float = 5e4) -> bytes:
    plots = [
        {"frame": "cartesian", "x": 100.0 * i, "y": y, "covariance": [[1e4, 0], [0, 1e4]]}
        for i in range(candidates)
    ]
    return json.dumps(
        {"gate": {"kind": "ellipse", "P_G": 0.9}, "first": plots[0], "candidates": plots}
    ).encode()


GOOD = _body(5)
SLOW = _body(100)
BAD = json.dumps({"gate": {"kind": "ellipse"}, "first": 1}).encode()
PROBLEM = (
    b'{"type": "urn:plotgate:problem:x", "title": "t", "status": %d, "detail": "d", '
    b'"errors": [{"field": "body", "reason": "r"}]}'
)


def _answer(body: bytes) -> tuple[int, bytes]:
    outcome = execute(OPERATIONS[OP], body)
    return outcome.status, outcome.content


def _changed(content: bytes) -> bytes:
    answer = json.loads(content)
    answer["statistic"][0] += 1.0
    return json.dumps(answer).encode()


def _events(seed: int, n: int) -> list[tuple[int, str, bytes]]:
    """``n`` exchanges of every kind, overlapping in time, as (time, kind, record)."""
    rng = random.Random(seed)
    answers = {GOOD: _answer(GOOD), BAD: _answer(BAD), SLOW: _answer(SLOW)}
    events: list[tuple[int, str, bytes]] = []
    originals = []
    for i in range(n):
        t, delay = T0 + i * 10 * MS, rng.randint(1, 40) * MS
        rid = rng.choice(["a", "b", f"r{i}", f"r{i}", f"r{i}"])
        if any(rid == r for r, until in originals if until >= t):
            rid = f"r{i}"
        kind = rng.choice(
            [
                "ok",
                "ok",
                "refused",
                "changed",
                "never",
                "lost",
                "408",
                "503",
                "replay",
                "twice",
                "conflict",
            ]
        )
        body = rng.choice([GOOD, GOOD, SLOW])
        if kind == "refused":
            body = BAD
        status, content = answers[body]
        replay_of = None
        if kind == "replay":
            replay_of = rng.choice([r for r, _ in originals] + ["nowhere"]) if originals else "x"
        request = request_record(rid, OP, body, replay_of=replay_of)
        if kind != "lost":
            events.append((t, "request", request))
        if kind == "twice":
            events.append((t, "request", request))
        if kind == "conflict":
            events.append((t, "request", request_record(rid, OP, body.replace(b"{", b"{ ", 1))))
        if kind in ("408", "503"):
            status, content = int(kind), PROBLEM % int(kind)
        elif kind == "changed":
            content = _changed(content)
        if kind != "never":
            events.append(
                (t + delay, "response", response_record(rid, OP, status, 0.001, content))
            )
        if replay_of is None:
            originals.append((rid, t + delay))
    events.sort(key=lambda e: e[0])
    return events


def _recordings(folder: Path, seed: int, n: int = 40, damage: bool = True) -> Path:
    rng = random.Random(seed)
    events = _events(seed, n)
    write_files(folder, events, set(rng.sample(range(len(events)), 4)), chunk_size=3000)
    if damage:
        files = sorted(folder.glob("*.mcap"))
        hit = files[rng.randrange(len(files))]
        data = bytearray(hit.read_bytes())
        at = rng.randrange(len(data) // 4, len(data) // 2)
        data[at] ^= 0xFF  # a flipped byte in the data section: a damaged chunk, or worse
        hit.write_bytes(bytes(data))
        cut = files[rng.randrange(len(files))]
        cut.write_bytes(cut.read_bytes()[: -rng.randint(40, 400)])  # a killed writer's file
        (folder / "plotgate-99998.mcap").touch()  # empty: skipped with a note
        (folder / "plotgate-99999.mcap").write_bytes(b"not a recording")
    return folder


def _same(serial, fleet) -> None:
    assert json.dumps(fleet.to_json(), indent=2, default=str) == json.dumps(
        serial.to_json(), indent=2, default=str
    )
    assert fleet.text() == serial.text()
    assert fleet.exit_code() == serial.exit_code()


@pytest.mark.parametrize("seed", range(24))
def test_parts_in_process_report_what_the_serial_replay_reports(tmp_path, seed):
    folder = _recordings(tmp_path / "rec", seed, damage=seed % 3 != 0)
    serial = replay(folder, progress=False)
    assert serial.exchanges >= 40 - 5
    for part_bytes in (1, 2000, 10**9):  # every chunk a part, a few chunks, whole files
        _same(serial, fleet_replay(folder, part_bytes=part_bytes))


def test_the_parts_cover_the_chunks_and_a_file_without_summary_is_whole(tmp_path):
    folder = _recordings(tmp_path / "rec", 5, n=60, damage=False)
    files = recording_files(folder)
    cut = parts(files, part_bytes=1)
    assert len(cut) > 3 * len(files)
    for path in files:
        mine = [p for p in cut if p.path == str(path)]
        assert mine[0].start == 8 and mine[-1].stop == path.stat().st_size
        assert all(a.stop == b.start for a, b in zip(mine, mine[1:], strict=False))
    truncated = files[0]
    truncated.write_bytes(truncated.read_bytes()[:-10])
    assert [p for p in parts(files, 1) if p.path == str(truncated)] == [Part(str(truncated))]


def test_a_part_that_skips_damage_past_its_end_has_its_file_read_again_whole(tmp_path):
    folder = _recordings(tmp_path / "rec", 9, n=60, damage=False)
    path = max(recording_files(folder), key=lambda f: f.stat().st_size)
    cut = parts([path], part_bytes=1)
    assert len(cut) > 4
    data = bytearray(path.read_bytes())
    for part in cut[2:4]:  # two chunks in a row whose lengths are damaged: the read of
        data[part.start + 8] ^= 0x7F  # the first resumes after the second
    path.write_bytes(bytes(data))
    assert len(parts([path], part_bytes=1)) == len(cut)  # the summary still checks
    serial = replay(folder, progress=False)
    assert serial.files[[f["path"] for f in serial.files].index(str(path))]["damage_count"]
    _same(serial, fleet_replay(folder, part_bytes=1))


def test_every_file_of_the_hostile_corpus_reports_as_in_the_serial_replay(tmp_path):
    status, content = _answer(GOOD)
    events = []
    for i in range(6):
        events.append((T0 + i * MS, "request", request_record(f"s{i}", OP, GOOD)))
        events.append(
            (T0 + i * MS + 1, "response", response_record(f"s{i}", OP, status, 0.001, content))
        )
    write_files(tmp_path / "sound", events, set(), chunk_size=600)
    [sound] = (tmp_path / "sound").glob("*.mcap")
    expect = corpus(sound.read_bytes(), (GOOD, status, content), tmp_path / "files")
    assert len(expect) >= 50
    for name in expect:
        path = tmp_path / "files" / f"{name}.mcap"
        serial = replay(path, progress=False)
        for part_bytes in (1, 10**9):
            _same(serial, fleet_replay(path, part_bytes=part_bytes))
    serial = replay(tmp_path / "files", progress=False)  # all of them at once
    _same(serial, fleet_replay(tmp_path / "files", part_bytes=1))


def test_a_live_file_is_open_or_unfinished_as_this_process_sees_its_writer(tmp_path, monkeypatch):
    """Whether a file's writer still writes it is asked here, as the serial replay asks it,
    whatever the worker that read its last part saw (here: workers that see no writer)."""
    from plotgate.clients import recordings

    folder = tmp_path / "rec"
    write_files(folder, _events(3, 20), set(), chunk_size=3000)
    [written] = folder.glob("*.mcap")
    live = folder / f"plotgate-20261203T000000.000000Z-pid{os.getpid()}-0001.mcap"
    live.write_bytes(written.read_bytes()[:-100])  # a writer's file without its footer
    written.unlink()
    with open(live, "rb"):  # the writer: this process, holding the file
        serial = replay(folder, progress=False)
        assert serial.files[0]["state"] == "open"
        monkeypatch.setattr(recordings, "writer_alive", lambda path: False)
        _same(serial, fleet_replay(folder, part_bytes=1))
    monkeypatch.undo()
    serial = replay(folder, progress=False)
    assert serial.files[0]["state"] == "unfinished"
    _same(serial, fleet_replay(folder, part_bytes=1))


def test_filters_and_a_changed_answer_in_parts(tmp_path):
    folder = _recordings(tmp_path / "rec", 7, n=50)
    filters = Filters(frozenset({OP}), T0 + 100 * MS, T0 + 400 * MS)
    serial = replay(folder, progress=False, filters=filters, rtol=1e-3)
    judging = Judging(rtol=1e-3, filters=filters)
    _same(serial, fleet_replay(folder, judging, part_bytes=1))


def test_an_exchange_past_its_timeout_is_stopped_on_a_worker_thread_too(tmp_path, swap_handler):
    """A Dask task runs in a worker's thread, where no signal arrives: the deadline is an
    exception set on the thread, and the report is the serial one's (a SIGALRM there)."""
    status, content = _answer(GOOD)

    def slow(request):
        for _ in range(3000):  # 30 s, unless stopped between two sleeps
            time.sleep(0.01)

    swap_handler(OP, slow)
    events = [(T0, "request", request_record("r", OP, GOOD))]
    events.append((T0 + MS, "response", response_record("r", OP, status, 0.001, content)))
    write_files(tmp_path / "rec", events, set())
    serial = replay(tmp_path / "rec", progress=False, timeout=0.2)
    assert "no answer within 0.2 s" in serial.text()
    spread = {}
    thread = threading.Thread(
        target=lambda: spread.update(report=fleet_replay(tmp_path / "rec", Judging(timeout=0.2)))
    )
    started = time.monotonic()
    thread.start()
    thread.join(timeout=25)
    assert time.monotonic() - started < 20
    _same(serial, spread["report"])


def test_a_progress_bar_counts_the_parts_on_stderr(tmp_path, capsys):
    folder = _recordings(tmp_path / "rec", 2, damage=False)
    count = len(parts(recording_files(folder), part_bytes=2000))
    serial = replay(folder, progress=False)
    _same(serial, fleet_replay(folder, progress=True, part_bytes=2000))
    err = capsys.readouterr().err
    assert f"{count}/{count}" in err
    assert fleet_replay(folder, part_bytes=2000) is not None
    assert capsys.readouterr().err == ""  # progress=False: no bar


def test_a_worker_that_cannot_read_the_folder_says_so(tmp_path):
    with pytest.raises(WorkerCannotRead, match="the recording folder at the same path"):
        read_part(Part(str(tmp_path / "elsewhere.mcap")), Judging())


def test_the_command_says_which_file_a_worker_cannot_read_and_exits_2(
    tmp_path, monkeypatch, capsys
):
    from plotgate.clients import fleet

    path = tmp_path / "elsewhere.mcap"

    def unshared(paths, judging, **cluster):
        return read_part(Part(str(path)), judging)  # as a worker without the folder

    monkeypatch.setattr(fleet, "fleet_replay", unshared)
    assert main(["replay", str(tmp_path), "--local-workers", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"plotgate replay: {path}: the worker on ")
    assert "the recording folder at the same path on every worker" in err
    assert "Traceback" not in err


def _cli(args: list[str], capsys, report: Path) -> tuple[int, str, bytes]:
    code = main(["replay", *args, "--report", str(report)])
    return code, capsys.readouterr().out, report.read_bytes()


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return _recordings(tmp_path_factory.mktemp("fleet") / "rec", 11, n=80)


def test_one_and_two_local_workers_print_and_report_what_the_serial_replay_does(
    folder, tmp_path, capsys
):
    serial = _cli([str(folder)], capsys, tmp_path / "serial.json")
    assert serial[0] in (1, 2)
    assert b'"changed": 0' not in serial[2] and b'"conflict_count": 0' not in serial[2]
    for workers in ("1", "2"):
        spread = _cli(
            [str(folder), "--local-workers", workers, "--part-bytes", "2000"],
            capsys,
            tmp_path / f"{workers}.json",
        )
        assert spread == serial


def test_a_worker_killed_mid_replay_changes_nothing(tmp_path):
    from distributed import Client, LocalCluster

    rng = random.Random(3)
    events = []
    for i in range(300):
        t = T0 + i * MS
        status, content = _answer(SLOW)
        events.append((t, "request", request_record(f"r{i}", OP, SLOW)))
        events.append(
            (t + MS // 2, "response", response_record(f"r{i}", OP, status, 0.001, content))
        )
    write_files(tmp_path / "rec", events, set(rng.sample(range(len(events)), 3)), chunk_size=3000)
    serial = replay(tmp_path / "rec", progress=False)
    outcome = {}
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        Client(local) as client,
    ):
        pids = client.run(os.getpid)
        client.run(_answer, SLOW)  # warm: the operation imported on both workers

        def run():
            outcome["report"] = fleet_replay(
                tmp_path / "rec", address=local.scheduler_address, part_bytes=4000
            )

        thread = threading.Thread(target=run)
        thread.start()
        victim = None
        deadline = time.monotonic() + 60
        while victim is None and time.monotonic() < deadline and thread.is_alive():
            busy = [w for w, keys in client.processing().items() if keys]
            victim = busy[0] if busy else None
            time.sleep(0.05)
        assert victim is not None and thread.is_alive()  # killed mid-replay, not after it
        os.kill(pids[victim], signal.SIGKILL)
        thread.join(timeout=300)
        assert not thread.is_alive()
    _same(serial, outcome["report"])


def test_a_scheduler_that_does_not_answer_is_exit_2_with_a_message(folder, capsys):
    port = free_port()
    assert main(["replay", str(folder), "--dask", f"tcp://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err
    assert f"no Dask scheduler answers at tcp://127.0.0.1:{port}" in err
    assert "Traceback" not in err
    assert main(["replay", str(folder), "--dask", "not-an-address"]) == 2
    assert "is no Dask scheduler address" in capsys.readouterr().err


def test_out_and_server_are_refused_with_a_cluster(folder, tmp_path, capsys):
    out = tmp_path / "s.mcap"
    assert main(["replay", str(folder), "--local-workers", "1", "--out", str(out)]) == 2
    assert "--out writes one session file" in capsys.readouterr().err
    assert not out.exists()
    assert main(["replay", str(folder), "--local-workers", "1", "--server", "http://x"]) == 2
    assert "not allowed with argument" in capsys.readouterr().err
