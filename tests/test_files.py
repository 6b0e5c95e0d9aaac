"""The one safe way to write a file (:mod:`plotgate.files`), held against every writer: a
symlink to a victim file and a FIFO planted where each writes (and a character device when
the tests run as root). Nothing is written through the link, no FIFO or device is replaced
or written into, and each command ends with one line and exit 2."""

import contextlib
import json
import os
import stat
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from plotgate.clients.cli import main
from plotgate.files import NotRegularTarget, atomic_write, check_target, create_new
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.recording.compaction import compact
from plotgate.service.recording.files import RecordingFile
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.table import ENDPOINTS

PRECIOUS = b"the victim's bytes"


def _record(folder: Path, status: int, content: bytes) -> Path:
    """``folder`` with one recorded gate test, answered ``status`` and ``content``."""
    recorder = Recorder(folder, OPERATIONS.values()).start()
    data = json.dumps(ENDPOINTS["gates.test"].example_body).encode()
    written = recorder.request("gates.test", request_record("r1", "gates.test", data))
    recorder.response(written, response_record("r1", "gates.test", status, 0.01, content))
    recorder.flush()
    recorder.close()
    return folder


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """A recorded gate test answered 422 (the writers are refused before it is run)."""
    return _record(tmp_path_factory.mktemp("recording"), 422, b'{"status": 422}')


@pytest.fixture(scope="module")
def answered(tmp_path_factory) -> Path:
    """A recorded gate test with this build's answer (a replay of it is unchanged)."""
    answer = execute(
        OPERATIONS["gates.test"], json.dumps(ENDPOINTS["gates.test"].example_body).encode()
    )
    return _record(tmp_path_factory.mktemp("answered"), answer.status, answer.content)


@contextlib.contextmanager
def fifo_at(path: Path) -> Iterator[list[int]]:
    """A FIFO at ``path`` with a reader draining it (so an old writer never blocks): the
    sizes read, which must stay empty."""
    os.mkfifo(path)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    got: list[int] = []
    stop = threading.Event()

    def drain() -> None:
        while not stop.is_set():
            try:
                data = os.read(fd, 65536)
            except BlockingIOError:
                data = b""
            if data:
                got.append(len(data))
            else:
                time.sleep(0.01)

    thread = threading.Thread(target=drain, daemon=True)
    thread.start()
    try:
        yield got
    finally:
        stop.set()
        thread.join(10)
        os.close(fd)


KINDS = ["symlink", "fifo", "chardev"]


@contextlib.contextmanager
def planted(kind: str, target: Path) -> Iterator[None]:
    """``kind`` at ``target``, checked untouched at the end: the link still a link and its
    victim's bytes the same, the FIFO still a FIFO with nothing written into it, the
    device still a device."""
    if kind == "symlink":
        victim = target.with_name("victim.txt")
        victim.write_bytes(PRECIOUS)
        target.symlink_to(victim)
        yield
        assert target.is_symlink() and victim.read_bytes() == PRECIOUS
    elif kind == "fifo":
        with fifo_at(target) as got:
            yield
        assert stat.S_ISFIFO(os.lstat(target).st_mode) and got == []
    else:
        if os.geteuid() != 0:
            pytest.skip("a character device can be made in a temporary folder only as root")
        os.mknod(target, stat.S_IFCHR | 0o600, os.makedev(1, 3))  # a /dev/null of our own
        yield
        assert stat.S_ISCHR(os.lstat(target).st_mode)


def _one_line_exit_2(capsys, code: int, target: Path) -> None:
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].endswith("not a regular file: refused")
    assert str(target) in err[-1]


WRITERS = {
    "view": lambda rec, out: ["view", str(rec), "-o", str(out)],
    "recover": lambda rec, out: ["recover", str(next(rec.glob("*.mcap"))), "--out", str(out)],
    "replay-out": lambda rec, out: ["replay", str(rec), "--out", str(out)],
    "replay-report": lambda rec, out: ["replay", str(rec), "--report", str(out)],
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("writer", WRITERS)
def test_the_commands_refuse_a_target_that_is_not_a_regular_file(
    recording, tmp_path, capsys, writer, kind
):
    """Defect 3: view -o and recover --out replaced a FIFO or device with a file; replay
    --out wrote into it."""
    target = tmp_path / "out.mcap"
    with planted(kind, target):
        code = main(WRITERS[writer](recording, target))
    _one_line_exit_2(capsys, code, target)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("writer", WRITERS)
def test_the_commands_still_replace_a_regular_file(answered, tmp_path, writer):
    target = tmp_path / "out.json"
    target.write_bytes(b"old")
    assert main(WRITERS[writer](answered, target)) == 0
    assert target.read_bytes() != b"old" and stat.S_ISREG(os.lstat(target).st_mode)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def _closed_uncompacted(monkeypatch, folder: Path) -> Path:
    monkeypatch.setattr("plotgate.service.recording.recorder.compact", lambda path: False)
    recorder = Recorder(folder, OPERATIONS.values()).start()
    data = json.dumps(ENDPOINTS["gates.test"].example_body).encode()
    written = recorder.request("gates.test", request_record("r1", "gates.test", data))
    recorder.response(written, response_record("r1", "gates.test", 200, 0.01, b"{}"))
    recorder.flush()
    recorder.close()
    monkeypatch.undo()
    [path] = recorder.files
    return path


@pytest.mark.parametrize("kind", ["symlink", "fifo"])
def test_compaction_never_opens_a_name_planted_in_the_folder(monkeypatch, tmp_path, kind):
    """Defect 2: the temporary ``.<file>.<pid>.compacting`` was opened by name, so a
    planted link overwrote its victim and the recording became a link."""
    path = _closed_uncompacted(monkeypatch, tmp_path)
    with planted(kind, path.with_name(f".{path.name}.{os.getpid()}.compacting")):
        assert compact(path)
    assert stat.S_ISREG(os.lstat(path).st_mode)
    assert not compact(path)  # compacted: it has a summary now


@pytest.mark.parametrize("kind", ["symlink", "fifo"])
def test_compaction_refuses_a_recording_replaced_by_a_link_or_fifo(tmp_path, kind):
    path = tmp_path / "plotgate-x.mcap"
    with planted(kind, path), pytest.raises(OSError):
        compact(path)


@pytest.mark.parametrize("kind", ["symlink", "fifo"])
def test_the_recorder_never_follows_a_name_planted_in_its_folder(tmp_path, kind):
    path = tmp_path / "plotgate-planted.mcap"
    with planted(kind, path), pytest.raises(FileExistsError):
        RecordingFile(path, 1, b"head")


def test_the_recorders_probe_never_writes_through_a_planted_link(tmp_path):
    recorder = Recorder(tmp_path, OPERATIONS.values()).start()
    with planted("symlink", tmp_path / f".plotgate-probe-{os.getpid()}"):
        assert recorder._write_probe() is None  # noqa: SLF001 - the probe a full disk runs
    recorder.close()


def test_atomic_write_leaves_the_target_whole_or_untouched(tmp_path):
    target = tmp_path / "t.bin"
    target.write_bytes(b"before")
    with pytest.raises(RuntimeError), atomic_write(target) as stream:
        stream.write(b"half")
        raise RuntimeError
    assert target.read_bytes() == b"before" and [p.name for p in tmp_path.iterdir()] == ["t.bin"]
    with atomic_write(target) as stream:
        stream.write(b"after")
    assert target.read_bytes() == b"after" and stat.S_IMODE(target.stat().st_mode) == 0o644
    (tmp_path / "d").mkdir()
    with pytest.raises(NotRegularTarget):
        check_target(tmp_path / "d")
    with pytest.raises(FileExistsError):
        os.close(create_new(target))
