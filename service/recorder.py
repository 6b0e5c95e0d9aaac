"""MCAP recorder: every exchange, durably, group-committed on the event loop.

Design (DESIGN section 8):

- One file per process at a time, named ``plotgate-<UTC time>-pid<pid>-<seq>.mcap`` so
  names sort by time and workers of one server never share a file. A file is closed with
  its summary and index and a new one opened when it passes ``max_bytes`` or ``max_age_s``.
- Two channels per operation, ``<op>/request`` and ``<op>/response``, with the JSON schemas
  of :class:`~service.schemas.RequestRecord` and :class:`~service.schemas.ResponseRecord`
  (``jsonschema`` schema encoding, ``json`` messages), and a ``plotgate`` metadata record
  (versions, git commit, settings) at the start of every file.
- mcap's ``Writer`` is not thread-safe and its ``flush()`` closes the current chunk, so
  the event loop owns it and group-commits: records are added as requests arrive and
  answers are ready, and one flush, scheduled with ``call_soon``, writes every record
  added during that turn of the loop (chunk closed, bytes handed to the OS) before the
  answers waiting on it are released. A killed process therefore leaves a file holding
  every exchange a client saw answered. There is no writer thread: measured here, thread
  hand-offs and GIL contention cost several times more than the writing itself.
"""

import asyncio
import contextlib
import json
import os
import time
from collections.abc import Callable, Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

from mcap.writer import CompressionType, Writer
from pydantic_core import from_json

from service.registry import Operation
from service.schemas import RequestRecord, ResponseRecord

__all__ = ["Recorder", "RecordingError", "request_record", "response_record"]


class RecordingError(RuntimeError):
    """The recorder could not write a record (disk full, directory gone, closed)."""


def _is_strict_json(body: bytes) -> bool:
    """True for a body that is one JSON value without NaN or Infinity tokens."""
    try:
        from_json(body, allow_inf_nan=False)
    except ValueError:
        return False
    return True


def _head(request_id: str, operation: str) -> bytes:
    return b'{"request_id": %s, "operation": "%s"' % (
        json.dumps(request_id).encode(), operation.encode()
    )


def request_record(request_id: str, operation: str, body: bytes) -> bytes:
    """The request message: strict-JSON bodies are embedded as they came, others as text."""
    if _is_strict_json(body):
        return b'%s, "body": %s}' % (_head(request_id, operation), body)
    raw = json.dumps(body.decode("utf-8", "backslashreplace"))
    return b'%s, "raw": %s}' % (_head(request_id, operation), raw.encode())


def response_record(
    request_id: str, operation: str, status: int, duration_s: float, content: bytes
) -> bytes:
    """The response message around an answer's JSON ``content`` (result or problem)."""
    key = b"result" if status < 400 else b"error"
    return b'%s, "status": %d, "duration_s": %r, "%s": %s}' % (
        _head(request_id, operation), status, duration_s, key, content
    )


class Recorder:
    """Writes request and response records of the given operations to rotating MCAP files.

    Use it from one thread: the event loop of a server process (``request`` then
    ``await aresponse``), or plain code (``request``, ``response``, ``close``).

    Parameters
    ----------
    directory : folder for the files; created if missing.
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
            (f"{op.name}/{kind}", f"plotgate.{op.name}.{kind}",
             json.dumps(envelope[model].model_json_schema()).encode())
            for op in operations
            for kind, envelope, model in (
                ("request", RequestRecord, op.request),
                ("response", ResponseRecord, op.response),
            )
        ]
        self.records = 0  # records handed to the OS
        self.pending = 0  # records added, waiting for the next flush
        self.rotations = 0  # files closed because of size or age
        self._bytes_closed = 0  # bytes of the files already closed
        self._closed = False
        self._error: Exception | None = None
        self._stream: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._opened_at = 0.0
        self._seq = 0
        self._batch: asyncio.Future[None] | None = None

    def start(self) -> "Recorder":
        """Check the folder can be written; the first file is opened by the first record."""
        self.directory.mkdir(parents=True, exist_ok=True)
        if not os.access(self.directory, os.W_OK):
            raise RecordingError(f"cannot write to {self.directory}")
        return self

    def close(self) -> None:
        """Write what is pending, then the summary and index, and close the file."""
        if self._closed:
            return
        self.flush()
        self._closed = True
        self._finish()

    @property
    def ready(self) -> bool:
        """True while records can be written: open, no failed write, directory writable."""
        return not self._closed and self._error is None and os.access(self.directory, os.W_OK)

    def probe(self) -> bool:
        """After a failed write, try the folder again (a small file written and removed,
        synced); clear the failure when that works. Then :attr:`ready`.

        ``/readyz`` calls it, so readiness comes back when the disk does, without waiting
        for a request to try.
        """
        if self._error is not None and not self._closed:
            probe = self.directory / f".plotgate-probe-{os.getpid()}"
            try:
                with open(probe, "wb") as f:
                    f.write(b"\0" * 4096)
                    f.flush()
                    os.fsync(f.fileno())
                probe.unlink()
            except OSError:
                with contextlib.suppress(OSError):
                    probe.unlink()
                return False
            self._error = None
        return self.ready

    def request(self, operation: str, data: bytes, log_time: int | None = None) -> None:
        """Add a request record; on a running loop it is flushed this turn."""
        self._add(f"{operation}/request", data, log_time)
        self._schedule()

    def response(self, operation: str, data: bytes, log_time: int | None = None) -> None:
        """Add a response record; it is written by the next ``flush`` or ``close``."""
        self._add(f"{operation}/response", data, log_time)

    async def aresponse(self, operation: str, data: bytes, log_time: int | None = None) -> None:
        """Add a response record and wait until the flush holding it has reached the OS."""
        self._add(f"{operation}/response", data, log_time)
        batch = self._schedule()
        assert batch is not None
        await asyncio.shield(batch)

    @property
    def bytes_written(self) -> int:
        """Bytes of every file this recorder has written, the current one included."""
        current = 0
        if self._stream is not None:
            with contextlib.suppress(OSError, ValueError):
                current = self._stream.tell()
        return self._bytes_closed + current

    def flush(self) -> None:
        """Close the current chunk, hand every added record to the OS, release its waiters."""
        if self._writer is not None:
            started = time.perf_counter()
            try:
                self._writer.flush()
            except Exception as exc:
                self._fail(exc)
                return
            if self.on_flush is not None:
                self.on_flush(time.perf_counter() - started)
            self.records += self.pending
            self.pending = 0
        batch, self._batch = self._batch, None
        if batch is not None and not batch.done():
            batch.set_result(None)

    def _add(self, topic: str, data: bytes, log_time: int | None) -> None:
        if self._closed:
            raise RecordingError("the recorder is closed")
        try:
            self._maybe_rotate()
            if self._writer is None:
                self._open()
            assert self._writer is not None
            stamp = log_time or time.time_ns()
            self._writer.add_message(self._channels[topic], stamp, data, stamp)
            self.pending += 1
        except Exception as exc:
            self._fail(exc)
            raise RecordingError(f"could not record: {exc}") from exc

    def _schedule(self) -> asyncio.Future[None] | None:
        """The future of this turn's flush, scheduled once per turn; None off a loop."""
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return None
        if self._batch is None:
            self._batch = loop.create_future()
            loop.call_soon(self.flush)
        return self._batch

    def _maybe_rotate(self) -> None:
        if self._stream is None or self.file_name is not None:
            return
        age = time.monotonic() - self._opened_at
        if self._stream.tell() >= self.max_bytes or age >= self.max_age_s:
            self._finish()
            self.rotations += 1

    def _open(self) -> None:
        """Open the next file. Lazily, on a record: a file without messages would lose its
        schemas and channels, which mcap's writer keeps in the chunk being built."""
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
        self._seq += 1
        name = self.file_name or f"plotgate-{stamp}-pid{os.getpid()}-{self._seq:04d}.mcap"
        path = self.directory / name
        self._stream = open(path, "wb")  # noqa: SIM115 - open for the file's whole life
        self.files.append(path)
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

    def _finish(self) -> None:
        """Write the summary and index and close the file."""
        if self._writer is not None and self._stream is not None:
            try:
                self._writer.finish()
                self._bytes_closed += self._stream.tell()
                self._stream.close()
                self.records += self.pending
                self.pending = 0
            except OSError as exc:
                self._fail(exc)
        self._writer = None
        self._stream = None

    def _fail(self, exc: Exception) -> None:
        """Drop a file that failed mid-write, and fail every answer waiting on its records.

        The next record opens a new file.
        """
        self._error = exc
        self.pending = 0  # lost with the file
        batch, self._batch = self._batch, None
        if batch is not None and not batch.done():
            batch.set_exception(RecordingError(f"could not record: {exc}"))
        if self._stream is not None:
            with contextlib.suppress(OSError):
                self._stream.close()
        self._writer = None
        self._stream = None
