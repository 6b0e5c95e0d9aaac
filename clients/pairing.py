"""Requests and responses paired across files: the rules of
:class:`plotgate.clients.recordings.Reader`, which pairs with this, over records described
rather than parsed, so that the records of many parts, read by many workers, pair exactly
as one serial read of every file does (:mod:`plotgate.clients.fleet`).

A record is a :class:`Seen` (its kind, key, time, digest and place) and a reference the
caller chooses (a record's index in its part); it may carry a payload (its parsed record
and bytes) that comes back with its pair. A response pairs with the earliest waiting
request of its key; one that comes first waits for its request; a
record with the key and time of one read before is written twice (the same digest) or a
conflict (another digest; the first read is kept); the records of the last
:data:`RECENT` answered exchanges are remembered for that; a
replay's original was read when its (operation, request id) came as an original request
before the replay was paired; requests never answered and answers without a request come
last, in the order their keys first waited.
"""

import hashlib
from collections import OrderedDict, deque
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any, NamedTuple

from plotgate.clients.mcap_reader import location

__all__ = [
    "MAX_LISTED",
    "RECENT",
    "Filters",
    "Pair",
    "Pairing",
    "Seen",
    "Waiting",
    "digest",
    "iso_time",
]

MAX_LISTED = 100
"""Damage listed per file, conflicts per reading; the rest is counted."""
RECENT = 200_000
"""Records of answered exchanges remembered to recognise one written twice."""


def iso_time(ns: int | None) -> str | None:
    """Nanoseconds since the epoch as an ISO 8601 UTC time (microseconds)."""
    if ns is None:
        return None
    return (
        datetime.fromtimestamp(ns / 1e9, UTC)
        .isoformat(timespec="microseconds")
        .replace("+00:00", "Z")
    )


@dataclass(frozen=True)
class Filters:
    """Which exchanges to take: by operation and by request time (``since`` inclusive,
    ``until`` exclusive, ns since the epoch); empty or None takes all."""

    operations: frozenset[str] = frozenset()
    since: int | None = None
    until: int | None = None

    def admit(self, operation: str, log_time: int) -> bool:
        return (
            (not self.operations or operation in self.operations)
            and (self.since is None or log_time >= self.since)
            and (self.until is None or log_time < self.until)
        )


def digest(data: bytes) -> bytes:
    """What tells two records apart in every process alike: the same digest is the same
    bytes. The serial :class:`~plotgate.clients.recordings.Reader` uses Python's keyed
    ``hash`` instead (faster, but drawn anew in each process); the fleet's parts, paired
    again in another process, need this one."""
    return hashlib.blake2b(data, digest_size=16).digest()


class Seen(NamedTuple):
    """One intact record, described."""

    kind: str
    operation: str
    request_id: str
    log_time: int
    digest: Any
    """Equal for equal bytes (``hash`` in one process, :func:`digest` across processes)."""
    offset: int
    inner: int | None
    replay_of: str | None


@dataclass(slots=True)
class Waiting:
    """A record read, with the caller's reference, its file and its payload."""

    ref: Any
    file: str
    seen: Seen
    kept: bool
    """A response, or a request the filters take."""
    payload: Any = None


class Pair(NamedTuple):
    """A request (None: its record was lost) and its response (None: never answered)."""

    request: Waiting | None
    response: Waiting | None
    original_read: bool = False


_Mark = tuple[str, str, str, int]
_Place = tuple[str, Seen]
"""A record remembered to recognise its twin: its file and description (a plain tuple: one
is made for every record read, where a :class:`Waiting` costs several times as much)."""


def _named(place: _Place) -> str:
    file, seen = place
    return f"{file} at {location(seen.offset, seen.inner)}"


class Pairing:
    """Take records in the serial order and get the exchanges they complete."""

    def __init__(self, filters: Filters | None = None) -> None:
        self.filters = filters or Filters()
        self.written_twice = 0
        self.conflict_count = 0
        self.conflicts: list[str] = []
        self._requests: dict[tuple[str, str], deque[Waiting]] = {}
        self._responses: dict[tuple[str, str], deque[Waiting]] = {}
        self._seen: dict[_Mark, _Place] = {}
        self._recent: OrderedDict[_Mark, _Place] = OrderedDict()
        self._originals: set[tuple[str, str]] = set()

    def take(self, ref: Any, file: str, seen: Seen, payload: Any = None) -> Pair | None:
        """The exchange this record completes, if it completes one the filters take.

        Called once for every record of a recording: what it makes is kept to the least
        (a :class:`Waiting` for a record that waits, two plain tuples per exchange)."""
        kind, operation, rid, t = seen[:4]
        key = (operation, rid)
        mark = (kind, operation, rid, t)
        first = self._seen.get(mark) or self._recent.get(mark)
        if first is not None:
            self._again(mark, first, (file, seen))
            return None
        if kind == "request":
            kept = self.filters.admit(operation, t)
            current = Waiting(ref, file, seen, kept, payload if kept else None)
            if seen.replay_of is None:
                self._originals.add(key)
            mine, other = self._requests, self._responses
        else:
            current = Waiting(ref, file, seen, True, payload)
            mine, other = self._responses, self._requests
        counterparts = other.get(key)
        if not counterparts:
            mine.setdefault(key, deque()).append(current)
            self._seen[mark] = (file, seen)
            return None
        waiting = counterparts.popleft()
        if not counterparts:
            del other[key]
        other_time = waiting.seen.log_time
        recent = self._recent
        if kind == "request":
            request, response = current, waiting
            self._seen.pop(("response", operation, rid, other_time), None)
            recent[mark] = (file, seen)  # its place and digest, not its payload
            recent[("response", operation, rid, other_time)] = (waiting.file, waiting.seen)
        else:
            request, response = waiting, current
            self._seen.pop(("request", operation, rid, other_time), None)
            recent[("request", operation, rid, other_time)] = (waiting.file, waiting.seen)
            recent[mark] = (file, seen)
        while len(recent) > RECENT:
            recent.popitem(last=False)
        if not request.kept:
            return None
        return Pair(request, response, self._original_read(request))

    def take_pair(
        self, file: str, request: Seen, response: Seen, payloads: tuple[Any, Any]
    ) -> list[Pair]:
        """What :meth:`take` gives for a request and then its response (the same operation
        and request id), read one after the other, as the recorder writes them: in one step
        when neither record was read before and no record of their key waits (a Waiting is
        made only for an exchange the filters take); by two calls of :meth:`take` otherwise.
        """
        operation, rid = request.operation, request.request_id
        key = (operation, rid)
        asked = ("request", operation, rid, request.log_time)
        answered = ("response", operation, rid, response.log_time)
        seen, recent = self._seen, self._recent
        if (
            key in self._requests
            or key in self._responses
            or asked in seen
            or asked in recent
            or answered in seen
            or answered in recent
        ):
            pairs = (
                self.take(None, file, request, payloads[0]),
                self.take(None, file, response, payloads[1]),
            )
            return [pair for pair in pairs if pair is not None]
        if request.replay_of is None:
            self._originals.add(key)
        recent[asked] = (file, request)
        recent[answered] = (file, response)
        while len(recent) > RECENT:
            recent.popitem(last=False)
        if not self.filters.admit(operation, request.log_time):
            return []
        waiting = Waiting(None, file, request, True, payloads[0])
        return [
            Pair(
                waiting,
                Waiting(None, file, response, True, payloads[1]),
                self._original_read(waiting),
            )
        ]

    def leftovers(self) -> Iterator[Pair]:
        """Requests never answered, then answers whose request is lost (those the filters
        take), and forget them."""
        for queue in self._requests.values():
            for request in queue:
                if request.kept:
                    yield Pair(request, None, self._original_read(request))
        for queue in self._responses.values():
            for response in queue:
                if self.filters.admit(response.seen.operation, response.seen.log_time):
                    yield Pair(None, response)
        self._requests.clear()
        self._responses.clear()
        self._seen.clear()

    def _original_read(self, request: Waiting) -> bool:
        replay_of = request.seen.replay_of
        return replay_of is not None and (request.seen.operation, replay_of) in self._originals

    def _again(self, mark: _Mark, first: _Place, again: _Place) -> None:
        if again[1].digest == first[1].digest:
            self.written_twice += 1
            return
        self.conflict_count += 1
        if len(self.conflicts) < MAX_LISTED:
            kind, operation, rid, t = mark
            self.conflicts.append(
                f"{operation} {rid} at {iso_time(t)}: the {kind} record {_named(again)} "
                f"differs from the one at {_named(first)} (that one kept)"
            )
