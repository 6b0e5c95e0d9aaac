"""MCAP recorder: every exchange, durably, group-committed on the event loop.

Design:

- One file per process at a time, named ``plotgate-<UTC time>-pid<pid>-<seq>.mcap`` so
  names sort by time and workers of one server never share a file. A file is closed with
  its summary and index and a new one opened when it passes ``max_bytes``, ``max_age_s``
  or :data:`MAX_CHUNKS` chunks. Its records are flushed on the event loop first; the
  summary, which indexes every chunk, is written by a worker thread, so a rotation never
  stalls the answers (measured: 770 ms for the 300,000 chunks of a full 256 MB file).
- Two channels per operation, ``<op>/request`` and ``<op>/response``, whose JSON schemas
  are :class:`~plotgate.service.schemas.RequestRecord` and
  :class:`~plotgate.service.schemas.ResponseRecord`
  with the operation's request, result and problem models embedded
  (:func:`~plotgate.service.schemas.request_schema`; ``jsonschema`` schema encoding, ``json``
  messages), and a ``plotgate`` metadata record (versions, git commit, settings) at the
  start of every file.
- mcap's ``Writer`` is not thread-safe and its ``flush()`` closes the current chunk, so
  the event loop owns it and group-commits: records are added as requests arrive and
  answers are ready, and one flush, scheduled with ``call_soon``, writes every record
  added during that turn of the loop (chunk closed, bytes handed to the OS) before the
  answers waiting on it are released. A killed process therefore leaves a file holding
  every exchange a client saw answered. There is no writer thread: measured here, thread
  hand-offs and GIL contention cost several times more than the writing itself. Only a
  record over a megabyte is written from a worker thread, with the writer to itself.
- Every flush checks that the file still has a name; records lost with a deleted file
  (or folder) are written again to a new one before anything is answered
  (:class:`Recorder`). A moved file keeps its records and is noticed by the probe.
"""

import asyncio
import codecs
import contextlib
import json
import logging
import os
import re
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

from mcap.writer import CompressionType, Writer

from plotgate.service.bodies import is_strict_json, slices
from plotgate.service.registry import Operation
from plotgate.service.schemas import request_schema, response_schema

__all__ = ["Exchange", "Recorder", "RecordingError", "request_record", "response_record"]


log = logging.getLogger("plotgate")

MAX_CHUNKS = 2**14
"""Rotate after this many chunks (one per flush that wrote records). mcap's writer keeps an
index entry per chunk until the file's summary; measured, 300,000 chunks (a 256 MB file
under load) held 167 MB, cost every full garbage collection 47 ms and their summary 770
ms. At this bound: about 9 MB, under 3 ms, and 42 ms of summary, written off the loop."""

LARGE_RECORD_BYTES = 2**20
"""Records over this size are written from a worker thread, not on the event loop."""

PROBE_BYTES = 2**16
"""Bytes the probe writes: more than a new file's first flush (its schemas and channels,
35 KB for the operations of this build), so that a disk a probe passes has room to open a
file, and one with less refuses at once without creating and removing a file per
request."""


class RecordingError(RuntimeError):
    """The recorder could not write a record (disk full, directory gone, closed)."""


def _head(request_id: str, operation: str, replay_of: str | None = None) -> bytes:
    head = b'{"request_id": %s, "operation": "%s"' % (
        json.dumps(request_id).encode(),
        operation.encode(),
    )
    if replay_of is not None:
        head += b', "replay_of": %s' % json.dumps(replay_of).encode()
    return head


def request_record(
    request_id: str,
    operation: str,
    body: bytes,
    strict_json: bool | None = None,
    replay_of: str | None = None,
) -> bytes:
    """The request message: strict-JSON bodies are embedded as they came, others as text.

    ``strict_json`` says which the body is when the caller knows (the service parsed it);
    by default the body is parsed here to find out. ``replay_of`` is, for a request sent by
    ``plotgate replay``, the request id of the exchange it replays.
    """
    if strict_json is None:
        strict_json = is_strict_json(body)
    head = _head(request_id, operation, replay_of)
    if strict_json:
        return b'%s, "body": %s}' % (head, body)
    return b'%s, "raw": %s}' % (head, _json_string(body))


_CONTROL = re.compile(rb"[\x00-\x1f]")


def _json_string(body: bytes) -> bytes:
    """``body`` as a JSON string (bytes that are not UTF-8 escaped as ``\\xNN``), built slice
    by slice so that no call holds the interpreter long. Printable ASCII, as large bodies
    mostly are, is escaped with byte replacements, without a round trip through Python
    text; anything else is decoded incrementally (a character cut by a slice's end is
    finished by the next) and escaped a character at a time, as a whole body would be."""
    if all(piece.isascii() and _CONTROL.search(piece) is None for piece in slices(body)):
        escaped = (p.replace(b"\\", b"\\\\").replace(b'"', b'\\"') for p in slices(body))
        return b"".join([b'"', *escaped, b'"'])
    decoder = codecs.getincrementaldecoder("utf-8")("backslashreplace")
    texts = [*(decoder.decode(piece) for piece in slices(body)), decoder.decode(b"", final=True)]
    return b"".join([b'"', *(json.dumps(text)[1:-1].encode() for text in texts), b'"'])


def response_record(
    request_id: str, operation: str, status: int, duration_s: float, content: bytes
) -> bytes:
    """The response message around an answer's JSON ``content`` (result or problem)."""
    key = b"result" if status < 400 else b"error"
    return b'%s, "status": %d, "duration_s": %r, "%s": %s}' % (
        _head(request_id, operation),
        status,
        duration_s,
        key,
        content,
    )


@dataclass(eq=False)
class Exchange:
    """One exchange in flight: its records, kept until both are flushed to a file that is
    still in its folder, so that a file lost before then can be written again.

    ``file`` is the number of the file holding the request record (0: not written, or lost
    with its file); ``answered`` is set once the response record has been added.
    """

    operation: str
    request: bytes
    request_time: int
    response: bytes | None = None
    response_time: int = 0
    file: int = 0
    flushed: bool = False
    answered: bool = False


class Recorder:
    """Writes request and response records of the given operations to rotating MCAP files.

    Use it from one thread: the event loop of a server process (``ex = await arequest(...)``
    then ``await aresponse(ex, ...)``; records over :data:`LARGE_RECORD_BYTES` are handed to
    a worker thread, with the writer to itself meanwhile), or plain code (``request``,
    ``response``, ``close``).

    Nothing is answered unrecorded. Every flush checks that the file is
    still named where it was written: a file whose folder was deleted (an operator's ``rm -rf``, a
    volume unmounted) takes every record written to it since it was opened, so the folder
    is created again, a new file opened, and the records of every exchange still in flight
    written to it once more before any of them is answered. A failed write (disk full, read
    only) is tried once more in a new file the same way, opened only when a probe can
    write to the folder; if that fails too, the exchanges waiting on the flush get
    :class:`RecordingError` (the service answers 503) and the recorder is not
    :attr:`ready` until :meth:`probe` can write to the folder again. Meanwhile no file is
    created (each refused request used to leave an empty one), and a file none of whose
    flushes succeeded is removed.

    Parameters
    ----------
    directory : folder for the files; created if missing, and again if it disappears.
    operations : the registry's operations; each gets a request and a response channel.
    max_bytes : rotate when the current file reaches this size.
    max_age_s : rotate when the current file is this old.
    metadata : string key/values written into every file's ``plotgate`` metadata record.
    file_name : write exactly this one file in ``directory`` and never rotate (replay's
        ``--out``); by default files are named by time and pid and rotate.
    on_flush : called with the duration (s) of every flush that wrote records (metrics).
    """

    def __init__(
        self,
        directory: Path,
        operations: Iterable[Operation],
        *,
        max_bytes: int = 256 * 2**20,
        max_age_s: float = 3600.0,
        metadata: Mapping[str, str] | None = None,
        file_name: str | None = None,
        on_flush: Callable[[float], None] | None = None,
    ) -> None:
        self.directory = Path(directory)
        self.max_bytes = max_bytes
        self.max_age_s = max_age_s
        self.metadata = dict(metadata or {})
        self.file_name = file_name
        self.on_flush = on_flush
        self.files: list[Path] = []
        self._schemas = [
            (f"{op.name}/{kind}", f"plotgate.{op.name}.{kind}", json.dumps(schema).encode())
            for op in operations
            for kind, schema in (
                ("request", request_schema(op.request)),
                ("response", response_schema(op.response)),
            )
        ]
        self.records = 0  # records handed to the OS
        self.pending = 0  # records added, waiting for the next flush
        self.rotations = 0  # files closed because of size, age or chunk count
        self.rewritten = 0  # records written again after their file was lost
        self._bytes_closed = 0  # bytes of the files already closed
        self._closed = False
        self._error: Exception | None = None
        self._stream: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._opened_at = 0.0
        self._chunks = 0  # chunks in the current file
        self._full = False  # the current file reached max_bytes or MAX_CHUNKS
        self._summaries: ThreadPoolExecutor | None = None  # writes rotated files' summaries
        self._sizes = threading.Lock()  # _bytes_closed, added to by that thread too
        self._seq = 0
        self._batch: asyncio.Future[None] | None = None
        self._lock: asyncio.Lock | None = None  # held while a worker thread writes
        self._flush_waiting = False
        self._inflight: set[Exchange] = set()
        self._unflushed: list[Exchange] = []  # request records added since the last flush
        self._answered: list[Exchange] = []  # response records added since the last flush
        self._lost = False  # some in-flight record must be written again

    def start(self) -> "Recorder":
        """Check the folder can be written (:class:`RecordingError` saying why, a file in
        its place included); the first file is opened by the first record."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecordingError(f"cannot create the folder {self.directory}: {exc}") from exc
        if not self._folder_writable():
            raise RecordingError(f"cannot write to {self.directory}")
        return self

    def close(self) -> None:
        """Write what is pending, then the summary and index, and close the file; wait for
        the summaries of rotated files."""
        if self._closed:
            return
        self.flush()
        self._closed = True
        self._finish()
        if self._summaries is not None:
            self._summaries.shutdown(wait=True)

    @property
    def error(self) -> Exception | None:
        """The failure that stopped the last write, until a write or the probe works."""
        return self._error

    @property
    def ready(self) -> bool:
        """True while records can be written: open, no failed write, directory writable."""
        return not self._closed and self._error is None and self._folder_writable()

    def probe(self) -> bool:
        """Look after the folder without waiting for traffic; then :attr:`ready`.

        A current file that left its folder is dropped (and its in-flight records written
        again to a new file); a missing folder is created again; after a failed write a
        small file is written, synced and removed, and the failure cleared when that works.
        The service calls it every ``probe_interval_s`` and on ``/readyz``, so readiness
        comes back with the disk by itself.
        """
        if self._closed:
            return False
        if self._lock is not None and self._lock.locked():
            return self.ready  # a worker thread is writing: look next time
        if self._stream is not None:
            try:
                self._check_file(moved=True)
            except _FileMoved:
                self._finish()
            except _FileLost as exc:
                self._drop(exc, whole_file=True)
        if self._error is not None or not self._folder_writable():
            failure = self._write_probe()
            if failure is not None:
                self._error = self._error or failure
                return False
            self._error = None
        if self._lost:
            self.flush()
        return self.ready

    def _folder_writable(self) -> bool:
        """The folder is a folder (not a file put in its place) and may be written."""
        return self.directory.is_dir() and os.access(self.directory, os.W_OK)

    def _write_probe(self) -> OSError | None:
        """Write a small file into the folder (creating it if missing), sync and remove it;
        the error when that fails. The probe is removed either way, so trying leaves
        nothing behind, however often it is tried on a full disk."""
        probe = self.directory / f".plotgate-probe-{os.getpid()}"
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            with open(probe, "wb") as f:
                f.write(b"\0" * PROBE_BYTES)
                f.flush()
                os.fsync(f.fileno())
            probe.unlink()
        except OSError as exc:
            with contextlib.suppress(OSError):
                probe.unlink()
            return exc
        return None

    def request(self, operation: str, data: bytes, log_time: int | None = None) -> Exchange:
        """Add a request record (plain code: it is written by the next ``flush``).

        Returns the exchange to answer with :meth:`response`.
        """
        exchange = Exchange(operation, data, log_time or time.time_ns())
        self._write_request(exchange)
        self._inflight.add(exchange)
        return exchange

    def response(self, exchange: Exchange, data: bytes, log_time: int | None = None) -> None:
        """Add a response record; it is written by the next ``flush`` or ``close``."""
        exchange.response, exchange.response_time = data, log_time or time.time_ns()
        self._write_response(exchange)

    async def arequest(self, operation: str, data: bytes) -> Exchange:
        """Add a request record on the event loop; it is flushed this turn.

        Returns the exchange to answer with :meth:`aresponse`, or to :meth:`forget` when no
        answer will be recorded.
        """
        exchange = Exchange(operation, data, time.time_ns())
        await self._exclusive(self._write_request, exchange, len(data))
        self._inflight.add(exchange)
        self._schedule()
        return exchange

    async def aresponse(self, exchange: Exchange, data: bytes) -> None:
        """Add a response record and wait until the flush holding both records of the
        exchange has reached the OS (:class:`RecordingError` if it cannot)."""
        try:
            exchange.response, exchange.response_time = data, time.time_ns()
            await self._exclusive(self._write_response, exchange, len(data))
            batch = self._schedule()
            assert batch is not None
            await asyncio.shield(batch)
        finally:
            self.forget(exchange)

    async def _exclusive(
        self, write: Callable[[Exchange], None], exchange: Exchange, size: int
    ) -> None:
        """Run ``write`` with the writer to itself: on the loop for a small record, in a
        worker thread for one over :data:`LARGE_RECORD_BYTES` (copying, checksumming and
        compressing tens of megabytes would stall every other request); the flush that
        falls due meanwhile waits for it (:meth:`_flush_due`)."""
        if size <= LARGE_RECORD_BYTES and (self._lock is None or not self._lock.locked()):
            write(exchange)  # no thread is writing, and nothing can start one meanwhile
            return
        if self._lock is None:
            self._lock = asyncio.Lock()
        async with self._lock:
            if size <= LARGE_RECORD_BYTES:
                write(exchange)
                return
            try:
                await asyncio.to_thread(write, exchange)
            finally:
                if self._flush_waiting:
                    self._flush_waiting = False
                    asyncio.get_running_loop().call_soon(self._flush_due)

    def forget(self, exchange: Exchange) -> None:
        """Stop keeping an exchange's records (answered, or refused unrecorded)."""
        self._inflight.discard(exchange)

    @property
    def bytes_written(self) -> int:
        """Bytes of every file this recorder has written, the current one included."""
        current = 0
        if self._stream is not None:
            with contextlib.suppress(OSError, ValueError):
                current = self._stream.tell()
        return self._bytes_closed + current

    def flush(self) -> bool:
        """Hand every added record to the OS and release the answers waiting on them.

        The chunk is closed and flushed, then the file checked: still linked in its folder.
        A lost or failed file is replaced once (:meth:`_commit`); if that fails too, the
        waiting answers get :class:`RecordingError`, and False is returned, so that plain
        code, which has no answer waiting, learns it too (True: every record is with the
        OS).
        """
        batch, self._batch = self._batch, None
        started = time.perf_counter()
        try:
            wrote = self._commit()
        except RecordingError as exc:
            if batch is not None and not batch.done():
                batch.set_exception(exc)
            return False
        if wrote and self.on_flush is not None:
            self.on_flush(time.perf_counter() - started)
        if batch is not None and not batch.done():
            batch.set_result(None)
        return True

    def _commit(self) -> bool:
        """Flush the current file; on loss or failure, write the in-flight records to a new
        file and flush that. True when records were written."""
        for attempt in (1, 2):
            try:
                if self._lost:
                    self._open()
                if self._writer is None:
                    return False
                self._writer.flush()
                size = self._check_file()
                self._chunks += 1
                self._full = self._chunks >= MAX_CHUNKS or size >= self.max_bytes
            except _FileMoved:
                self._finish()  # its records are safe where it went; the next file is here
                return True
            except Exception as exc:
                self._drop(exc, whole_file=isinstance(exc, _FileLost))
                if attempt == 2:
                    raise RecordingError(f"could not record: {exc}") from exc
                continue
            self._flushed()
            return True
        raise AssertionError("unreachable")

    def _flushed(self) -> None:
        """Every record added so far is with the OS: count them, finish answered exchanges."""
        for exchange in self._unflushed:
            exchange.flushed = True
        for exchange in self._answered:
            self._inflight.discard(exchange)
        self._unflushed.clear()
        self._answered.clear()
        self.records += self.pending
        self.pending = 0

    def _write_request(self, exchange: Exchange) -> None:
        self._add(f"{exchange.operation}/request", exchange.request, exchange.request_time)
        exchange.file, exchange.flushed = self._seq, False
        self._unflushed.append(exchange)

    def _write_response(self, exchange: Exchange) -> None:
        assert exchange.response is not None
        self._add(f"{exchange.operation}/response", exchange.response, exchange.response_time)
        exchange.answered = True
        self._answered.append(exchange)

    def _add(self, topic: str, data: bytes, log_time: int) -> None:
        if self._closed:
            raise RecordingError("the recorder is closed")
        try:
            if self._writer is not None and self._rotation_due():
                self._rotate()
            if self._writer is None:
                self._open()
            assert self._writer is not None
            self._writer.add_message(self._channels[topic], log_time, data, log_time)
            self.pending += 1
        except Exception as exc:
            self._drop(exc, whole_file=False)
            raise RecordingError(f"could not record: {exc}") from exc

    def _schedule(self) -> asyncio.Future[None] | None:
        """The future of this turn's flush, scheduled once per turn; None off a loop."""
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return None
        if self._batch is None:
            self._batch = loop.create_future()
            loop.call_soon(self._flush_due)
        return self._batch

    def _flush_due(self) -> None:
        """This turn's flush, unless a worker thread is writing: then right after it."""
        if self._lock is not None and self._lock.locked():
            self._flush_waiting = True
        else:
            self.flush()

    def _rotation_due(self) -> bool:
        """The current file reached its size or chunk count (as of the last flush) or age."""
        if self.file_name is not None:
            return False
        return self._full or time.monotonic() - self._opened_at >= self.max_age_s

    def _rotate(self) -> None:
        """Close the current file: its records flushed here (:meth:`_commit`, so they are
        with the OS before any of them is answered), its summary and index written by a
        worker thread when a loop is running, here otherwise."""
        seq = self._seq
        self._commit()
        writer, stream = self._writer, self._stream
        if writer is None or stream is None or self._seq != seq:
            return  # the file moved, or was lost and replaced: nothing left to close
        self._writer, self._stream = None, None
        self.rotations += 1
        path = self.files[-1]
        size = stream.tell()
        with self._sizes:  # counted now, so bytes_written never goes down meanwhile
            self._bytes_closed += size
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            self._summarize(writer, stream, path, size)
            return
        if self._summaries is None:
            self._summaries = ThreadPoolExecutor(1, thread_name_prefix="plotgate-summary")
        self._summaries.submit(self._summarize, writer, stream, path, size)

    def _summarize(self, writer: Writer, stream: IO[bytes], path: Path, counted: int) -> None:
        """Write a rotated file's summary and index and close it (``counted``: its bytes
        already in :attr:`bytes_written`). Its records are already with the OS: a failure
        here loses the index only, which ``plotgate recover`` rebuilds."""
        try:
            writer.finish()
            size = stream.tell() - counted
            stream.close()
        except OSError as exc:
            log.warning("could not finish %s: %s (plotgate recover rebuilds its index)", path, exc)
            with contextlib.suppress(OSError):
                stream.close()
            return
        with self._sizes:
            self._bytes_closed += size

    def _open(self) -> None:
        """Open the next file (creating the folder if it is gone), and write into it every
        in-flight record whose file was lost.

        Lazily, on a record: a file without messages would lose its schemas and channels,
        which mcap's writer keeps in the chunk being built.

        After a failed write no file is created until a probe (:meth:`_write_probe`) can
        write to the folder: on a full disk every refused request used to leave one empty
        file behind (thousands a second), which the readers then took for recordings.
        """
        self._finish()
        self._find_gone()
        if self._error is not None:
            failure = self._write_probe()
            if failure is not None:
                raise RecordingError(f"cannot write to {self.directory}: {failure}")
        self.directory.mkdir(parents=True, exist_ok=True)
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
        self._seq += 1
        name = self.file_name or f"plotgate-{stamp}-pid{os.getpid()}-{self._seq:04d}.mcap"
        path = self.directory / name
        if self.file_name is not None and self.files and path.exists():
            # the one file failed: opening its name again would truncate what it holds
            raise RecordingError(f"{path}: {self._error}; not opened again over its records")
        self._stream = open(path, "wb")  # noqa: SIM115 - open for the file's whole life
        self.files.append(path)
        self._chunks, self._full = 0, False  # before anything can fail: see _drop
        writer = Writer(self._stream, compression=CompressionType.LZ4)
        writer.start(profile="", library="plotgate")
        writer.add_metadata("plotgate", self.metadata)
        self._channels = {
            topic: writer.register_channel(
                topic, "json", writer.register_schema(schema_name, "jsonschema", schema)
            )
            for topic, schema_name, schema in self._schemas
        }
        writer.flush()
        self._writer = writer
        self._opened_at = time.monotonic()
        self._error = None
        if self._lost:
            self._lost = False
            for exchange in sorted(self._inflight, key=lambda ex: ex.request_time):
                if exchange.file == 0:
                    self._write_request(exchange)
                    self.rewritten += 1
                if exchange.answered:
                    self._write_response(exchange)
                    self.rewritten += 1

    def _check_file(self, moved: bool = False) -> int:
        """The current file's size as the OS has it (all of it, after a flush); raise
        :class:`_FileLost` when the file has no name left (its folder or itself deleted);
        with ``moved``, :class:`_FileMoved` when its name now leads elsewhere.

        Every flush checks for loss (one ``fstat``), which would take acknowledged records
        with it; the probe, every ``probe_interval_s``, also for a move (one ``stat`` of the
        path more), which takes none: the records stay in the moved file, and the next
        ones go to a new file in the folder.
        """
        assert self._stream is not None
        opened = os.fstat(self._stream.fileno())
        if opened.st_nlink == 0:
            raise _FileLost(f"{self.files[-1]} was deleted (its folder removed?)")
        if moved and not self._named(opened):
            raise _FileMoved
        return opened.st_size

    def _named(self, opened: os.stat_result) -> bool:
        """The current file's path still leads to the open file (``opened``, its fstat):
        not gone, not replaced, its folder not turned into a file (ENOTDIR) or unreadable."""
        try:
            named = os.stat(self.files[-1])
        except OSError:
            return False
        return (named.st_dev, named.st_ino) == (opened.st_dev, opened.st_ino)

    def _finish(self) -> None:
        """Write the summary and index and close the file."""
        if self._writer is not None and self._stream is not None:
            try:
                self._writer.finish()
                with self._sizes:
                    self._bytes_closed += self._stream.tell()
                self._stream.close()
                self._flushed()
            except OSError as exc:
                self._drop(exc, whole_file=False)
        self._writer = None
        self._stream = None

    def _drop(self, exc: Exception, *, whole_file: bool) -> None:
        """Abandon the current file after ``exc``: mark for writing again every in-flight
        record it took (all of them when the file itself is gone, else those not yet
        flushed; every response, since an exchange leaves once its response is flushed)."""
        self._error = exc
        for exchange in list(self._inflight):  # a snapshot: forget() may run meanwhile
            if exchange.file == self._seq and (whole_file or not exchange.flushed):
                exchange.file, exchange.flushed = 0, False
                self._lost = True
            if exchange.answered:
                self._lost = True
        if whole_file:
            self._find_gone(but=self._seq)
        self._unflushed.clear()
        self._answered.clear()
        self.pending = 0
        if self._stream is not None:
            if self._chunks == 0 and not whole_file:
                self._remove_unflushed()
            with contextlib.suppress(OSError):
                self._stream.close()
        self._writer = None
        self._stream = None

    def _remove_unflushed(self) -> None:
        """Remove the current file, none of whose flushes succeeded: it holds nothing
        acknowledged (at most part of its header and of records that are written again or
        refused), and left behind it would be an empty or headless file that the readers
        must skip. Only while its name still leads to it: never someone else's file."""
        assert self._stream is not None
        with contextlib.suppress(OSError):
            if self._named(os.fstat(self._stream.fileno())):
                self.files[-1].unlink()

    def _find_gone(self, but: int = 0) -> None:
        """Mark for writing again the request records of in-flight exchanges whose file, one
        closed since (rotated), has no name left: a slow operation's request, written
        before a rotation, then the folder removed. ``but``: a file already dealt with. A
        file merely moved is taken for gone too: its request is then recorded twice, never
        lost."""
        gone: dict[int, bool] = {}
        for exchange in list(self._inflight):
            number = exchange.file
            if number in (0, but) or number > len(self.files):
                continue
            if number not in gone:
                gone[number] = not self.files[number - 1].exists()
            if gone[number]:
                exchange.file, exchange.flushed = 0, False
                self._lost = True


class _FileLost(OSError):
    """The current file has no name left: everything written to it is gone."""


class _FileMoved(Exception):
    """The current file is no longer at its path, but still exists elsewhere."""
