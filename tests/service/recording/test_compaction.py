"""The recorder's two forms: unchunked message records while a file is written, and the
indexed, chunked, compressed MCAP a closed file is compacted into, swapped in atomically.
A kill during compaction leaves the original whole; leftovers are removed at the next
start."""

import asyncio
import contextlib
import hashlib
import os
import random
import signal
import subprocess
import sys
import time

import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader

from plotgate.clients.recordings import read_recording
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.recording import compaction as compaction_module
from plotgate.service.recording.compaction import compact, remove_leftovers, temporaries
from plotgate.service.registry import OPERATIONS

OP = OPERATIONS["gates.test"]


def _exchanges(recorder: Recorder, n: int, body=lambda i: b'{"x": 1}') -> None:
    for i in range(n):
        rid = f"r{i}"
        exchange = recorder.request(OP.name, request_record(rid, OP.name, body(i), True))
        recorder.response(exchange, response_record(rid, OP.name, 200, 0.001, b'{"ok": true}'))
        recorder.flush()


def _uncompacted(monkeypatch, folder, n: int, body=lambda i: b'{"x": 1}'):
    """A closed file in its unchunked form (compaction switched off)."""
    monkeypatch.setattr("plotgate.service.recording.recorder.compact", lambda path: False)
    recorder = Recorder(folder, OPERATIONS.values()).start()
    _exchanges(recorder, n, body)
    recorder.close()
    monkeypatch.undo()
    [path] = recorder.files
    return path


def _records(path):
    """Every record, up to the end of a file without footer too."""
    records = []
    with open(path, "rb") as f, contextlib.suppress(EndOfFile):
        records.extend(StreamReader(f).records)
    return records


def _messages(path):
    with open(path, "rb") as f:
        return [
            (channel.topic, m.log_time, m.sequence, m.data)
            for _, channel, m in make_reader(f).iter_messages(log_time_order=False)
        ]


def test_a_file_being_written_is_plain_message_records_every_reader_reads(tmp_path, mcap_check):
    """Before it is closed (or when its process is killed) a file holds top-level message
    records after its schemas, channels and metadata: no chunk, no footer."""
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()
    _exchanges(recorder, 5)
    [path] = recorder.files
    records = _records(path)
    assert not any(isinstance(r, Chunk) for r in records)
    messages = [r for r in records if isinstance(r, Message)]
    assert len(messages) == 10 and [m.sequence for m in messages] == list(range(1, 11))
    recording = read_recording(path)
    assert [ex.request_id for ex in recording.exchanges] == [f"r{i}" for i in range(5)]
    assert all(ex.response is not None for ex in recording.exchanges)
    code, report = mcap_check(path)  # no footer yet: read as a killed process's file
    assert code == 1 and report["truncated"] and report["recovered_messages"] == 10, report
    recorder.close()


def test_a_closed_file_is_compacted_with_every_record_in_order(tmp_path, monkeypatch, mcap_check):
    path = _uncompacted(monkeypatch, tmp_path, 50)
    assert _records(path)[-1].__class__.__name__ == "Footer"
    before = _messages(path)
    assert compaction_module.closed(path)
    assert compact(path)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics.message_count == 100
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    assert len(summary.channels) == 2 * len(OPERATIONS)
    assert _messages(path) == before
    assert not compact(path)  # compacted already: nothing to do
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]
    code, report = mcap_check(path)
    assert code == 0 and report["summary_present"] and report["total_messages"] == 100


def test_a_file_left_by_a_killed_process_is_not_compacted(tmp_path):
    """No footer: its writer may still be running (another worker), so it stays as it is."""
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()
    _exchanges(recorder, 3)
    [path] = recorder.files
    data = path.read_bytes()
    assert not compact(path) and path.read_bytes() == data
    recorder.close()


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_a_sigkill_during_compaction_leaves_the_original_whole(tmp_path, monkeypatch):
    rng = random.Random(25)  # bodies that compress 2:1 at best, so the copy takes a while
    path = _uncompacted(  # a 40 MB file
        monkeypatch, tmp_path, 4000, lambda i: b'{"x": "%s"}' % rng.randbytes(5000).hex().encode()
    )
    digest = _sha(path)
    child = subprocess.Popen(
        [sys.executable, "-P", compaction_module.__file__, str(path)],
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 60
    while not ((made := temporaries(path, child.pid)) and made[0].stat().st_size > 2**20):
        assert child.poll() is None, child.stderr.read() if child.stderr else ""
        assert time.monotonic() < deadline, "the compaction never started writing"
        time.sleep(0.002)
    [copy] = made  # mid-way through the copy
    os.kill(child.pid, signal.SIGKILL)
    child.wait(30)
    child.stderr.close()
    assert _sha(path) == digest  # untouched: the swap had not happened
    recording = read_recording(path)
    assert len(recording.exchanges) == 4000 and recording.complete
    assert copy.exists()
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()  # the next start
    assert not copy.exists() and [p.name for p in tmp_path.iterdir()] == [path.name]
    recorder.close()


def test_leftovers_are_removed_only_when_their_process_is_gone(tmp_path):
    path = tmp_path / "plotgate-x.mcap"
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait(30)
        kept, mine, gone = (
            tmp_path / f".{path.name}.x1y2.{pid}.compacting"
            for pid in (live.pid, os.getpid(), dead.pid)
        )
        for leftover in (kept, mine, gone):
            leftover.write_bytes(b"part of a copy")
        assert sorted(remove_leftovers(tmp_path)) == sorted([mine, gone])
        assert [p.name for p in tmp_path.iterdir()] == [kept.name]
    finally:
        live.kill()
        live.wait(30)


def test_rotation_while_compactions_run_keeps_every_exchange(tmp_path, mcap_check):
    """On a loop, rotated files are compacted by child processes while the next files are
    written; close waits for them, and every file ends compacted, every exchange in it."""

    async def session() -> Recorder:
        recorder = Recorder(tmp_path, OPERATIONS.values(), max_bytes=2**18).start()
        body = b'{"plots": [%s]}' % b", ".join([b"2.5"] * 5000)
        for i in range(60):
            rid = f"r{i}"
            ex = await recorder.arequest(OP.name, request_record(rid, OP.name, body, True))
            await recorder.aresponse(ex, response_record(rid, OP.name, 200, 0.1, b"{}"))
        assert recorder.rotations > 3
        recorder.close()
        return recorder

    recorder = asyncio.run(session())
    files = sorted(tmp_path.glob("*.mcap"))
    assert files == sorted(recorder.files) and recorder.compacting == []
    assert [p.name for p in sorted(tmp_path.iterdir())] == [f.name for f in files]
    ids = set()
    for f in files:
        with open(f, "rb") as stream:
            assert make_reader(stream).get_summary().chunk_indexes  # compacted
        ids |= {ex.request_id for ex in read_recording(f).exchanges if ex.response}
    assert ids == {f"r{i}" for i in range(60)}
    code, reports = mcap_check.many(files)
    assert code == 0 and all(r["summary_present"] for r in reports)


def test_a_shutdown_out_of_time_stops_the_compaction_and_keeps_the_original(tmp_path, mcap_check):
    """With no time left, close stops the running compaction: the file stays whole in
    its unchunked, closed form, and no temporary is left."""

    async def session() -> Recorder:
        recorder = Recorder(tmp_path, OPERATIONS.values(), compaction_wait_s=0).start()
        for i in range(20):
            ex = await recorder.arequest(OP.name, request_record(f"r{i}", OP.name, b"{}", True))
            await recorder.aresponse(ex, response_record(f"r{i}", OP.name, 200, 0.1, b"{}"))
        recorder.close()
        return recorder

    recorder = asyncio.run(session())
    [path] = recorder.files
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    assert compaction_module.closed(path)  # not compacted, closed with its footer
    recording = read_recording(path)
    assert len(recording.exchanges) == 20 and recording.complete
    code, report = mcap_check(path, schemas=True)  # the independent reader: a sound file
    assert code == 0 and not report["truncated"] and report["total_messages"] == 40, report


def test_records_are_packed_as_mcap_says(tmp_path):
    """The hand-packed message records against mcap's own parser, a large message too."""
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()
    big = b'{"x": "%s"}' % (b"y" * 3_000_000)
    exchange = recorder.request(OP.name, request_record("big", OP.name, big, True), 123)
    recorder.response(exchange, response_record("big", OP.name, 200, 0.5, b"{}"), 456)
    recorder.flush()
    [path] = recorder.files
    [request, response] = [m for m in _records(path) if isinstance(m, Message)]
    assert (request.log_time, request.publish_time, response.log_time) == (123, 123, 456)
    assert request.data == request_record("big", OP.name, big, True)
    recorder.close()


def test_a_damaged_file_is_not_compacted_and_stays_whole(tmp_path, monkeypatch):
    """A length byte flipped in a message record: the copy would lose what follows, so
    the compaction fails, the original is kept byte for byte and no temporary is left."""
    path = _uncompacted(monkeypatch, tmp_path, 20)
    data = bytearray(path.read_bytes())
    first = next(r for r in _offsets(bytes(data)) if data[r] == 0x05)
    data[first + 8] ^= 0x40  # the high byte of its length: past the file's end
    path.write_bytes(bytes(data))
    with pytest.raises(compaction_module.FAILURES):
        compact(path)
    assert path.read_bytes() == bytes(data)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def _offsets(data: bytes):
    """The offsets of the records of an unchunked file, walked by their lengths."""
    pos = 8
    while pos < len(data) - 8:
        yield pos
        pos += 9 + int.from_bytes(data[pos + 1 : pos + 9], "little")


def _no_space_left() -> None:
    """In a compaction's child: every write past a file's first byte fails (EFBIG), as on
    a full disk."""
    import resource

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1, resource.RLIM_INFINITY))


def test_a_file_closed_while_the_disk_was_full_is_compacted_once_space_returns(
    tmp_path, monkeypatch
):
    """Its compaction failed for lack of space and was never tried again: the file stayed
    in its unchunked form for good. Now the probe that finds space back starts it again."""
    popen = subprocess.Popen

    def full(*args, **kwargs):
        return popen(*args, preexec_fn=_no_space_left, **kwargs)

    async def settled(recorder: Recorder) -> None:
        deadline = time.monotonic() + 120
        while recorder.compacting:
            assert time.monotonic() < deadline
            await asyncio.sleep(0.05)

    async def session() -> None:
        recorder = Recorder(tmp_path, OPERATIONS.values(), max_bytes=1).start()
        monkeypatch.setattr(compaction_module.subprocess, "Popen", full)
        for i in range(2):  # the second rotates the first file: its compaction fails
            ex = await recorder.arequest(OP.name, request_record(f"r{i}", OP.name, b"{}", True))
            await recorder.aresponse(ex, response_record(f"r{i}", OP.name, 200, 0.1, b"{}"))
        await settled(recorder)
        first = recorder.files[0]
        assert compaction_module.closed(first)  # still unchunked
        monkeypatch.setattr(compaction_module.subprocess, "Popen", popen)  # space is back
        recorder.probe()
        await settled(recorder)
        assert not compaction_module.closed(first)
        with open(first, "rb") as stream:
            assert make_reader(stream).get_summary().chunk_indexes  # compacted
        assert {ex.request_id for ex in read_recording(first).exchanges} == {"r0"}
        recorder.close()

    asyncio.run(session())


def test_the_budget_sleeps_off_the_cpu_over_its_share(monkeypatch):
    """A child that used 0.1 s of CPU in 0.2 s at a share of a quarter sleeps until 0.4 s
    have passed; one within its share does not sleep."""
    clock = {"cpu": 0.0, "wall": 0.0}
    slept: list[float] = []
    monkeypatch.setattr(compaction_module.time, "process_time", lambda: clock["cpu"])
    monkeypatch.setattr(compaction_module.time, "monotonic", lambda: clock["wall"])
    monkeypatch.setattr(compaction_module.time, "sleep", slept.append)
    budget = compaction_module.Budget(0.25)
    clock.update(cpu=0.1, wall=0.2)
    budget.spend()
    assert slept == [pytest.approx(0.2)]
    clock.update(cpu=0.1, wall=0.5)
    budget.spend()
    assert len(slept) == 1


def test_compaction_paces_itself_and_keeps_every_record(tmp_path, monkeypatch, mcap_check):
    """The budget is consulted as records are copied, and the copy is the same."""
    path = _uncompacted(monkeypatch, tmp_path, 300)
    before = _messages(path)
    copied = len(_records(path)) - 2  # all but the DataEnd and the footer
    calls = []
    assert compact(path, lambda: calls.append(1))
    assert len(calls) == copied // compaction_module.BUDGET_RECORDS > 0
    assert _messages(path) == before
    code, _ = mcap_check(path)
    assert code == 0


def test_the_compaction_child_runs_at_the_lowest_priority():
    """nice 19 and, on Linux, SCHED_IDLE: the child never delays the server's work."""
    code = (
        "import os; from plotgate.service.recording import compaction as c; "
        "c.yield_to_the_server(); "
        "print(os.nice(0), getattr(os, 'sched_getscheduler', lambda p: -1)(0))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert int(out[0]) == 19
    if sys.platform == "linux":
        assert int(out[1]) == os.SCHED_IDLE


def test_the_budget_is_lifted_when_its_pipe_closes(monkeypatch):
    """The server closes the child's standard input at shutdown: the sleep ends at once
    and the budget is not consulted again."""
    clock = {"cpu": 0.0, "wall": 0.0}
    monkeypatch.setattr(compaction_module.time, "process_time", lambda: clock["cpu"])
    monkeypatch.setattr(compaction_module.time, "monotonic", lambda: clock["wall"])
    read, write = os.pipe()
    try:
        budget = compaction_module.Budget(0.25, until=read)
        clock.update(cpu=100.0, wall=1.0)  # 399 s over: a sleep that would never end
        os.close(write)
        budget.spend()
        assert budget.lifted
    finally:
        os.close(read)
