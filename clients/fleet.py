"""``plotgate replay --dask ADDRESS | --local-workers N``: one replay, read and run by many
workers, whose report and exit code are the serial replay's, byte for byte.

How the work is shared and put back together:

1. **Parts.** The files are cut into parts (:mod:`plotgate.clients.parts`): a large file
   whose summary indexes its chunks into ranges of whole chunks, any other file whole.
   Each part is a task: a worker reads it itself, so **the recording folder must be
   visible to every worker at the same path** (a shared filesystem); a worker that cannot
   open a file ends the run (:class:`WorkerCannotRead`, exit 2) naming the worker and the
   file.
2. **On the worker** (:func:`read_part`), each intact record is described (a
   :class:`~plotgate.clients.pairing.Seen`: kind, key, time, digest, place) and paired
   within the part by the serial rules (:class:`~plotgate.clients.pairing.Pairing`);
   every exchange completed within the part is replayed and judged at once (with the
   judgement it would get were its original read before it, for a replay). The part sends
   back its file statistics, where its reading stopped, every record's description, the
   judgements by (request, response) record, and the records it left unpaired, whole.
3. **On this process** (:func:`fleet_replay`), the descriptions of every part are paired
   again in the serial order (files in name order, parts in offset order): this finds the
   exchanges split across parts, files and rotations, the records written twice and the
   conflicts across parts, and the order in which the serial replay meets each exchange.
   Each exchange then takes its part's judgement when the part paired it the same way; the
   others (split across parts, or paired otherwise within a part than across all of them:
   a record whose twin is in an earlier part) are put together from the records the parts
   sent (a record a part paired is read again here) and judged on the cluster in a second
   round. The report is then tallied in the serial order.

A file whose parts do not meet (a part that skipped damage past its end) is read again
whole, by one worker. A worker killed mid-part changes nothing: Dask runs its task again
on another worker, and a task is a pure function of its part.

Set apart from the serial replay: ``--server`` and ``--out`` (the replay is in-process on
the workers, and one session file cannot be written by many); a file that vanishes or
stops being readable between the plan and a worker ends the run (exit 2) where the serial
replay would report it unreadable; a recording that declares a channel in its data
section otherwise than in its sound summary is read by chunk ranges with the summary's.
"""

import os
import socket
from array import array
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from plotgate.clients.live import writer_alive
from plotgate.clients.mcap_reader import open_regular
from plotgate.clients.messages import Envelope
from plotgate.clients.pairing import Pair, Pairing, Seen, Waiting, digest
from plotgate.clients.parts import PART_BYTES, Part, parts
from plotgate.clients.recordings import (
    MAX_LISTED,
    Exchange,
    Filters,
    Reader,
    Recording,
    exchange_of,
    recording_files,
)
from plotgate.clients.replay import (
    DEFAULT_TIMEOUT_S,
    Outcome,
    ReplayReport,
    in_process,
    judge,
    tally,
)
from plotgate.clients.tolerances import Rules

__all__ = [
    "BATCH",
    "UNCHANGED",
    "Described",
    "Judging",
    "PartRead",
    "WorkerCannotRead",
    "fleet_replay",
    "judge_all",
    "read_part",
]

BATCH = 64
"""Exchanges judged per task in the second round (those split across parts)."""


UNCHANGED = Outcome()


class Described:
    """Records described (:class:`~plotgate.clients.pairing.Seen`), in columns: a part
    sends about 50 bytes and its request id a record, not a Python object's 300."""

    def __init__(self) -> None:
        self.kinds = bytearray()
        self.operations: list[str] = []
        self.operation = array("H")
        self.request_ids: list[str] = []
        self.times = array("q")
        self.digests = bytearray()
        self.offsets = array("q")
        self.inners = array("q")
        self.replays_of: dict[int, str] = {}

    def append(self, seen: Seen) -> None:
        if seen.operation not in self.operations:
            self.operations.append(seen.operation)
        if seen.replay_of is not None:
            self.replays_of[len(self.times)] = seen.replay_of
        self.kinds.append(seen.kind == "response")
        self.operation.append(self.operations.index(seen.operation))
        self.request_ids.append(seen.request_id)
        self.times.append(seen.log_time)
        self.digests += seen.digest
        self.offsets.append(seen.offset)
        self.inners.append(-1 if seen.inner is None else seen.inner)

    def __iter__(self) -> Iterator[Seen]:
        for i, t in enumerate(self.times):
            yield Seen(
                "response" if self.kinds[i] else "request",
                self.operations[self.operation[i]],
                self.request_ids[i],
                t,
                bytes(self.digests[16 * i : 16 * i + 16]),
                self.offsets[i],
                None if self.inners[i] < 0 else self.inners[i],
                self.replays_of.get(i),
            )


class WorkerCannotRead(OSError):
    """A worker cannot open a recording this process can: the folder is not shared."""


@dataclass(frozen=True)
class Judging:
    """How every exchange is replayed and compared (the serial replay's arguments)."""

    rtol: float = 1e-9
    atol: float = 1e-12
    timeout: float | None = DEFAULT_TIMEOUT_S
    limits: Mapping[str, Mapping[str, int]] | None = None
    filters: Filters = field(default_factory=Filters)
    rules: Rules | None = None
    """Per-field tolerances over ``rtol`` and ``atol``."""
    cases: bool = False
    """Keep every compared exchange's name in the report (JUnit)."""


@dataclass
class PartRead:
    """What a worker sends back for one part."""

    part: Part
    recording: Recording
    unreadable: list[str]
    skipped: list[str]
    stopped_at: int
    records: "Described" = field(default_factory=lambda: Described())
    partner: "array[int]" = field(default_factory=lambda: array("q"))
    """By record index: the response a request was paired with in the part (-1: none)."""
    judged: dict[int, tuple[Outcome, Outcome]] = field(default_factory=dict)
    """By request record index, when either is not :data:`UNCHANGED`: the judgement, and
    the one it gets were its original read before it."""
    unpaired: dict[int, tuple[Envelope, bytes]] = field(default_factory=dict)
    """Records left unpaired in the part, by index: the envelope and its bytes."""


def read_part(part: Part, judging: Judging) -> PartRead:
    """Read one part on a worker, pair and judge what it can, describe the rest."""
    try:
        os.close(open_regular(part.path))
    except OSError as exc:
        raise WorkerCannotRead(
            exc.errno,
            f"the worker on {socket.gethostname()} cannot read it ({exc.strerror or exc}); "
            "a fleet replay needs the recording folder at the same path on every worker",
            part.path,
        ) from None
    return _read(part, judging)


def _read(part: Part, judging: Judging) -> PartRead:
    run = _Lazy(judging)
    pairing = Pairing(judging.filters)
    records = Described()
    partner: array[int] = array("q")
    judged: dict[int, tuple[Outcome, Outcome]] = {}

    def take(seen: Seen, envelope: Envelope, data: bytes) -> None:
        records.append(seen)
        partner.append(-1)
        pair = pairing.take(len(partner) - 1, part.path, seen, (envelope, data))
        if pair is not None:
            assert pair.request is not None and pair.response is not None
            partner[pair.request.ref] = pair.response.ref
            both = _both(exchange_of(pair), run, judging)
            if both != (UNCHANGED, UNCHANGED):
                judged[pair.request.ref] = both

    reader = Reader([part.path], judging.filters, span=part.span, on_record=take, digest=digest)
    for _ in reader:
        pass  # every record goes to take
    unpaired = {}
    for pair in pairing.leftovers():
        for w in (pair.request, pair.response):
            if w is not None:
                unpaired[w.ref] = w.payload
    [recording] = reader.files
    return PartRead(
        part,
        recording,
        list(reader.unreadable),
        list(reader.skipped),
        reader.stopped_at,
        records,
        partner,
        judged,
        unpaired,
    )


def _both(
    exchange: Exchange, run: Callable[..., Any], judging: Judging
) -> tuple[Outcome, Outcome]:
    outcome = judge(exchange, run, judging.rtol, judging.atol, rules=judging.rules)
    if exchange.original_read or exchange.replay_of is None:
        return outcome, outcome
    # were its original read before it, it is set aside without running
    return outcome, judge(
        _original_read(exchange), run, judging.rtol, judging.atol, rules=judging.rules
    )


def _original_read(exchange: Exchange) -> Exchange:
    """The same exchange, its original read before it."""
    return Exchange(
        exchange.operation,
        exchange.request_id,
        None,
        None,
        exchange.log_time,
        exchange.file,
        True,
        exchange.request_bytes,
        exchange.response_bytes,
        replay_of=exchange.replay_of,
        status=exchange.status,
        duration_s=exchange.duration_s,
    )


def judge_all(exchanges: list[Exchange], judging: Judging) -> list[Outcome]:
    """Judge exchanges on a worker (the second round)."""
    run = in_process(judging.timeout, judging.limits)
    return [judge(ex, run, judging.rtol, judging.atol, rules=judging.rules) for ex in exchanges]


class _Lazy:
    """The in-process runner, made on first use: a part without an exchange to run (or a
    file read here that cannot be) imports no operation."""

    def __init__(self, judging: Judging) -> None:
        self.judging = judging
        self.run: Callable[..., Any] | None = None

    def __call__(self, exchange: Exchange, rid: str) -> Any:
        if self.run is None:
            self.run = in_process(self.judging.timeout, self.judging.limits)
        return self.run(exchange, rid)


def _never(exchange: Exchange, rid: str) -> Any:
    raise AssertionError("an exchange set aside is never run")


Mapper = Callable[[Callable[..., Any], Iterable[Any]], Iterable[Any]]


def fleet_replay(
    paths: Path | str | Iterable[Path | str],
    judging: Judging | None = None,
    *,
    address: str | None = None,
    local_workers: int | None = None,
    progress: bool = False,
    part_bytes: int = PART_BYTES,
) -> ReplayReport:
    """Replay every exchange in the files at ``paths`` on the Dask scheduler at
    ``address`` or on ``local_workers`` local worker processes (neither: in this process,
    part by part), and report exactly what :func:`plotgate.clients.replay.replay` reports.

    Raises :class:`~plotgate.service.cluster.ClusterUnavailable` when no cluster can be
    had, :class:`WorkerCannotRead` when a worker cannot open a file, and what
    :func:`~plotgate.clients.recordings.recording_files` raises for the paths.
    """
    from plotgate.service.cluster import cluster, mapper

    judging = judging or Judging()
    planned = parts(recording_files(paths), part_bytes)
    with cluster(address, local_workers, progress):
        spread: Mapper = mapper() or _in_order
        reads = _reads(spread, planned, judging)
        return _Merge(judging, spread).report(reads)


def _in_order(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
    return [function(item) for item in items]


def _reads(spread: Mapper, planned: list[Part], judging: Judging) -> list[list[PartRead]]:
    """Each file's parts read (a file whose parts do not meet, read again whole)."""
    remote = iter(spread(partial(read_part, judging=judging), [p for p in planned if not p.local]))
    by_file: dict[str, list[PartRead]] = {}
    for part in planned:
        read = _read(part, judging) if part.local else next(remote)
        by_file.setdefault(part.path, []).append(read)
    kept = {path: _met(reads) for path, reads in by_file.items()}
    again = [Part(path) for path, reads in kept.items() if reads is None]
    for read in spread(partial(read_part, judging=judging), again):
        kept[read.part.path] = [read]
    return [reads for reads in kept.values() if reads is not None]


def _met(reads: list[PartRead]) -> list[PartRead] | None:
    """The parts as the serial read would have read them: up to the first that could not
    be read (reading stops there); None when one stopped elsewhere than where the next
    begins."""
    for i, read in enumerate(reads[:-1]):
        if read.recording.error is not None:
            return reads[: i + 1]
        if read.stopped_at != reads[i + 1].part.start:
            return None
    return reads


def _recording(reads: list[PartRead]) -> Recording:
    """One file's statistics from its parts'."""
    rec = Recording(reads[0].recording.path)
    for r in (read.recording for read in reads):
        rec.messages += r.messages
        for t in (r.first_time, r.last_time):
            if t is not None:
                rec.first_time = t if rec.first_time is None else min(rec.first_time, t)
                rec.last_time = t if rec.last_time is None else max(rec.last_time, t)
        rec.damage += r.damage[: MAX_LISTED - len(rec.damage)]
        rec.damage_count += r.damage_count
        rec.metadata.update(r.metadata)
        rec.chunks += r.chunks
        rec.chunks_damaged += r.chunks_damaged
        rec.error = rec.error or r.error
        rec.skipped = rec.skipped or r.skipped
    last = reads[-1].recording  # the file's tail is the last part's
    rec.size, rec.complete, rec.tail, rec.state = last.size, last.complete, last.tail, last.state
    if rec.state in ("open", "unfinished"):
        # whether its writer still writes it is asked here, as the serial replay asks it:
        # a worker on another host cannot see this host's writer
        rec.state = "open" if writer_alive(rec.path) else "unfinished"
    return rec


class _Merge:
    """The parts' records paired in the serial order, each exchange judged once, tallied."""

    def __init__(self, judging: Judging, spread: Mapper) -> None:
        self.judging = judging
        self.spread = spread
        self.pairing = Pairing(judging.filters)
        self.parts: list[PartRead] = []
        self.slots: list[list[_Name] | dict[str, int] | tuple[Exchange, Outcome | Pair]] = []
        """In the serial order: runs of unchanged exchanges (what names each when the
        report keeps every name, else their count per operation), and the others (with
        their judgement, or the pair still to be judged)."""

    def report(self, files: list[list[PartRead]]) -> ReplayReport:
        report = ReplayReport(cases=[] if self.judging.cases else None)
        for reads in files:
            rec = _recording(reads)
            report.files.append(rec.summary())
            for read in reads:
                report.unreadable += read.unreadable
                report.skipped += read.skipped
                self._pair(read)
            report.recordings += rec.error is None and rec.skipped is None
        for pair in self.pairing.leftovers():
            self.slots.append((_named(pair), judge(_stub(pair), _never, 0.0, 0.0)))
        outcomes = iter(self._second_round())
        for slot in self.slots:
            if isinstance(slot, list):
                for operation, rid, log_time in slot:
                    tally(report, Exchange(operation, rid, None, None, log_time), UNCHANGED)
                continue
            if isinstance(slot, dict):
                for operation, count in slot.items():
                    for _ in range(count):
                        tally(report, Exchange(operation, ""), UNCHANGED)
                continue
            exchange, outcome = slot
            tally(report, exchange, outcome if isinstance(outcome, Outcome) else next(outcomes))
        report.written_twice = self.pairing.written_twice
        report.conflict_count = self.pairing.conflict_count
        report.conflicts = list(self.pairing.conflicts)
        return report

    def _pair(self, read: PartRead) -> None:
        n = len(self.parts)
        self.parts.append(read)
        for i, seen in enumerate(read.records):
            pair = self.pairing.take((n, i), read.part.path, seen)
            if pair is None:
                continue
            outcome = self._judged(pair)
            if outcome == UNCHANGED:
                self._unchanged(pair)
            else:
                self.slots.append((_named(pair), outcome or pair))
        # paired: only the records the part left unpaired are kept
        read.records, read.partner, read.judged = Described(), array("q"), {}

    def _unchanged(self, pair: Pair) -> None:
        """Count an unchanged exchange into the run it ends."""
        assert pair.request is not None
        seen = pair.request.seen
        last = self.slots[-1] if self.slots else None
        if self.judging.cases:
            if not isinstance(last, list):
                last = []
                self.slots.append(last)
            last.append((seen.operation, seen.request_id, seen.log_time))
            return
        if not isinstance(last, dict):
            last = {}
            self.slots.append(last)
        last[seen.operation] = last.get(seen.operation, 0) + 1

    def _judged(self, pair: Pair) -> Outcome | None:
        """The part's judgement, when the part paired these two records itself."""
        assert pair.request is not None and pair.response is not None
        (n, i), (m, j) = pair.request.ref, pair.response.ref
        if n != m or self.parts[n].partner[i] != j:
            return None
        outcome, if_original_read = self.parts[n].judged.get(i, (UNCHANGED, UNCHANGED))
        return if_original_read if pair.original_read else outcome

    def _second_round(self) -> list[Outcome]:
        """Judge, on the cluster, the exchanges no part could judge alone."""
        pairs = [s[1] for s in self.slots if isinstance(s, tuple) and isinstance(s[1], Pair)]
        if not pairs:
            return []
        self._fill([w for p in pairs for w in (p.request, p.response) if w is not None])
        exchanges = [exchange_of(p) for p in pairs]
        batches = [exchanges[i : i + BATCH] for i in range(0, len(exchanges), BATCH)]
        judged = self.spread(partial(judge_all, judging=self.judging), batches)
        return [outcome for batch in judged for outcome in batch]

    def _fill(self, records: list[Waiting]) -> None:
        """Give each record its payload: the one its part sent, or read again here."""
        wanted: dict[int, set[int]] = {}
        for w in records:
            n, i = w.ref
            w.payload = self.parts[n].unpaired.get(i)
            if w.payload is None:
                wanted.setdefault(n, set()).add(i)
        found = {
            n: _payloads(self.parts[n].part, indices, self.judging)
            for n, indices in wanted.items()
        }
        for w in records:
            n, i = w.ref
            if w.payload is None:
                w.payload = found[n][i]


def _payloads(
    part: Part, indices: set[int], judging: Judging
) -> dict[int, tuple[Envelope, bytes]]:
    """The records of ``part`` at these indices (as :func:`read_part` counted them)."""
    found: dict[int, tuple[Envelope, bytes]] = {}
    count = 0

    def take(seen: Seen, envelope: Envelope, data: bytes) -> None:
        nonlocal count
        if count in indices:
            found[count] = (envelope, data)
        count += 1

    for _ in Reader([part.path], judging.filters, span=part.span, on_record=take):
        pass
    return found


_Name = tuple[str, str, int]
"""An unchanged exchange's operation, request id and time: all a report names it by."""


def _named(pair: Pair) -> Exchange:
    """An exchange with what a report names it by (its records not needed)."""
    first = pair.request or pair.response
    assert first is not None
    return Exchange(
        first.seen.operation, first.seen.request_id, None, None, first.seen.log_time, first.file
    )


def _stub(pair: Pair) -> Exchange:
    """A leftover with a stand-in for the record it has: its judgement (never answered,
    or its request lost) needs no more."""
    first = pair.request or pair.response
    assert first is not None
    return Exchange(
        first.seen.operation,
        first.seen.request_id,
        {} if pair.request else None,
        {} if pair.response else None,
        first.seen.log_time,
        first.file,
    )
