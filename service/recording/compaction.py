"""Compaction: a closed unchunked recording made an indexed, compressed, chunked MCAP.

The event loop writes plain message records (:mod:`plotgate.service.recording.records`);
a file it has closed is rewritten here, off the loop, into the form readers seek in: zstd
chunks of :data:`CHUNK_BYTES`, message indexes, and a summary with the chunk index and
statistics (mcap's ``Writer``). The schemas, channels, metadata and messages are copied in
order, with their ids, times and sequence numbers.

Safety, step by step: the copy is written to a new temporary file in the same folder
(``.<name>.<random>.<pid>.compacting``: hidden, and not ``*.mcap``, so no reader takes it
for a recording), created by :mod:`plotgate.files` with O_EXCL|O_NOFOLLOW, so a name
planted in the folder is never opened; the source is opened without following a link.
The copy is synced, then swapped in with ``os.replace`` and the folder synced. Until the
swap the original is untouched; after it the copy holds the same messages. A kill at any
moment therefore leaves one readable file with every acknowledged exchange, plus at worst
a temporary, which the next start removes (:func:`remove_leftovers`) once its process is
gone.

Only files that were closed are compacted (they end with the closing footer). A file left
without it by a killed process stays readable as it is: the next start does not compact
it, because with several workers the files of the others are open and growing, and a
start cannot tell them from a dead one's; ``plotgate recover`` writes its indexed copy.

A server compacts in a child process (:class:`Compactions`), so the compaction never
holds the loop's GIL; the child yields the cores to the server: the lowest priority
(``nice`` 19, ``SCHED_IDLE``) and at most :data:`CPU_SHARE` of a core (:class:`Budget`).
The child runs this file as a script, so it imports mcap and the standard library only,
not the service (which takes seconds on a loaded machine); that is why this module
imports nothing of plotgate but the standard-library :mod:`plotgate.files`. Plain code
(``plotgate replay --out``, the benches) compacts in its own thread on ``close``.
Memory is bounded: records are read one at a time and the writer holds one chunk, its
message index and one index entry per chunk.
"""

import contextlib
import errno
import io
import logging
import os
import select
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.records import Channel, Header, McapRecord, Message, Metadata, Schema
from mcap.writer import MCAP0_MAGIC, CompressionType, Writer

from plotgate.files import open_regular, replace_into, temporary_beside

__all__ = [
    "CHUNK_BYTES",
    "CPU_SHARE",
    "Budget",
    "BUDGET_RECORDS",
    "COMPRESSION",
    "FAILURES",
    "Compactions",
    "compact",
    "remove_leftovers",
    "temporaries",
    "yield_to_the_server",
]

log = logging.getLogger("plotgate")

CHUNK_BYTES = 2**20
"""Uncompressed bytes per chunk (mcap's default): a reader decompresses about this much to
reach any message, and the summary holds one index entry per chunk."""

COMPRESSION = CompressionType.ZSTD
"""zstd, chosen by measurement (bench/HISTORY.md, "Compaction"): smaller files than LZ4 on
recordings, read about as fast."""

SUFFIX = ".compacting"

FAILURES = (OSError, ValueError, McapError)
"""What a compaction can meet: the disk, or a file that does not read as its recorder
wrote it. The original is intact after each."""


NO_SPACE = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
"""The errors of a full disk (EFBIG: a file size limit, as the tests make one)."""
NO_SPACE_EXIT = 3
"""The exit status of a compaction that failed for lack of space (1: any other failure)."""


def temporaries(path: Path, pid: int) -> list[Path]:
    """The temporaries process ``pid`` made for compacted copies of ``path``."""
    return sorted(path.parent.glob(f".{path.name}.*.{pid}{SUFFIX}"))


_UNSUMMARIZED_END = struct.pack("<BQQ", 0x02, 20, 0)
"""How the footer of a file without summary starts: opcode, length, summary start 0."""


def closed(path: Path) -> bool:
    """``path`` ends with the footer its recorder writes on closing it, without a summary
    (a compacted file has one: compacting it again does nothing)."""
    with open_regular(path) as f:
        size = f.seek(0, os.SEEK_END)
        if size < 29 + len(MCAP0_MAGIC):
            return False
        f.seek(size - 29 - len(MCAP0_MAGIC))
        end = f.read()
    return end.startswith(_UNSUMMARIZED_END) and end.endswith(MCAP0_MAGIC)


def compact(path: Path, pace: Callable[[], None] | None = None) -> bool:
    """Rewrite a closed unchunked recording as an indexed, chunked, compressed MCAP, in
    place and atomically. False (and nothing changed) when it is not a closed unchunked
    file; ``OSError`` when the copy cannot be written or swapped (the temporary removed,
    the original intact). ``pace`` is called every :data:`BUDGET_RECORDS` records (the
    child's :class:`Budget`)."""
    path = Path(path)
    if not closed(path):
        return False
    fd, copy = temporary_beside(path, suffix=f".{os.getpid()}{SUFFIX}")
    try:
        with os.fdopen(fd, "wb") as out, open_regular(path) as source:
            os.fchmod(fd, 0o644)  # mkstemp's 0600: the recording's mode
            _copy(source, out, os.fstat(source.fileno()).st_size, pace)
            out.flush()
            os.fsync(out.fileno())
        replace_into(copy, path)
    except BaseException:
        with contextlib.suppress(OSError):
            copy.unlink()
        raise
    return True


def _copy(source: IO[bytes], out: IO[bytes], size: int, pace: Callable[[], None] | None) -> None:
    """Copy every record of an unchunked recording into a chunked writer, in order."""
    writer = Writer(out, chunk_size=CHUNK_BYTES, compression=COMPRESSION)
    for count, record in enumerate(_records(source, size), start=1):
        if pace is not None and count % BUDGET_RECORDS == 0:
            pace()
        match record:
            case Header():
                writer.start(record.profile, record.library)
            case Schema():
                writer.register_schema(record.name, record.encoding, record.data)
            case Channel():
                writer.register_channel(
                    record.topic, record.message_encoding, record.schema_id, record.metadata
                )
            case Message():
                writer.add_message(
                    record.channel_id,
                    record.log_time,
                    record.data,
                    record.publish_time,
                    record.sequence,
                )
            case Metadata():
                writer.add_metadata(record.name, record.metadata)
    writer.finish()


_READERS: dict[int, Callable[[ReadDataStream, int], McapRecord]] = {
    0x01: lambda stream, _: Header.read(stream),
    0x03: lambda stream, _: Schema.read(stream),
    0x04: lambda stream, _: Channel.read(stream),
    0x05: Message.read,
    0x0C: lambda stream, _: Metadata.read(stream),
}
_DATA_END_TO_END = 13 + 29 + len(MCAP0_MAGIC)
"""Bytes from a closed file's ``DataEnd`` to its end: ``DataEnd``, footer, magic."""


def _records(source: IO[bytes], size: int) -> Iterator[McapRecord]:
    """The records of an unchunked recording of ``size`` bytes, up to its ``DataEnd``, each
    checked before it is believed: a kind the recorder writes, inside the file, its fields
    filling it exactly, the ``DataEnd`` right before the footer. A damaged file raises
    ``ValueError`` (or mcap's ``EndOfFile``) at its first bad record, so the original is
    kept whole instead of a copy missing what followed the damage (mcap's stream reader
    skips a record of unknown kind without a word)."""
    if source.read(len(MCAP0_MAGIC)) != MCAP0_MAGIC:
        raise ValueError("no MCAP magic")
    pos = len(MCAP0_MAGIC)
    while True:
        head = source.read(9)
        if len(head) < 9:
            raise ValueError(f"offset {pos}: cut short before the DataEnd")
        opcode, length = struct.unpack("<BQ", head)
        if opcode == 0x0F:
            if pos + _DATA_END_TO_END != size:
                raise ValueError(f"offset {pos}: a DataEnd that is not before the footer")
            return
        if opcode not in _READERS or pos + 9 + length > size - _DATA_END_TO_END:
            raise ValueError(f"offset {pos}: opcode {opcode:#04x} of {length} bytes")
        stream = ReadDataStream(io.BytesIO(source.read(length)))
        record = _READERS[opcode](stream, length)
        if stream.count != length:
            raise ValueError(f"offset {pos}: the record's fields do not fill its length")
        yield record
        pos += 9 + length


def remove_leftovers(folder: Path) -> list[Path]:
    """Remove the temporaries of compactions that died (their process is gone, or its pid
    is ours: a container restarted with the same pid). Those of a running compaction, a
    sibling worker's, are left alone. Returns what was removed."""
    removed = []
    for leftover in folder.glob(f".*{SUFFIX}"):
        pid = leftover.name.removesuffix(SUFFIX).rsplit(".", 1)[-1]
        if not pid.isdigit() or int(pid) != os.getpid() and _running(int(pid)):
            continue
        with contextlib.suppress(OSError):
            leftover.unlink()
            removed.append(leftover)
    return removed


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    return True


class Compactions:
    """Compactions of closed files, each in a child process (``python -m`` this module).

    A child process, not a thread: the copy parses and compresses every record, which in
    a thread would take the GIL from the event loop in slices of milliseconds. The child
    runs in its own session, so a terminal's Ctrl-C goes to the server, whose shutdown
    decides (:meth:`wait`). It keeps to its :class:`Budget` until its standard input
    closes: the server closes it when nothing is left to yield to (:meth:`wait`, at
    shutdown; a second compaction of the same file), and so does the server's end.
    """

    def __init__(self) -> None:
        self._running: dict[Path, subprocess.Popen[bytes]] = {}
        self.no_space: list[Path] = []
        """Files whose compaction failed for lack of space, to start again once there is
        some (:meth:`plotgate.service.recording.recorder.Recorder.probe`)."""

    def start(self, path: Path) -> None:
        """Compact ``path`` in a child process (a second request for it waits for the first)."""
        self.reap()
        earlier = self._running.pop(path, None)
        if earlier is not None:
            _hurry(earlier)
            earlier.wait()
        self._running[path] = subprocess.Popen(
            [sys.executable, "-P", __file__, str(path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            start_new_session=True,
        )

    @property
    def running(self) -> list[Path]:
        """The files being compacted."""
        self.reap()
        return list(self._running)

    def reap(self) -> None:
        """Forget the compactions that ended (their exit status collected)."""
        for path, child in list(self._running.items()):
            if child.poll() is not None:
                del self._running[path]
                _hurry(child)  # its end of the pipe, closed
                if child.returncode == NO_SPACE_EXIT:
                    self.no_space.append(path)
                    log.warning("compaction of %s waits for space on the disk", path)
                elif child.returncode != 0:
                    log.warning("compaction of %s failed (exit %s)", path, child.returncode)

    def wait(self, timeout_s: float) -> list[Path]:
        """Wait up to ``timeout_s`` for the running compactions; kill those still running
        then (their originals stay, unchunked and readable; their temporaries removed).
        Returns the files left uncompacted that way."""
        deadline = time.monotonic() + timeout_s
        left = []
        for child in self._running.values():
            _hurry(child)  # nothing left to yield to: full speed
        for path, child in self._running.items():
            try:
                child.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
                for leftover in temporaries(path, child.pid):
                    with contextlib.suppress(OSError):
                        leftover.unlink()
                log.warning("%s left uncompacted: the shutdown's time ran out", path)
                left.append(path)
        self._running.clear()
        return left


CPU_SHARE = 0.25
"""The share of one core a compaction child may use, averaged from its start: on a
two-core machine it leaves the server its core and most of the other (measured in
bench/HISTORY.md, "Recording and the server (issue 40)": the p99 at 50 clients while a
file compacts)."""

BUDGET_RECORDS = 256
"""Records copied between two looks at the child's CPU time."""


def _hurry(child: "subprocess.Popen[bytes]") -> None:
    """Close a compaction child's standard input: its budget is lifted."""
    if child.stdin is not None:
        with contextlib.suppress(OSError):
            child.stdin.close()


class Budget:
    """Keeps a process's CPU time within ``share`` of the wall time since it started:
    :meth:`spend` sleeps off what is over. The compaction child calls it as it copies, so
    besides running at the lowest priority (which yields only to runnable processes, and
    a server between requests is not one) it leaves the cores idle most of the time,
    ready for the next burst of requests.

    ``until``: a file descriptor (the child's standard input, a pipe from the server)
    whose end (or any byte) lifts the budget for good, even in the middle of a sleep: the
    server is stopping and waits for the compaction (POSIX; elsewhere it is ignored).
    """

    def __init__(self, share: float, until: int | None = None) -> None:
        self.share = share
        self.until = until if os.name == "posix" else None
        self.lifted = False
        self.started = time.monotonic()
        self.cpu = time.process_time()

    def spend(self) -> None:
        """Sleep until the CPU used so far is within the share of the time elapsed."""
        if self.lifted:
            return
        ahead = (time.process_time() - self.cpu) / self.share - (time.monotonic() - self.started)
        if ahead <= 0:
            return
        if self.until is None:
            time.sleep(ahead)
            return
        woken, _, _ = select.select([self.until], [], [], ahead)
        self.lifted = bool(woken)


def yield_to_the_server() -> None:
    """The lowest priority there is: ``nice`` 19 and, on Linux, ``SCHED_IDLE`` (run only
    when nothing else wants the core). Either may be refused (a container's policy):
    the budget still holds."""
    with contextlib.suppress(OSError):
        os.nice(19)
    if hasattr(os, "sched_setscheduler"):
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))


def main(argv: list[str]) -> int:
    """``python -P compaction.py FILE``: compact one closed file, at the lowest priority
    and within :data:`CPU_SHARE` of a core. Exit 0 when compacted or nothing to do,
    :data:`NO_SPACE_EXIT` when it failed for lack of space, 1 for any other failure (the
    original intact)."""
    yield_to_the_server()
    [path] = argv
    try:
        compact(Path(path), Budget(CPU_SHARE, until=sys.stdin.fileno()).spend)
    except FAILURES as exc:
        with contextlib.suppress(OSError):  # a log on the full disk
            print(f"plotgate: compaction of {path} failed: {exc}", file=sys.stderr)
        no_space = isinstance(exc, OSError) and exc.errno in NO_SPACE
        return NO_SPACE_EXIT if no_space else 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
