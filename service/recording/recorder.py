"""Durability: every exchange recorded before it is answered, whatever happens to the disk.

- **Group commit on the event loop.** Records are added as requests arrive and answers
  are ready (a message record's header packed in front of the message, no copy); one
  commit, scheduled with ``call_soon``, hands every record added during that turn of the
  loop to the OS in one ``writev`` and checks the file, before the answers waiting on it
  are released. An exchange alone in flight commits at once instead of waiting for the
  turn (:meth:`Recorder.aresponse`). A killed process therefore leaves a file holding
  every exchange a client saw answered. There is no writer thread: measured here, thread
  hand-offs and GIL contention cost several times more than the writing itself. Only a
  record over a
  megabyte is written from a worker thread, with the file to itself meanwhile.
- **Loss detection.** Every commit checks that the file still has a name; records lost
  with a deleted file (or folder) are written again to a new one before anything is
  answered. A moved file keeps its records and is noticed by the probe.
- **The disk-full probe.** After a failed write nothing is answered and no file is created
  until a small probe file can be written and synced (:meth:`Recorder.probe`). A closed
  file whose compaction failed for lack of space is compacted again once the probe can
  write.
- **Rotation and compaction.** A file is closed when it passes ``max_bytes`` or
  ``max_age_s`` and compacted off the loop (:mod:`plotgate.service.recording.compaction`);
  ``close`` waits for the compactions up to ``compaction_wait_s``.
"""

import asyncio
import contextlib
import itertools
import json
import logging
import os
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from plotgate.files import temporary_beside
from plotgate.service.recording.compaction import (
    FAILURES,
    Compactions,
    compact,
    remove_leftovers,
)
from plotgate.service.recording.files import FileLost, FileMoved, RecordingFile, file_name
from plotgate.service.recording.records import file_head, message_header
from plotgate.service.registry import Operation
from plotgate.service.schemas import request_schema, response_schema

__all__ = [
    "Exchange",
    "LARGE_RECORD_BYTES",
    "MIN_ROTATE_BYTES",
    "PROBE_BYTES",
    "Recorder",
    "RecordingError",
    "rotation_bytes",
]

log = logging.getLogger("plotgate")

LARGE_RECORD_BYTES = 2**20
"""Records over this size are handed to the OS from a worker thread, not on the event loop."""

PROBE_BYTES = 2**16
"""Bytes the probe writes: more than a new file's head (its schemas and channels, 35 KB
for the operations of this build), so that a disk a probe passes has room to open a file,
and one with less refuses at once without creating and removing a file per request."""


MIN_ROTATE_BYTES = 4 * 2**20
"""The floor of the service's rotation size (``PLOTGATE_ROTATE_BYTES``): a smaller one is
raised to it, with a warning. A new file starts with its head (schemas and channels, about
263 KB for the operations of this build), so below the head every commit opened a new
file (measured: 897 files, and 15 requests/s instead of 1,740). At 4 MiB the head is
about 6% of a file."""


def rotation_bytes(asked: int) -> int:
    """The rotation size the service uses for ``asked`` (``PLOTGATE_ROTATE_BYTES``): at least
    :data:`MIN_ROTATE_BYTES`, a warning logged when it is raised."""
    if asked >= MIN_ROTATE_BYTES:
        return asked
    log.warning(
        "PLOTGATE_ROTATE_BYTES %d is below its floor: files rotate at %d bytes",
        asked,
        MIN_ROTATE_BYTES,
    )
    return MIN_ROTATE_BYTES


class RecordingError(RuntimeError):
    """The recorder could not write a record (disk full, directory gone, closed)."""


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
    the OS by a worker thread, with the file to itself meanwhile), or plain code
    (``request``, ``response``, ``flush``, ``close``).

    Nothing is answered unrecorded. Every commit checks that the file is still named where
    it was written: a file whose folder was deleted (an operator's ``rm -rf``, a volume
    unmounted) takes every record written to it since it was opened, so the folder is
    created again, a new file opened, and the records of every exchange still in flight
    written to it once more before any of them is answered. A failed write (disk full, read
    only) is tried once more in a new file the same way, opened only when a probe can
    write to the folder; if that fails too, the exchanges waiting on the commit get
    :class:`RecordingError` (the service answers 503) and the recorder is not
    :attr:`ready` until :meth:`probe` can write to the folder again. Meanwhile no file is
    created, and a file none of whose commits succeeded is removed.

    The state is the current file (``None`` between files), the failure that stopped the
    last write (``error``), whether some in-flight record must be written again, and
    whether the recorder is closed.

    Parameters
    ----------
    directory : folder for the files; created if missing, and again if it disappears.
    operations : the registry's operations; each gets a request and a response channel.
    max_bytes : rotate when the current file reaches this size.
    max_age_s : rotate when the current file is this old.
    metadata : string key/values written into every file's ``plotgate`` metadata record.
    file_name : write exactly this one file in ``directory`` and never rotate (replay's
        ``--out``); by default files are named by time and pid and rotate.
    on_flush : called with the duration (s) of every commit that wrote records (metrics).
    other_channels : more channels, ``(topic, schema name, schema, encoding)`` of
        :func:`~plotgate.service.recording.records.file_head`, whose messages
        :meth:`message` adds (replay's ``/replay/diff`` log).
    compaction_wait_s : how long ``close`` waits for running compactions (the service's
        graceful-shutdown budget); those still running then are stopped, their files left
        unchunked and readable.
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
        compaction_wait_s: float = 30.0,
        other_channels: Iterable[tuple[str, str, bytes, str]] = (),
    ) -> None:
        self.directory = Path(directory)
        self.max_bytes = max_bytes
        self.max_age_s = max_age_s
        self.metadata = dict(metadata or {})
        self.file_name = file_name
        self.on_flush = on_flush
        self.compaction_wait_s = compaction_wait_s
        self.files: list[Path] = []
        operation_channels = (
            (f"{op.name}/{kind}", f"plotgate.{op.name}.{kind}", json.dumps(schema).encode())
            for op in operations
            for kind, schema in (
                ("request", request_schema(op.request)),
                ("response", response_schema(op.response)),
            )
        )
        self._head, self._channels = file_head(
            itertools.chain(operation_channels, other_channels), self.metadata
        )
        self.records = 0  # records handed to the OS
        self.pending = 0  # records added, waiting for the next commit
        self.rotations = 0  # files closed because of size or age
        self.rewritten = 0  # records written again after their file was lost
        self._bytes_closed = 0  # bytes written to the files already closed
        self._closed = False
        self._error: Exception | None = None
        self._file: RecordingFile | None = None
        self._opened = 0  # files opened: the number of the current or last one
        self._sequence = 0  # message records added (their MCAP sequence numbers)
        self._buffers: list[bytes] = []  # record bytes added since the last commit
        self._compactions = Compactions()
        self._batch: asyncio.Future[None] | None = None  # made when an answer waits
        self._due: asyncio.Handle | None = None  # this turn's commit, once scheduled
        self._lock: asyncio.Lock | None = None  # held while a worker thread writes
        self._flush_waiting = False
        self._inflight: set[Exchange] = set()
        self._unflushed: list[Exchange] = []  # request records added since the last commit
        self._answered: list[Exchange] = []  # response records added since the last commit
        self._lost = False  # some in-flight record must be written again

    def start(self) -> "Recorder":
        """Check the folder can be written (:class:`RecordingError` saying why, a file in
        its place included) and remove the temporaries of compactions that died; the
        first file is opened by the first record."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecordingError(f"cannot create the folder {self.directory}: {exc}") from exc
        if not self._folder_writable():
            raise RecordingError(f"cannot write to {self.directory}")
        for leftover in remove_leftovers(self.directory):
            log.info("removed %s, left by a compaction that did not finish", leftover)
        return self

    def close(self) -> None:
        """Commit what is pending, close the file and compact it; wait up to
        ``compaction_wait_s`` for the compactions still running."""
        if self._closed:
            return
        self.flush()
        self._closed = True
        self._finish()
        self._compactions.wait(self.compaction_wait_s)

    @property
    def compacting(self) -> list[Path]:
        """The files being compacted by child processes now."""
        return self._compactions.running

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
        comes back with the disk by itself. It also collects finished compactions.
        """
        if self._closed:
            return False
        if self._lock is not None and self._lock.locked():
            return self.ready  # a worker thread is writing: look next time
        self._compactions.reap()
        if self._file is not None:
            try:
                self._file.check(moved=True)
            except FileMoved:
                self._finish(compact_it=False)
            except FileLost as exc:
                self._drop(exc, whole_file=True)
        if self._error is not None or not self._folder_writable():
            failure = self._write_probe()
            if failure is not None:
                self._error = self._error or failure
                return False
            self._error = None
        if self._lost:
            self.flush()
        self._compact_again()
        return self.ready

    def _compact_again(self) -> None:
        """Start again the compactions that failed for lack of space, once a probe can
        write: files closed while the disk was full are compacted when space returns (at
        most one try per file per probe while it is still full)."""
        if not self._compactions.no_space or self._write_probe() is not None:
            return
        waiting, self._compactions.no_space = self._compactions.no_space, []
        for path in waiting:
            if path.exists():
                self._compactions.start(path)

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
            fd, probe = temporary_beside(probe, suffix="")  # never a planted name
            with os.fdopen(fd, "wb") as f:
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

    def message(self, topic: str, data: bytes, log_time: int) -> None:
        """Add a message on one of ``other_channels`` (plain code: written by the next
        ``flush``); never written again after a lost file, as exchanges' records are."""
        self._add(topic, data, log_time)

    def response(self, exchange: Exchange, data: bytes, log_time: int | None = None) -> None:
        """Add a response record; it is written by the next ``flush`` or ``close``."""
        exchange.response, exchange.response_time = data, log_time or time.time_ns()
        self._write_response(exchange)

    async def arequest(self, operation: str, data: bytes) -> Exchange:
        """Add a request record on the event loop; it is committed this turn.

        Returns the exchange to answer with :meth:`aresponse`, or to :meth:`forget` when no
        answer will be recorded.
        """
        exchange = Exchange(operation, data, time.time_ns())
        await self._exclusive(self._write_request, exchange, len(data))
        self._inflight.add(exchange)
        self._schedule()
        return exchange

    async def aresponse(self, exchange: Exchange, data: bytes) -> None:
        """Add a response record and return once both records of the exchange are with the
        OS (:class:`RecordingError` if they cannot be).

        An exchange alone in flight commits at once, here: no other answer could share
        its commit, and waiting for the next turn of the loop (a future, its shield, the
        turn itself) cost it more than the commit (measured in bench/HISTORY.md,
        "Recording's write path": 36 against 56 us an exchange). With others in flight it
        waits for this turn's group commit, which their records share (one ``writev`` and
        one ``fstat`` for all: committing each at once cost twice as much at 10 and 50
        clients), as it does while a worker thread writes.
        """
        try:
            exchange.response, exchange.response_time = data, time.time_ns()
            await self._exclusive(self._write_response, exchange, len(data))
            if len(self._inflight) == 1 and (self._lock is None or not self._lock.locked()):
                # alone in flight: no other answer to share a commit, which takes every
                # record added so far, so the one scheduled for this turn has none left
                if self._due is not None:
                    self._due.cancel()
                    self._due = None
                self._commit_batch()
                return
            await asyncio.shield(self._waiter())
        finally:
            self.forget(exchange)

    async def _exclusive(
        self, write: Callable[[Exchange], None], exchange: Exchange, size: int
    ) -> None:
        """Add a record with the file to itself: on the loop for a small record; for one
        over :data:`LARGE_RECORD_BYTES`, the records added so far are then handed to the OS
        by a worker thread (copying tens of megabytes into the page cache would stall every
        other request); the commit that falls due meanwhile waits for it
        (:meth:`_flush_due`)."""
        if size <= LARGE_RECORD_BYTES and (self._lock is None or not self._lock.locked()):
            write(exchange)  # no thread is writing, and nothing can start one meanwhile
            return
        if self._lock is None:
            self._lock = asyncio.Lock()
        async with self._lock:
            write(exchange)
            if size <= LARGE_RECORD_BYTES or self._file is None:
                return
            buffers, self._buffers = self._buffers, []
            try:
                await asyncio.to_thread(self._file.write, buffers)
            except OSError as exc:
                self._drop(exc, whole_file=False)
                raise RecordingError(f"could not record: {exc}") from exc
            finally:
                if self._flush_waiting:
                    self._flush_waiting = False
                    self._due = asyncio.get_running_loop().call_soon(self._flush_due)

    def forget(self, exchange: Exchange) -> None:
        """Stop keeping an exchange's records (answered, or refused unrecorded)."""
        self._inflight.discard(exchange)

    @property
    def bytes_written(self) -> int:
        """Bytes written to every file of this recorder (as written, before compaction)."""
        return self._bytes_closed + (self._file.size if self._file is not None else 0)

    def flush(self) -> bool:
        """Hand every added record to the OS and release the answers waiting on them.

        The records are written, then the file checked: still linked in its folder. A lost
        or failed file is replaced once (:meth:`_commit`); if that fails too, the waiting
        answers get :class:`RecordingError`, and False is returned, so that plain code,
        which has no answer waiting, learns it too (True: every record is with the OS).
        """
        try:
            self._commit_batch()
        except RecordingError:
            return False
        return True

    def _commit_batch(self) -> None:
        """Commit (:meth:`_commit`) and release the answers waiting on this turn's commit,
        with :class:`RecordingError` when it failed (raised here too)."""
        batch, self._batch = self._batch, None
        started = time.perf_counter()
        try:
            wrote = self._commit()
        except RecordingError as exc:
            if batch is not None and not batch.done():
                batch.set_exception(exc)
                # retrieved here: a turn whose only records are requests (their answers
                # then commit alone, or never come) has nobody waiting on it, and asyncio
                # logged "Future exception was never retrieved" with a traceback for it
                batch.exception()
            raise
        if wrote and self.on_flush is not None:
            self.on_flush(time.perf_counter() - started)
        if batch is not None and not batch.done():
            batch.set_result(None)

    def _commit(self) -> bool:
        """Write the added records to the current file and check it; on loss or failure,
        write the in-flight records to a new file and commit that. True when records were
        written."""
        if self.pending == 0 and not self._lost:
            return False  # nothing added since the last commit
        for attempt in (1, 2):
            try:
                if self._lost:
                    self._open()
                if self._file is None:
                    return False
                self._write_out(self._file)
                self._file.check()
                self._file.commits += 1
            except Exception as exc:
                self._drop(exc, whole_file=isinstance(exc, FileLost))
                if attempt == 2:
                    raise RecordingError(f"could not record: {exc}") from exc
                continue
            self._flushed()
            return True
        raise AssertionError("unreachable")

    def _write_out(self, file: RecordingFile) -> None:
        if self._buffers:
            buffers, self._buffers = self._buffers, []
            file.write(buffers)

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
        exchange.file, exchange.flushed = self._opened, False
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
            if self._file is not None and self._rotation_due(self._file):
                self._rotate()
            if self._file is None:
                self._open()
            self._sequence += 1
            self._buffers += (
                message_header(self._channels[topic], self._sequence, log_time, len(data)),
                data,
            )
            self.pending += 1
        except Exception as exc:
            self._drop(exc, whole_file=False)
            raise RecordingError(f"could not record: {exc}") from exc

    def _schedule(self) -> None:
        """Schedule this turn's commit, once per turn (a request's record needs its commit,
        not a future to wait on: one is made only for the answers that wait,
        :meth:`_waiter`); nothing off a loop."""
        if self._due is not None:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return  # plain code flushes itself
        self._due = loop.call_soon(self._flush_due)

    def _waiter(self) -> asyncio.Future[None]:
        """The future of this turn's commit, one for every answer waiting on it, made by
        the first of them."""
        self._schedule()
        if self._batch is None:
            self._batch = asyncio.get_running_loop().create_future()
        return self._batch

    def _flush_due(self) -> None:
        """This turn's commit, unless a worker thread is writing: then right after it."""
        if self._lock is not None and self._lock.locked():
            self._flush_waiting = True
        else:
            self._due = None
            self.flush()

    def _rotation_due(self, file: RecordingFile) -> bool:
        """The current file, with at least one commit, reached its size or age (a file
        holds at least one commit: without one it would hold nothing)."""
        if self.file_name is not None or file.commits == 0:
            return False
        return file.size >= self.max_bytes or time.monotonic() - file.opened_at >= self.max_age_s

    def _rotate(self) -> None:
        """Close the current file, its records committed first (:meth:`_commit`, so they are
        with the OS before any of them is answered), and compact it off the loop."""
        assert self._file is not None
        number = self._file.number
        self._commit()
        if self._file is None or self._file.number != number:
            return  # the file was lost and replaced: nothing left to close
        self.rotations += 1
        self._finish()

    def _finish(self, compact_it: bool = True) -> None:
        """Write what is pending and the footer, close the file, and compact it: in a child
        process on a running loop, here otherwise. Not compacted: a moved file."""
        file = self._file
        if file is None:
            return
        try:
            self._write_out(file)
            file.close()
        except OSError as exc:
            self._drop(exc, whole_file=False)
            return
        self._file = None
        self._bytes_closed += file.size
        self._flushed()
        if not compact_it:
            return
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            self._compact_here(file.path)
            return
        self._compactions.start(file.path)

    def _compact_here(self, path: Path) -> None:
        """Compact in this thread (plain code, no loop to keep answering)."""
        try:
            compact(path)
        except FAILURES as exc:
            log.warning("%s left uncompacted: %s", path, exc)

    def _open(self) -> None:
        """Open the next file (creating the folder if it is gone), and write into it every
        in-flight record whose file was lost.

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
        number = len(self.files) + 1  # files[number - 1], once it is open
        path = self.directory / (self.file_name or file_name(number))
        if self.file_name is not None and self.files and path.exists():
            # the one file failed: opening its name again would truncate what it holds
            raise RecordingError(f"{path}: {self._error}; not opened again over its records")
        self._file = RecordingFile(path, number, self._head)
        self.files.append(path)
        self._opened = number
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

    def _drop(self, exc: Exception, *, whole_file: bool) -> None:
        """Abandon the current file after ``exc``: mark for writing again every in-flight
        record it took (all of them when the file itself is gone, else those not yet
        committed; every response, since an exchange leaves once its response is
        committed). A file none of whose commits succeeded is removed: it holds nothing
        acknowledged, and left behind it would be a headless file the readers must skip."""
        self._error = exc
        for exchange in list(self._inflight):  # a snapshot: forget() may run meanwhile
            if exchange.file == self._opened and (whole_file or not exchange.flushed):
                exchange.file, exchange.flushed = 0, False
                self._lost = True
            if exchange.answered:
                self._lost = True
        if whole_file:
            self._find_gone(but=self._opened)
        self._unflushed.clear()
        self._answered.clear()
        self._buffers.clear()
        self.pending = 0
        file, self._file = self._file, None
        if file is not None:
            self._bytes_closed += file.size
            if file.commits == 0 and not whole_file:
                file.remove()
            file.abandon()

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
