"""plotgate recordings read back: every exchange of any number of MCAP files, each once.

Files are read with :class:`plotgate.clients.scan.Scan`, which reports damage (with its file
offset)
and goes on after it, so a truncated or corrupt file gives every intact record it holds.
Each message is then checked for the shape the recorder writes (:func:`parse_record`): a
JSON object of at most :data:`MAX_DEPTH` levels, a request id the service could have
given, ``raw`` as text for a request (without ``body`` or ``raw``, its body was
empty), a status and a result or problem for a response.
A message that is not is damage too, reported with its offset and skipped.

Requests and responses are paired across every file read (:class:`Reader`), by operation,
request id and time, so an exchange whose response went to the next file after a rotation
is one exchange. Records the recorder wrote twice (a request written again into a new file
after its file was lost: the same id, the same time, the same bytes) count once. Two
records with the same id and time but different bytes are a conflict, which the recorder
never writes: the first read is kept, and the conflict is reported naming both by file and
offset.

Only regular files are opened (a FIFO named ``*.mcap`` would block a reader forever): a
FIFO, socket, device or folder among the paths is refused before anything is read
(:class:`~plotgate.clients.scan.NotRegular`). A file that is empty or does not start with
the MCAP magic is not a recording: it is skipped with a note, and decides no exit code
when other files are recordings.
"""

import json
import os
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import Channel, Message, Metadata, Schema

from plotgate.clients.pairing import (
    MAX_LISTED,
    RECENT,
    Filters,
    Pair,
    Pairing,
    Seen,
    digest,
    iso_time,
)
from plotgate.clients.scan import (
    MAX_RECORD_BYTES,
    Damage,
    Located,
    NotMcap,
    Scan,
    check_regular,
)
from plotgate.service.schemas import REQUEST_ID_PATTERN, Problem

__all__ = [
    "MAX_DEPTH",
    "RECENT",
    "Exchange",
    "OnRecord",
    "Filters",
    "Reader",
    "Recording",
    "exchange_of",
    "iso_time",
    "parse_record",
    "plotgate_channel",
    "read_recording",
    "recording_files",
]

MAX_DEPTH = 256
"""Deepest JSON a record may hold. The service records a body as ``body`` only when its
JSON parser (nesting limit 200) takes it, inside a one-level envelope."""
REQUEST_ID = re.compile(REQUEST_ID_PATTERN)


@dataclass
class Exchange:
    """One request and its response, either of which may be missing: ``response`` is None
    for a request never answered, ``request`` None for an answer whose request record was
    lost to damage."""

    operation: str
    request_id: str
    request: dict[str, Any] | None
    response: dict[str, Any] | None = None
    log_time: int = 0
    """When the request arrived (ns since the epoch); the response's time without one."""
    file: str = ""
    """The file holding the request record (the response's, without one)."""
    original_read: bool = False
    """For a replay (``replay_of`` set): its original was read before it."""
    request_bytes: bytes | None = field(default=None, repr=False)
    response_bytes: bytes | None = field(default=None, repr=False)
    """The two records as they are in the file (valid JSON)."""

    @property
    def replay_of(self) -> str | None:
        """The request id of the exchange this one replays, if it is a replay."""
        return (self.request or {}).get("replay_of")

    @property
    def body(self) -> bytes:
        """The request body as it was sent."""
        request = self.request or {}
        if "body" in request:
            return json.dumps(request["body"]).encode()
        return str(request.get("raw", "")).encode()


@dataclass
class Recording:
    """What one file holds, and what was wrong with it."""

    path: Path
    exchanges: list[Exchange] = field(default_factory=list)
    """Filled by :func:`read_recording` only (a :class:`Reader` streams them instead)."""
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    messages: int = 0
    complete: bool = False
    """The file ends with its footer and magic (its writer finished it)."""
    first_time: int | None = None
    last_time: int | None = None
    size: int = 0
    chunks: int = 0
    chunks_damaged: int = 0
    damage: list[str] = field(default_factory=list)
    """The first :data:`MAX_LISTED` pieces of damage, each with its offset."""
    damage_count: int = 0
    error: str | None = None
    """Why the file could not be read at all (an I/O error); None otherwise."""
    skipped: str | None = None
    """Why the file is not a recording (empty, or no MCAP magic); None when it is one."""

    @property
    def stopped_by(self) -> str | None:
        """What went wrong first: the first damage, or the missing footer; None when
        nothing did."""
        if self.damage:
            return self.damage[0]
        return None if self.complete else "no footer (the writer did not finish the file)"

    def add_damage(self, damage: Damage) -> None:
        self.damage_count += 1
        if len(self.damage) < MAX_LISTED:
            self.damage.append(str(damage))

    def summary(self) -> dict[str, Any]:
        """The file as JSON: path, state, time range, damage."""
        return {
            "path": str(self.path),
            "size": self.size,
            "complete": self.complete,
            "error": self.error,
            "skipped": self.skipped,
            "messages": self.messages,
            "chunks": self.chunks,
            "chunks_damaged": self.chunks_damaged,
            "first_time": iso_time(self.first_time),
            "last_time": iso_time(self.last_time),
            "damage_count": self.damage_count,
            "damage": self.damage,
            "metadata": self.metadata,
        }


def recording_files(paths: Path | str | Iterable[Path | str]) -> list[Path]:
    """The MCAP files at ``paths`` (files, or folders whose ``*.mcap`` are taken), each once,
    in name order (names start with their UTC time, so this is time order).

    Raises ``FileNotFoundError`` for a path that does not exist, and
    :class:`~plotgate.clients.scan.NotRegular` for one, given or in a folder, that is not a
    regular file (a FIFO, socket, device or folder): refused before anything is read.
    """
    if isinstance(paths, str | Path):
        paths = [paths]
    found: dict[Path, Path] = {}
    for path in map(Path, paths):
        if path.is_dir():
            files = list(path.glob("*.mcap"))
        elif path.exists():
            files = [path]
        else:
            raise FileNotFoundError(f"no such file or folder: {path}")
        for f in files:
            try:
                mode = os.stat(f).st_mode
            except FileNotFoundError:  # gone since the folder was listed (a live server's)
                continue
            check_regular(f, mode)
            found.setdefault(f.resolve(), f)
    return sorted(found.values(), key=lambda f: (f.name, str(f)))


_STRINGS = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)
_BARE_STRINGS = re.compile(rb'"[^"]*"')
_NOT_STRUCTURE = bytes(set(range(256)) - set(b'[]{}"'))
_STEP = np.zeros(256, np.int8)
_STEP[list(b"[{")] = 1
_STEP[list(b"]}")] = -1


def _too_deep(text: bytes) -> bool:
    """True when JSON ``text`` nests deeper than :data:`MAX_DEPTH`, from its bytes: the
    strings taken out (with the brackets in them), the brackets left counted, vectorized (a
    walk over the parsed values in Python cost more than the parse itself)."""
    if text.count(b"[") + text.count(b"{") <= MAX_DEPTH:
        return False
    if b"\\" in text:  # escapes: strings found in the whole text
        brackets = _STRINGS.sub(b"", text).translate(None, _NOT_STRUCTURE)
    else:  # every quote delimits a string: find them among the structure alone
        brackets = _BARE_STRINGS.sub(b"", text.translate(None, _NOT_STRUCTURE))
    level = 0
    for start in range(0, len(brackets), 2**20):
        steps = _STEP[np.frombuffer(brackets, np.uint8, min(2**20, len(brackets) - start), start)]
        run = np.cumsum(steps, dtype=np.int64) + level
        if run.max() > MAX_DEPTH:
            return True
        level = int(run[-1])
    return False


def _no_constant(token: str) -> Any:
    raise ValueError(f"{token} is not JSON")


def parse_record(kind: str, operation: str, data: bytes) -> dict[str, Any]:
    """A message of channel ``<operation>/<kind>`` as the recorder writes it, or ValueError
    saying why it is not one."""
    try:
        record = json.loads(data.decode("utf-8"), parse_constant=_no_constant)
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 ({exc.reason} at byte {exc.start})") from None
    except RecursionError:
        raise ValueError(f"JSON nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as exc:  # json.JSONDecodeError, an integer over 4300 digits
        raise ValueError(f"not JSON: {str(exc)[:200]}") from None
    if not isinstance(record, dict):
        raise ValueError(f"a JSON {type(record).__name__}, not an object")
    if _too_deep(data):
        raise ValueError(f"JSON nested deeper than {MAX_DEPTH} levels")
    rid = record.get("request_id")
    if not isinstance(rid, str) or not REQUEST_ID.match(rid):
        raise ValueError("no request_id the service could have given")
    if record.get("operation") != operation:
        raise ValueError(
            f"operation {str(record.get('operation'))[:100]!r} on the channel of {operation}"
        )
    if kind == "request":
        replay_of = record.get("replay_of")
        if replay_of is not None and not (
            isinstance(replay_of, str) and REQUEST_ID.match(replay_of)
        ):
            raise ValueError("replay_of is not a request id")
        if "raw" in record and not isinstance(record["raw"], str):
            raise ValueError("a request record whose raw body is not text")
        return record
    status, duration = record.get("status"), record.get("duration_s")
    if not (type(status) is int and 100 <= status <= 599):
        raise ValueError("a response record without an HTTP status")
    if not (isinstance(duration, int | float) and type(duration) is not bool):
        raise ValueError("a response record without a duration")
    if not 0 <= duration < float("inf"):
        raise ValueError("a response record without a duration")
    if status < 400 and "result" not in record:
        raise ValueError(f"a {status} response record without a result")
    if status >= 400:
        try:
            Problem.model_validate(record.get("error"))
        except ValueError:
            raise ValueError(f"a {status} response record without a problem") from None
    return record


def plotgate_channel(channel: Channel, schemas: set[int]) -> tuple[str, str] | str:
    """(operation, kind) of a plotgate channel (``schemas``: the schema ids declared so
    far), or why the channel is not one."""
    operation, _, kind = channel.topic.rpartition("/")
    name = f"channel {channel.id} ({channel.topic[:100]!r})"
    if not operation or kind not in ("request", "response"):
        return f"{name}, which is not a plotgate channel"
    if channel.message_encoding != "json":
        return f"{name}, which carries {channel.message_encoding[:40]!r} messages, not json"
    if channel.schema_id != 0 and channel.schema_id not in schemas:
        return f"{name}, whose schema {channel.schema_id} no Schema record declared"
    return operation, kind


OnRecord = Callable[[str, str, dict[str, Any], int, Located, bytes], None]
"""Called with each intact record instead of pairing it: (kind, operation, parsed record,
log time, where it is, its bytes)."""


class Reader:
    """Read recordings and give each exchange once (iterate), requests and responses paired
    across every file by (operation, request id) in time order.

    A response pairs with the earliest waiting request of its key; one that comes first
    waits for its request. A request record the same as one already read (same key, same
    time: the recorder wrote it again after losing its file) is not a new exchange, nor is
    a response written twice. Exchanges come as they are completed; requests never answered
    and answers whose request is lost come last. The filters take an exchange by its
    request (an answer without one by itself).

    ``files`` holds a :class:`Recording` for each file as it is read; ``unreadable`` the
    files that could not be read at all; ``skipped`` the files that are not recordings
    (empty, or without the MCAP magic); ``written_twice`` the records seen a second time,
    byte for byte; ``conflicts`` (the first :data:`MAX_LISTED`; ``conflict_count`` all)
    the records with the key and time of one read before but other bytes, each naming both
    records by file and offset. Memory holds the requests waiting for an answer (raw and
    parsed), the keys, digests and places of the last 100,000 answered exchanges and the
    (operation, id) of every original request read (to know a replay whose original was
    read).
    """

    def __init__(
        self,
        paths: Path | str | Iterable[Path | str],
        filters: Filters | None = None,
        *,
        max_record_bytes: int = MAX_RECORD_BYTES,
        span: tuple[int, int] | None = None,
        on_record: OnRecord | None = None,
    ) -> None:
        """``span`` reads only that range of each file (:class:`Scan`); ``on_record`` takes
        every intact record in file order, and then nothing is paired (the fleet replay
        pairs the records of many parts itself)."""
        self.paths = recording_files(paths)
        self.span = span
        self.on_record = on_record
        self.stopped_at = 0
        """Where reading the last file stopped (:attr:`Scan.stopped_at`)."""
        self.filters = filters or Filters()
        self.max_record_bytes = max_record_bytes
        self.files: list[Recording] = []
        self.unreadable: list[str] = []
        self.skipped: list[str] = []
        self._pairing = Pairing(self.filters)

    @property
    def recordings(self) -> int:
        """Files read so far that are recordings (neither skipped nor unreadable)."""
        return sum(rec.error is None and rec.skipped is None for rec in self.files)

    def __iter__(self) -> Iterator[Exchange]:
        for path in self.paths:
            rec = Recording(path)
            self.files.append(rec)
            yield from self._file(rec)
        for pair in self._pairing.leftovers():
            yield exchange_of(pair)

    def _file(self, rec: Recording) -> Iterator[Exchange]:
        scan = Scan(rec.path, max_record_bytes=self.max_record_bytes, span=self.span)
        channels: dict[int, tuple[str, str] | str] = {}
        schemas: set[int] = set()
        try:
            for item in scan:
                if isinstance(item, Damage):
                    rec.add_damage(item)
                elif isinstance(item.record, Schema):
                    schemas.add(item.record.id)
                elif isinstance(item.record, Channel):
                    channels[item.record.id] = plotgate_channel(item.record, schemas)
                elif isinstance(item.record, Metadata):
                    rec.metadata[item.record.name] = dict(item.record.metadata)
                elif isinstance(item.record, Message):
                    yield from self._message(rec, channels, item)
        except NotMcap as exc:
            rec.skipped = f"{exc}: skipped"
            self.skipped.append(rec.skipped)
        except OSError as exc:
            rec.error = f"{rec.path}: cannot be read ({exc.strerror or exc})"
        if rec.error is not None:
            self.unreadable.append(rec.error)
        rec.size, rec.complete = scan.size, scan.complete
        rec.chunks, rec.chunks_damaged = scan.chunks, scan.chunks_damaged
        self.stopped_at = scan.stopped_at

    def _message(
        self, rec: Recording, channels: dict[int, tuple[str, str] | str], item: Located
    ) -> Iterator[Exchange]:
        message = item.record
        assert isinstance(message, Message)
        rec.messages += 1
        t = message.log_time
        rec.first_time = t if rec.first_time is None else min(rec.first_time, t)
        rec.last_time = t if rec.last_time is None else max(rec.last_time, t)
        channel = channels.get(message.channel_id)
        if channel is None:
            channel = f"channel {message.channel_id}, which no Channel record declared"
        try:
            if isinstance(channel, str):
                raise ValueError(f"a message on {channel}")
            operation, kind = channel
            record = parse_record(kind, operation, message.data)
        except ValueError as exc:
            rec.add_damage(Damage(item.offset, str(exc), item.inner))
            return
        if self.on_record is not None:
            self.on_record(kind, operation, record, t, item, message.data)
            return
        rid = record["request_id"]
        replay_of = record.get("replay_of") if kind == "request" else None
        seen = Seen(
            kind, operation, rid, t, digest(message.data), item.offset, item.inner, replay_of
        )
        pair = self._pairing.take(None, str(rec.path), seen, (record, message.data))
        if pair is not None:
            yield exchange_of(pair)

    @property
    def written_twice(self) -> int:
        return self._pairing.written_twice

    @property
    def conflict_count(self) -> int:
        return self._pairing.conflict_count

    @property
    def conflicts(self) -> list[str]:
        return self._pairing.conflicts


def exchange_of(pair: Pair) -> Exchange:
    """The exchange of a pair whose records carry their payloads (parsed record, bytes)."""
    request, response = pair.request, pair.response
    first = request or response
    assert first is not None
    req_record, req_bytes = request.payload if request is not None else (None, None)
    resp_record, resp_bytes = response.payload if response is not None else (None, None)
    return Exchange(
        first.seen.operation,
        first.seen.request_id,
        req_record,
        resp_record,
        first.seen.log_time,
        first.file,
        pair.original_read,
        req_bytes,
        resp_bytes,
    )


def read_recording(path: Path | str) -> Recording:
    """Every exchange of one file, in the order the requests arrived (answers whose request
    is lost left out), with what was wrong with the file."""
    reader = Reader([path])
    exchanges = [ex for ex in reader if ex.request is not None]
    [rec] = reader.files
    rec.exchanges = sorted(exchanges, key=lambda ex: ex.log_time)
    return rec
