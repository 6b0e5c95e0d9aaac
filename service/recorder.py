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
"""

import contextlib
import json
import os
import queue
import threading
import time
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


@dataclass(frozen=True)
class _Item:
    topic: str
    data: bytes
    log_time: int
    done: Future[None] | None


_STOP = object()


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
        self._queue: queue.SimpleQueue[_Item | object] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="mcap-recorder", daemon=True)
        self._closing = False
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
        if self._closing:
            return
        self._closing = True
        self._queue.put(_STOP)
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
        """Queue a request record; it is written with the next batch."""
        self._put(f"{operation}/request", data, log_time, None)

    def response(self, operation: str, data: bytes, log_time: int | None = None) -> Future[None]:
        """Queue a response record; the future resolves once it is handed to the OS."""
        done: Future[None] = Future()
        self._put(f"{operation}/response", data, log_time, done)
        return done

    def _put(self, topic: str, data: bytes, log_time: int | None, done: Future[None] | None):
        if self._closing:
            raise RecordingError("the recorder is closed")
        self._queue.put(_Item(topic, data, log_time or time.time_ns(), done))

    # -- writer thread ----------------------------------------------------------------

    def _run(self) -> None:
        while True:
            try:
                first = self._queue.get(timeout=max(0.05, self._age_left()))
            except queue.Empty:
                self._maybe_rotate()
                continue
            batch = [first]
            while True:
                try:
                    batch.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            items = [item for item in batch if isinstance(item, _Item)]
            self._commit(items)
            if len(items) < len(batch):
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
            for done in waiters:
                done.set_exception(RecordingError(f"could not record: {exc}"))
            return
        self._error = None
        for done in waiters:
            done.set_result(None)

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
