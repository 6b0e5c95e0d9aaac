"""MCAP recorder: every exchange, durably, from one writer thread per process.

Design (DESIGN section 8):

- One file per process at a time, named ``plotgate-<UTC time>-pid<pid>-<seq>.mcap`` so
  names sort by time and workers of one server never share a file. A file is closed with
  its summary and index and a new one opened when it passes ``max_bytes`` or ``max_age_s``.
- Two channels per operation, ``<op>/request`` and ``<op>/response``, with the JSON schemas
  of :class:`~service.schemas.RequestRecord` and :class:`~service.schemas.ResponseRecord`
  (``jsonschema`` schema encoding, ``json`` messages), and a ``plotgate`` metadata record
  (versions, git commit, settings) at the start of every file.
- mcap's ``Writer`` is not thread-safe and its ``flush()`` closes the current chunk, so a
  single thread owns it and group-commits: it takes every record queued so far, writes
  them, flushes once (chunk closed, bytes handed to the OS) and only then resolves the
  futures of the responses in that batch. A response is answered after its future
  resolves, so a killed process leaves a file holding every exchange a client saw.
- Only a response (which someone waits for) wakes the writer; a request record rides with
  the next flush, at most ``REQUEST_FLUSH_S`` later. The waiters of a batch are released
  with one wake-up per event loop. Both keep the cost of durability per request small.
"""

import asyncio
import contextlib
import json
import os
import threading
import time
from collections import defaultdict
from collections.abc import Iterable, Mapping
from concurrent.futures import Future
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

from mcap.writer import Writer

from service.registry import Operation
from service.schemas import RequestRecord, ResponseRecord

__all__ = ["Recorder", "RecordingError", "request_record", "response_record"]


class RecordingError(RuntimeError):
    """The recorder could not write a record (disk full, directory gone, closed)."""


REQUEST_FLUSH_S = 0.1
"""Longest a request record waits in memory for a response record to share its flush."""

Waiter = Future[None] | asyncio.Future[None]


@dataclass(frozen=True)
class _Item:
    topic: str
    data: bytes
    log_time: int
    done: Waiter | None


def _resolve(futures: list[asyncio.Future[None]], exc: Exception | None) -> None:
    """Settle asyncio futures; runs on their event loop."""
    for done in futures:
        if not done.done():
            if exc is None:
                done.set_result(None)
            else:
                done.set_exception(exc)


def _settle(waiters: list[Waiter], exc: Exception | None) -> None:
    """Settle every waiter of a batch: one wake-up per event loop, not one per request."""
    by_loop: dict[asyncio.AbstractEventLoop, list[asyncio.Future[None]]] = defaultdict(list)
    for done in waiters:
        if isinstance(done, asyncio.Future):
            by_loop[done.get_loop()].append(done)
        elif exc is None:
            done.set_result(None)
        else:
            done.set_exception(exc)
    for loop, futures in by_loop.items():
        with contextlib.suppress(RuntimeError):  # the loop has closed: nobody waits
            loop.call_soon_threadsafe(_resolve, futures, exc)


def _is_strict_json(body: bytes) -> bool:
    def reject(token: str) -> None:
        raise ValueError(token)

    try:
        json.loads(body, parse_constant=reject)
    except ValueError:
        return False
    return True


def request_record(request_id: str, operation: str, body: bytes) -> bytes:
    """The request message: strict-JSON bodies are embedded as they came, others as text."""
    head = json.dumps({"request_id": request_id, "operation": operation})[:-1]
    if body.strip() and _is_strict_json(body):
        return b"%s, \"body\": %s}" % (head.encode(), body)
    raw = json.dumps(body.decode("utf-8", "backslashreplace"))
    return b"%s, \"raw\": %s}" % (head.encode(), raw.encode())


def response_record(
    request_id: str, operation: str, status: int, duration_s: float, content: bytes
) -> bytes:
    """The response message around an answer's JSON ``content`` (result or problem)."""
    head = json.dumps(
        {"request_id": request_id, "operation": operation, "status": status,
         "duration_s": duration_s}
    )[:-1]
    key = b"result" if status < 400 else b"error"
    return b"%s, \"%s\": %s}" % (head.encode(), key, content)


class Recorder:
    """Writes request and response records of the given operations to rotating MCAP files.

    Parameters
    ----------
    directory : folder for the files; created if missing.
    operations : the registry's operations; each gets a request and a response channel.
    max_bytes : rotate when the current file reaches this size.
    max_age_s : rotate when the current file is this old.
    metadata : string key/values written into every file's ``plotgate`` metadata record.
    file_name : write exactly this one file in ``directory`` and never rotate (replay's
        ``--out``); by default files are named by time and pid and rotate.
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
    ) -> None:
        self.directory = Path(directory)
        self.max_bytes = max_bytes
        self.max_age_s = max_age_s
        self.metadata = dict(metadata or {})
        self.file_name = file_name
        self.files: list[Path] = []
        self._schemas = [
            (f"{op.name}/{kind}", f"plotgate.{op.name}.{kind}",
             json.dumps(envelope[model].model_json_schema()).encode())
            for op in operations
            for kind, envelope, model in (
                ("request", RequestRecord, op.request),
                ("response", ResponseRecord, op.response),
            )
        ]
        self._cond = threading.Condition()
        self._pending: list[_Item] = []
        self._waited_for = False
        self._closing = False
        self._thread = threading.Thread(target=self._run, name="mcap-recorder", daemon=True)
        self._error: Exception | None = None
        self._stream: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._opened_at = 0.0
        self._seq = 0

    # -- public API, any thread -------------------------------------------------------

    def start(self) -> "Recorder":
        self.directory.mkdir(parents=True, exist_ok=True)
        self._open()
        self._thread.start()
        return self

    def close(self) -> None:
        """Write what is queued, then the summary and index, and close the file."""
        with self._cond:
            if self._closing:
                return
            self._closing = True
            self._cond.notify()
        self._thread.join()

    @property
    def ready(self) -> bool:
        """True while records are being written and the directory is writable."""
        return (
            self._thread.is_alive()
            and not self._closing
            and self._error is None
            and os.access(self.directory, os.W_OK)
        )

    def request(self, operation: str, data: bytes, log_time: int | None = None) -> None:
        """Queue a request record; it is written with the next flush (within REQUEST_FLUSH_S)."""
        self._put(f"{operation}/request", data, log_time, None)

    def response(self, operation: str, data: bytes, log_time: int | None = None) -> Future[None]:
        """Queue a response record; the future resolves once it is handed to the OS."""
        done: Future[None] = Future()
        self._put(f"{operation}/response", data, log_time, done)
        return done

    async def aresponse(self, operation: str, data: bytes, log_time: int | None = None) -> None:
        """Queue a response record and wait, without blocking the loop, until it is written."""
        done: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._put(f"{operation}/response", data, log_time, done)
        await done

    def _put(self, topic: str, data: bytes, log_time: int | None, done: Waiter | None) -> None:
        item = _Item(topic, data, log_time or time.time_ns(), done)
        with self._cond:
            if self._closing:
                raise RecordingError("the recorder is closed")
            self._pending.append(item)
            if done is not None:
                self._waited_for = True
                self._cond.notify()

    # -- writer thread ----------------------------------------------------------------

    def _run(self) -> None:
        while True:
            with self._cond:
                timeout = self._age_left()
                if self._pending:
                    timeout = min(timeout, REQUEST_FLUSH_S)
                self._cond.wait_for(lambda: self._waited_for or self._closing, max(0.0, timeout))
                batch, self._pending, self._waited_for = self._pending, [], False
                closing = self._closing
            if batch:
                self._commit(batch)
            if closing:
                self._finish()
                return
            self._maybe_rotate()

    def _commit(self, items: list[_Item]) -> None:
        waiters = [item.done for item in items if item.done is not None]
        try:
            if self._writer is None:
                self._open()
            assert self._writer is not None
            for item in items:
                self._writer.add_message(
                    self._channels[item.topic], item.log_time, item.data, item.log_time
                )
            self._writer.flush()
        except Exception as exc:
            self._error = exc
            self._abandon()
            _settle(waiters, RecordingError(f"could not record: {exc}"))
            return
        self._error = None
        _settle(waiters, None)

    def _age_left(self) -> float:
        if self._stream is None:
            return self.max_age_s
        return self._opened_at + self.max_age_s - time.monotonic()

    def _maybe_rotate(self) -> None:
        if self._stream is None:
            return
        if self.file_name is None and (
            self._stream.tell() >= self.max_bytes or self._age_left() <= 0
        ):
            self._finish()

    def _open(self) -> None:
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
        self._seq += 1
        name = self.file_name or f"plotgate-{stamp}-pid{os.getpid()}-{self._seq:04d}.mcap"
        path = self.directory / name
        self._stream = open(path, "wb")
        self.files.append(path)
        writer = Writer(self._stream)
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

    def _finish(self) -> None:
        if self._writer is not None and self._stream is not None:
            try:
                self._writer.finish()
                self._stream.close()
            except OSError as exc:
                self._error = exc
                self._abandon()
        self._writer = None
        self._stream = None

    def _abandon(self) -> None:
        """Drop a file that failed mid-write; the next batch opens a new one."""
        if self._stream is not None:
            with contextlib.suppress(OSError):
                self._stream.close()
        self._writer = None
        self._stream = None
