"""plotgate recordings read back: every exchange of any number of MCAP files, each once.

Files are read with :class:`plotgate.clients.mcap_reader.RecordReader`, which reports
damage (with its file offset) and goes on after it, so a truncated or corrupt file gives
every intact record it holds.
Each message is then checked for the shape the recorder writes
(:mod:`plotgate.clients.messages`: a JSON object of at most :data:`MAX_DEPTH` levels, a
request id the service could have given, ``raw`` as text for a request, a status and a
result or problem for a response), all the messages of a chunk at once, by msgspec's
compiled parser, with the verdicts of ``json``. A message that is not is damage too,
reported with its offset and skipped. A message's values are built only when asked for
(:attr:`Exchange.request`, :attr:`Exchange.response`): ``cat`` and ``inspect`` never need
them.

Requests and responses are paired across every file read (:class:`Reader`), by operation,
request id and time, so an exchange whose response went to the next file after a rotation
is one exchange. Records the recorder wrote twice (a request written again into a new file
after its file was lost: the same id, the same time, the same bytes) count once. Two
records with the same id and time but different bytes are a conflict, which the recorder
never writes: the first read is kept, and the conflict is reported naming both by file and
offset. Records are told apart by a keyed 64-bit hash of their bytes (Python's ``hash``,
SipHash with a key drawn at each start), which a hostile file cannot aim at without the key.
The rules are :class:`plotgate.clients.pairing.Pairing`'s, which the fleet replay's merge
(:mod:`plotgate.clients.fleet`) pairs with too, so the two cannot drift apart.

A file without its footer is *open* while a process on this host still has it open (its
name carries its writer's ``pid``; :mod:`plotgate.clients.live`), *unfinished* otherwise:
its cut-short tail is not damage (:class:`~plotgate.clients.mcap_reader.RecordReader`).

Only regular files are opened (a FIFO named ``*.mcap`` would block a reader forever): a
FIFO, socket, device or folder among the paths is refused before anything is read
(:class:`~plotgate.clients.mcap_reader.NotRegular`). A file that is empty or does not start with
the MCAP magic is not a recording: it is skipped with a note, and decides no exit code
when other files are recordings.
"""

import json
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.records import Channel, Metadata, Schema

from plotgate.clients.live import writer_alive
from plotgate.clients.mcap_reader import (
    MAX_RECORD_BYTES,
    Damage,
    Messages,
    NotMcap,
    RecordReader,
    check_regular,
)
from plotgate.clients.messages import (
    MAX_DEPTH,
    Envelope,
    check_messages,
    check_time,
    loads,
    parse_record,
)
from plotgate.clients.pairing import MAX_LISTED, Filters, Pair, Pairing, Seen, iso_time

__all__ = [
    "DIFF_TOPIC",
    "MAX_DEPTH",
    "Exchange",
    "Filters",
    "OnRecord",
    "Reader",
    "Recording",
    "SCENE",
    "TRANSFORM",
    "exchange_of",
    "file_state",
    "iso_time",
    "parse_record",
    "plotgate_channel",
    "read_recording",
    "recording_files",
]

_CHECKED_TOGETHER = 2**20
"""Bytes of messages checked in one call of :func:`~plotgate.clients.messages.check_messages`."""


class Exchange:
    """One request and its response, either of which may be missing: ``response`` is None
    for a request never answered, ``request`` None for an answer whose request record was
    lost to damage.

    A :class:`Reader` keeps the records as they are in the file (``request_bytes``,
    ``response_bytes``: checked, valid JSON) and their values are built on first use of
    :attr:`request` and :attr:`response`; ``replay_of``, ``status`` and ``duration_s`` come
    from the records' envelopes without building them. Made from values instead (the first
    arguments, as a test or a replay builds one), those come from the values.
    """

    def __init__(
        self,
        operation: str,
        request_id: str,
        request: dict[str, Any] | None = None,
        response: dict[str, Any] | None = None,
        log_time: int = 0,
        file: str = "",
        original_read: bool = False,
        request_bytes: bytes | None = None,
        response_bytes: bytes | None = None,
        *,
        replay_of: str | None = None,
        status: int | None = None,
        duration_s: float | None = None,
    ) -> None:
        self.operation, self.request_id = operation, request_id
        self.log_time = log_time
        """When the request arrived (ns since the epoch); the response's time without one."""
        self.file = file
        """The file holding the request record (the response's, without one)."""
        self.original_read = original_read
        """For a replay (``replay_of`` set): its original was read before it."""
        self.request_bytes, self.response_bytes = request_bytes, response_bytes
        self._request, self._response = request, response
        self.replay_of = replay_of if request is None else request.get("replay_of")
        """The request id of the exchange this one replays, if it is a replay."""
        self.status = status if response is None else response.get("status")
        """The response's HTTP status (None without a response)."""
        self.duration_s = duration_s if response is None else response.get("duration_s")
        """How long the server took to answer (None without a response)."""

    def __repr__(self) -> str:
        return (
            f"Exchange({self.operation!r}, {self.request_id!r}, status={self.status!r}, "
            f"file={self.file!r})"
        )

    @property
    def request(self) -> dict[str, Any] | None:
        """The request record's values."""
        if self._request is None and self.request_bytes is not None:
            self._request = loads(self.request_bytes)
        return self._request

    @property
    def response(self) -> dict[str, Any] | None:
        """The response record's values."""
        if self._response is None and self.response_bytes is not None:
            self._response = loads(self.response_bytes)
        return self._response

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
    state: str = "unread"
    """``complete``; ``open`` (no footer, and a process on this host still has the file
    open: its writer); ``unfinished`` (no footer, no writer: killed, or gone elsewhere)."""
    tail: str | None = None
    """For an open or unfinished file, what its last bytes are."""
    first_time: int | None = None
    last_time: int | None = None
    size: int = 0
    chunks: int = 0
    chunks_damaged: int = 0
    damage: list[str] = field(default_factory=list)
    """The first :data:`MAX_LISTED` pieces of damage, each with its offset."""
    damage_count: int = 0
    scene_messages: int = 0
    """Scene updates and logs of ``plotgate view`` (:data:`SCENE`; its transforms are read
    and not counted): neither exchanges nor damage."""
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
        return None if self.complete else f"no footer (the file is {self.state})"

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
            "state": self.state,
            "tail": self.tail,
            "error": self.error,
            "skipped": self.skipped,
            "messages": self.messages,
            "chunks": self.chunks,
            "chunks_damaged": self.chunks_damaged,
            "first_time": iso_time(self.first_time),
            "last_time": iso_time(self.last_time),
            "damage_count": self.damage_count,
            "damage": self.damage,
            "scene_messages": self.scene_messages,
            "metadata": self.metadata,
        }


def file_state(summary: dict[str, Any]) -> str:
    """A file's state in words, from its :meth:`Recording.summary`: a live file is open,
    not damaged."""
    if summary["state"] == "open":
        return "open (still being written)"
    if summary["state"] == "unfinished":
        return f"unfinished (no footer: {summary['tail']}; its writer stopped before closing it)"
    return str(summary["state"])


def recording_files(paths: Path | str | Iterable[Path | str]) -> list[Path]:
    """The MCAP files at ``paths`` (files, or folders whose ``*.mcap`` are taken), each once,
    in name order (names start with their UTC time, so this is time order).

    Raises ``FileNotFoundError`` for a path that does not exist, and
    :class:`~plotgate.clients.mcap_reader.NotRegular` for one, given or in a folder, that is not a
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


SCENE_PREFIX, LOG_TOPIC, TRANSFORM_TOPIC = "/scene/", "/log", "/tf"
"""The scene channels ``plotgate view`` writes beside the exchanges' (those of
:mod:`plotgate.service.scenes`, which the clients do not import)."""
DIFF_TOPIC = "/replay/diff"
"""The Log of changed exchanges ``plotgate replay --out`` writes beside the replayed ones
(:mod:`plotgate.clients.replay_diff`): read as a scene channel."""

SCENE, TRANSFORM = ("", "scene"), ("", "transform")
"""What :func:`plotgate_channel` gives for a scene channel (``/scene/<operation>``,
``/log``, replay's ``/replay/diff``) and for the radar frame's transform (``/tf``): read
as scenes, not damage."""


def plotgate_channel(channel: Channel, schemas: set[int]) -> tuple[str, str] | str:
    """(operation, kind) of a plotgate channel (``schemas``: the schema ids declared so
    far), :data:`SCENE` for a scene channel of ``plotgate view``, or why the channel is
    not one."""
    if channel.topic.startswith(SCENE_PREFIX) or channel.topic in (LOG_TOPIC, DIFF_TOPIC):
        return SCENE
    if channel.topic == TRANSFORM_TOPIC:
        return TRANSFORM
    operation, _, kind = channel.topic.rpartition("/")
    name = f"channel {channel.id} ({channel.topic[:100]!r})"
    if not operation or kind not in ("request", "response"):
        return f"{name}, which is not a plotgate channel"
    if channel.message_encoding != "json":
        return f"{name}, which carries {channel.message_encoding[:40]!r} messages, not json"
    if channel.schema_id != 0 and channel.schema_id not in schemas:
        return f"{name}, whose schema {channel.schema_id} no Schema record declared"
    return operation, kind


OnRecord = Callable[[Seen, Envelope, bytes], None]
"""Called with each checked record instead of pairing it: its description, its envelope
and its bytes."""


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
    records by file and offset. Memory holds the requests waiting for an answer (their
    bytes), the keys, hashes and places of the last 100,000 answered exchanges, the
    (operation, id) of every original request read (to know a replay whose original was
    read), and one block or chunk of the file being read.
    """

    def __init__(
        self,
        paths: Path | str | Iterable[Path | str],
        filters: Filters | None = None,
        *,
        max_record_bytes: int = MAX_RECORD_BYTES,
        span: tuple[int, int] | None = None,
        on_record: OnRecord | None = None,
        digest: Callable[[bytes], Any] = hash,
    ) -> None:
        """``span`` reads only that range of each file (:class:`RecordReader`); ``on_record`` takes
        every checked record in file order, and then nothing is paired (the fleet replay
        pairs the records of many parts itself); ``digest`` tells records apart (the fleet's
        parts need one that is the same in every process, which ``hash`` is not)."""
        self.paths = recording_files(paths)
        self.span = span
        self.on_record = on_record
        self.digest = digest
        self.stopped_at = 0
        """Where reading the last file stopped (:attr:`RecordReader.stopped_at`)."""
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
        scan = RecordReader(rec.path, max_record_bytes=self.max_record_bytes, span=self.span)
        channels: dict[int, tuple[str, str] | str] = {}
        schemas: set[int] = set()
        runs: list[Messages] = []
        size = 0
        try:
            for item in scan.runs():
                if isinstance(item, Messages):
                    # checked together up to a few MiB (a chunk per exchange is common), but
                    # always before the next other record: a Channel record changes what
                    # the messages after it are
                    runs.append(item)
                    size += item.size
                    if size >= _CHECKED_TOGETHER:
                        yield from self._messages(rec, channels, runs)
                        runs, size = [], 0
                    continue
                if runs:
                    yield from self._messages(rec, channels, runs)
                    runs, size = [], 0
                if isinstance(item, Damage):
                    rec.add_damage(item)
                elif isinstance(item.record, Schema):
                    schemas.add(item.record.id)
                elif isinstance(item.record, Channel):
                    channels[item.record.id] = plotgate_channel(item.record, schemas)
                elif isinstance(item.record, Metadata):
                    rec.metadata[item.record.name] = dict(item.record.metadata)
            yield from self._messages(rec, channels, runs)
        except NotMcap as exc:
            rec.skipped = f"{exc}: skipped"
            self.skipped.append(rec.skipped)
        except OSError as exc:
            rec.error = f"{rec.path}: cannot be read ({exc.strerror or exc})"
        if rec.error is not None:
            self.unreadable.append(rec.error)
        rec.size, rec.complete, rec.tail = scan.size, scan.complete, scan.unfinished
        rec.chunks, rec.chunks_damaged = scan.chunks, scan.chunks_damaged
        self.stopped_at = scan.stopped_at
        if rec.complete or rec.skipped is not None or rec.error is not None:
            rec.state = "complete" if rec.complete else "unread"
        else:
            rec.state = "open" if writer_alive(rec.path) else "unfinished"

    def _messages(
        self, rec: Recording, channels: dict[int, tuple[str, str] | str], runs: list[Messages]
    ) -> Iterator[Exchange]:
        """Check runs of messages together, then pair them in file order: a request and its
        response read one after the other (as the recorder writes them) in one step."""
        records = [r for run in runs for r in run.records]
        if not records:
            return
        rec.messages += len(records)
        times = [r[3] for r in records]
        first, last = min(times), max(times)
        on: list[tuple[str, str] | str]
        """Each message's (operation, kind), or why it is not a plotgate one (its channel,
        or a time out of range)."""
        named = {
            channel_id: channel if type(channel) is tuple else f"a message on {channel}"
            for channel_id, channel in channels.items()
        }
        if check_time(first) is None and check_time(last) is None:  # every time is
            on = [named.get(r[1]) or _undeclared(r[1]) for r in records]
        else:
            on = [check_time(r[3]) or named.get(r[1]) or _undeclared(r[1]) for r in records]
            times = [t for t in times if check_time(t) is None]
        if times:
            first, last = min(times), max(times)
            rec.first_time = first if rec.first_time is None else min(rec.first_time, first)
            rec.last_time = last if rec.last_time is None else max(rec.last_time, last)
        checked = iter(
            check_messages(
                [
                    (c[1], c[0], r[5])
                    for c, r in zip(on, records, strict=True)
                    if type(c) is tuple and c not in (SCENE, TRANSFORM)
                ]
            )
        )
        read: list[tuple[Seen, tuple[Envelope, bytes]]] = []
        """Each message that checked out, described, with its envelope and bytes."""
        digest = self.digest
        ons = iter(on)
        for run in runs:
            chunk = run.chunk
            for where, _, _, t, _, data in run.records:
                channel = next(ons)
                verdict: Envelope | str
                if isinstance(channel, tuple):
                    if channel in (SCENE, TRANSFORM):
                        rec.scene_messages += channel == SCENE
                        continue
                    verdict = next(checked)
                    if isinstance(verdict, Envelope):
                        operation, kind = channel
                        offset, inner = (where, None) if chunk is None else (chunk, where)
                        # a response's envelope has no replay_of
                        seen = Seen(
                            kind,
                            operation,
                            verdict.request_id,
                            t,
                            digest(data),
                            offset,
                            inner,
                            verdict.replay_of,
                        )
                        read.append((seen, (verdict, data)))
                        continue
                else:
                    verdict = channel
                offset, inner = (where, None) if chunk is None else (chunk, where)
                rec.add_damage(Damage(offset, verdict, inner))
        yield from self._paired(str(rec.path), read)

    def _paired(
        self, file: str, read: list[tuple[Seen, tuple[Envelope, bytes]]]
    ) -> Iterator[Exchange]:
        """Pair the records read, in file order: the exchanges they complete that the
        filters take (or each record to ``on_record``, unpaired)."""
        if self.on_record is not None:
            for seen, (envelope, data) in read:
                self.on_record(seen, envelope, data)
            return
        take, take_pair = self._pairing.take, self._pairing.take_pair
        at, count = 0, len(read)
        while at < count:
            seen, payload = read[at]
            if at + 1 < count and seen.kind == "request":
                answer, answered = read[at + 1]
                if answer.kind == "response" and answer[1:3] == seen[1:3]:
                    for pair in take_pair(file, seen, answer, (payload, answered)):
                        yield exchange_of(pair)
                    at += 2
                    continue
            taken = take(None, file, seen, payload)
            if taken is not None:
                yield exchange_of(taken)
            at += 1

    @property
    def written_twice(self) -> int:
        """Records seen a second time, byte for byte."""
        return self._pairing.written_twice

    @property
    def conflict_count(self) -> int:
        return self._pairing.conflict_count

    @property
    def conflicts(self) -> list[str]:
        return self._pairing.conflicts


def _undeclared(channel_id: int) -> str:
    return f"a message on channel {channel_id}, which no Channel record declared"


def exchange_of(pair: Pair) -> Exchange:
    """The exchange of a pair whose records carry their payloads (envelope, bytes): its
    values are built from the bytes on first use."""
    request, response = pair.request, pair.response
    first = request or response
    assert first is not None
    envelope, request_bytes = request.payload if request is not None else (None, None)
    answer, response_bytes = response.payload if response is not None else (None, None)
    return Exchange(
        first.seen.operation,
        first.seen.request_id,
        None,
        None,
        first.seen.log_time,
        first.file,
        pair.original_read,
        request_bytes,
        response_bytes,
        replay_of=None if envelope is None else envelope.replay_of,
        status=None if answer is None else answer.status,
        duration_s=None if answer is None else answer.duration_s,
    )


def read_recording(path: Path | str) -> Recording:
    """Every exchange of one file, in the order the requests arrived (answers whose request
    is lost left out), with what was wrong with the file."""
    reader = Reader([path])
    exchanges = [ex for ex in reader if ex.request_bytes is not None]
    [rec] = reader.files
    rec.exchanges = sorted(exchanges, key=lambda ex: ex.log_time)
    return rec
