"""Replay recorded sessions against this build (or a live server) and report what changed.

Every recorded exchange is read once (:class:`plotgate.clients.recordings.Reader`: requests and
responses paired across all the files given, damage reported and skipped) and its request
run again: in-process through the operation registry by default, or over HTTP against a
live server. Answers are compared field by field (:mod:`plotgate.clients.compare`: in one
pass, lists of numbers as arrays), floats with ``numpy.isclose(rtol, atol)``; a recorded
failure must fail the same way again (same status, problem type and offending fields).

The exit code is a contract (docs/architecture.md, :meth:`ReplayReport.exit_code`):

- 0: every exchange compared was unchanged (and at least one was compared);
- 1: something changed, a recorded failure that now succeeds or fails differently
  included, or an exchange did not answer within ``timeout``; or the recording
  contradicts itself: two records of one exchange (same operation, request id, kind and
  time) with different bytes, a conflict;
- 2: the run could not do what was asked: nothing comparable (unless ``allow_empty``), a
  file that cannot be read, no recording among the files given, a path that is not a
  regular file, a usage or connection error. 2 wins over 1.

A file that is empty or not MCAP at all (no MCAP magic) is skipped with a note: it
decides no exit code when other files are recordings (a full disk used to leave empty
files among sound ones). A conflict is counted apart from the tally: the first record
read is the one replayed and compared, the other is named with it (file and offset) in
``conflicts``; it exits 1 because which of the two the service answered cannot be told,
so the session cannot be called unchanged.

Not every exchange can be compared; these are counted apart, each with its reason, and do
not change the exit code by themselves: a request never answered (the server stopped
first), an answer whose request record was lost to damage, a body that timed out (408:
the body never arrived whole, so it cannot be sent again), a request its client gave up
(499: its work was cancelled, so nothing was answered to compare with), a replay whose
original was read before it (a folder replayed into itself would otherwise grow and
compare twice), and, in process, a request over this replay's work caps (the server's:
the defaults with ``PLOTGATE_LIMITS`` over them; ``no_limits`` runs it) whose recorded
answer is not that same cap's refusal: a recording made under higher caps answered it,
and a 422 here would read as a change. A recorded refusal by the same cap is refused
again and compared. The tally adds up: exchanges = compared + not compared, compared =
unchanged + changed, each exchange counted once.

A replay over HTTP sends each request under a new request id with header
``X-Plotgate-Replay-Of: <original id>``, so a server recording into the same folder records
it as a replay of its original, never under the original's id.
"""

import contextlib
import ctypes
import errno
import importlib
import json
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from plotgate.clients.compare import FIELDS_PER_EXCHANGE, diff
from plotgate.clients.latency import Durations
from plotgate.clients.messages import body_bytes
from plotgate.clients.recordings import (
    MAX_LISTED,
    Exchange,
    Filters,
    Reader,
    file_state,
    iso_time,
)
from plotgate.clients.replay_diff import DIFF_TOPIC, NO_SDK, diff_log, log_channel
from plotgate.clients.tolerances import DEFAULT, Rules
from plotgate.files import check_target, replace_into, temporary_beside
from plotgate.service.table import ENDPOINTS

_VALUES = msgspec.json.Decoder()

if TYPE_CHECKING:
    import httpx

    from plotgate.service.registry import Operation
    from plotgate.service.registry import Outcome as Answered

__all__ = [
    "Answer",
    "Change",
    "InProcess",
    "Observer",
    "Outcome",
    "ReplayReport",
    "diff",
    "in_process",
    "judge",
    "over_http",
    "replay",
    "sent_body",
    "tally",
]

MAX_CHANGES = 1000
"""Changes kept for the report (every changed exchange is counted)."""
DEFAULT_TIMEOUT_S = 60.0

NEVER_ANSWERED = "never answered (the server stopped first)"
REQUEST_LOST = "answer whose request record was lost to damage"
BODY_TIMEOUT = "body timed out (408): it never arrived whole, so it cannot be sent again"
REPLAYED_ORIGINAL = "replay of an exchange read before it"
REFUSED_FOR_THE_SERVER = (
    "refused for the server's state (503: recording, cluster, worker or shutdown), not for "
    "its input"
)
FAULT_NOW = "answered 503 by the replaying server (a fault, not an answer), not compared"
CLIENT_GONE = "given up by its client (499): the work was cancelled, no answer to compare"
OVER_CAPS = "over this replay's work caps (the defaults and PLOTGATE_LIMITS; --no-limits runs it)"


@dataclass(frozen=True)
class Answer:
    """What a replayed request got: a status and its JSON, or (``status`` None) no answer,
    ``note`` saying why; ``skip`` says why it was not run at all."""

    status: int | None
    content: Any = None
    note: str | None = None
    skip: str | None = None


Runner = Callable[[Exchange, str], Answer]
"""Runs an exchange's request again under a new request id."""
Observer = Callable[[str, Any, Any], None]
"""Called with an operation and the recorded and replayed answers (results, or what must
stay the same of a failure) of every exchange compared: ``--calibrate`` learns from them."""


@dataclass
class Change:
    """One field of one exchange whose new answer differs from the recorded one."""

    file: str
    operation: str
    request_id: str
    time: str
    """When the request arrived (ISO 8601 UTC): ids may be reused."""
    field: str
    recorded: Any
    replayed: Any
    rule: str = DEFAULT
    """What judged the field: a tolerance rule's name, or the global tolerances."""


@dataclass
class ReplayReport:
    """The tally, every change found (the first :data:`MAX_CHANGES`) and each file read."""

    files: list[dict[str, Any]] = field(default_factory=list)
    exchanges: int = 0
    compared: int = 0
    unchanged: int = 0
    changed: int = 0
    not_compared: dict[str, int] = field(default_factory=dict)
    written_twice: int = 0
    """Records the recorder wrote twice (after losing a file), read once."""
    conflict_count: int = 0
    """Records with the key and time of one read before but other bytes."""
    conflicts: list[str] = field(default_factory=list)
    """The first :data:`MAX_LISTED` conflicts, each naming both records."""
    unreadable: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    """Files that are not recordings (empty, or no MCAP magic), passed over."""
    recordings: int = 0
    """Files read that are recordings."""
    changes: list[Change] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    """Exceptions raised in process (each answered as the server's 500)."""
    operations: dict[str, dict[str, int]] = field(default_factory=dict)
    """Per operation: exchanges ``compared`` and ``changed``."""
    cases: list[tuple[str, str, int, bool]] | None = None
    """Every exchange compared, in order (operation, request id, time in ns, changed):
    kept only when asked (``replay(cases=True)``; JUnit needs one line per exchange),
    since it grows with the recording."""
    latency: dict[str, dict[str, float]] = field(default_factory=dict)
    """Per operation, recorded and replayed p50 and p99 durations (s): over HTTP only,
    where the replayed durations are a server's as the recorded ones are."""
    pacing: dict[str, Any] | None = None
    """With ``--pace``: the speed, exchanges sent, how many behind their time."""
    pacing_text: str | None = None

    @property
    def ok(self) -> bool:
        return self.changed == 0 and self.conflict_count == 0

    def exit_code(self, allow_empty: bool = False) -> int:
        """0, 1 or 2 as the module's contract says."""
        if self.unreadable or (self.skipped and not self.recordings):
            return 2
        if self.changed or self.conflict_count:
            return 1
        return 0 if self.compared or allow_empty else 2

    def to_json(self) -> dict[str, Any]:
        return {
            "exchanges": self.exchanges,
            "compared": self.compared,
            "unchanged": self.unchanged,
            "changed": self.changed,
            "not_compared": self.not_compared,
            "written_twice": self.written_twice,
            "conflict_count": self.conflict_count,
            "conflicts": self.conflicts,
            "ok": self.ok,
            "unreadable": self.unreadable,
            "skipped": self.skipped,
            "recordings": self.recordings,
            "files": self.files,
            "changes": [vars(c) for c in self.changes],
            "notes": self.notes,
            "operations": dict(sorted(self.operations.items())),
            "latency": self.latency,
            "pacing": self.pacing,
        }

    def text(self) -> str:
        lines = [_file_line(f) for f in self.files]  # unreadable and skipped ones included
        lines += [f"CONFLICT {c}" for c in self.conflicts]
        if self.conflict_count > len(self.conflicts):
            lines.append(f"... and {self.conflict_count - len(self.conflicts)} more conflicts")
        for c in self.changes:
            lines.append(
                f"CHANGED {c.operation} {c.request_id} {c.field}: "
                f"recorded {_short(c.recorded)}, replayed {_short(c.replayed)}"
                + ("" if c.rule == DEFAULT else f" (rule {c.rule!r})")
            )
        if self.changed > len({(c.file, c.request_id, c.time) for c in self.changes}):
            lines.append(f"... more changes than the {MAX_CHANGES} listed")
        lines += [f"note: {n}" for n in self.notes]
        if self.pacing_text:
            lines.append(self.pacing_text)
        for operation, row in sorted(self.latency.items()):
            lines.append(
                f"latency {operation}: p50 {row['recorded_p50']:.4g} s recorded, "
                f"{row['replayed_p50']:.4g} s replayed; p99 {row['recorded_p99']:.4g} s, "
                f"{row['replayed_p99']:.4g} s"
            )
        skipped = sum(self.not_compared.values())
        lines.append(
            f"{self.exchanges} exchanges: {self.compared} compared, {skipped} not compared"
        )
        lines += [f"  not compared: {n} {why}" for why, n in sorted(self.not_compared.items())]
        if self.written_twice:
            lines.append(
                f"  {self.written_twice} records written twice by the recorder, read once"
            )
        if self.conflict_count:
            lines.append(
                f"  {self.conflict_count} conflicting records (exit 1): the first read of "
                "each compared"
            )
        lines.append(
            f"{self.compared} compared: {self.unchanged} unchanged, {self.changed} changed"
        )
        return "\n".join(lines)


def _file_line(f: dict[str, Any]) -> str:
    if f["error"] or f["skipped"]:
        return str(f["error"] or f["skipped"])
    span = f"{f['first_time']} to {f['last_time']}" if f["first_time"] else "no messages"
    state = file_state(f) if f["complete"] else f"{file_state(f)}, {f['messages']} messages read"
    text = f"{f['path']}: {state}, {span}"
    if f["damage_count"]:
        text += f"; {f['damage_count']} damaged records skipped, the first at " + f["damage"][0]
    return text


def _short(value: Any) -> str:
    try:
        text = json.dumps(value)
    except ValueError:
        text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _failure(status: int, problem: Any) -> dict[str, Any]:
    """What must stay the same when a request fails again."""
    problem = problem if isinstance(problem, dict) else {}
    errors = problem.get("errors")
    fields = (
        [e.get("field") for e in errors if isinstance(e, dict)] if isinstance(errors, list) else []
    )
    return {"status": status, "type": problem.get("type"), "fields": sorted(map(str, fields))}


class _Overtime(BaseException):
    """Raised when an in-process exchange passes its deadline (a BaseException, so no
    ``except Exception`` in an operation swallows it)."""


@contextlib.contextmanager
def _thread_alarm(seconds: float) -> Iterator[None]:
    """:class:`_Overtime` in this thread after ``seconds``, from the one watchdog thread
    (a timer thread per exchange cost more than many exchanges). Raised between two
    bytecodes, so a long call into compiled code ends first. Once the block is left the
    deadline is disarmed; an exception set but not raised yet is cleared and raised here,
    so it can never surface after the block."""
    target = threading.get_ident()
    _WATCHDOG.arm(target, seconds)
    try:
        yield
    finally:
        if _WATCHDOG.disarm(target):
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target), None)
            raise _Overtime


class _Watchdog:
    """Deadlines of threads (by id), each rung once by one daemon thread: an asynchronous
    :class:`_Overtime` set on the thread."""

    def __init__(self) -> None:
        self._changed = threading.Condition()
        self._due: dict[int, float] = {}
        self._rang: set[int] = set()
        self._thread: threading.Thread | None = None

    def arm(self, target: int, seconds: float) -> None:
        with self._changed:
            self._rang.discard(target)  # rung while its last block was being left
            self._due[target] = time.monotonic() + seconds
            if self._thread is None:
                self._thread = threading.Thread(target=self._watch, name="replay-deadlines")
                self._thread.daemon = True
                self._thread.start()
            self._changed.notify()

    def disarm(self, target: int) -> bool:
        """Whether the deadline rang."""
        with self._changed:
            self._due.pop(target, None)
            rang = target in self._rang
            self._rang.discard(target)
            return rang

    def _watch(self) -> None:
        with self._changed:
            while True:
                now = time.monotonic()
                for target, due in list(self._due.items()):
                    if due <= now:
                        del self._due[target]
                        self._rang.add(target)
                        ctypes.pythonapi.PyThreadState_SetAsyncExc(
                            ctypes.c_ulong(target), ctypes.py_object(_Overtime)
                        )
                wait = min(self._due.values(), default=now + 3600.0) - now
                self._changed.wait(max(wait, 0.0))


_WATCHDOG = _Watchdog()


LONGEST_DEADLINE_S = 1e8
"""In-process deadlines are cut to about three years: the alarm's timer refuses what the
platform's time_t cannot hold (1e12 s here), and an exchange would then be reported as a
500 of the operation."""


def _ring(signum: int, frame: object) -> None:
    raise _Overtime


class InProcess:
    """Runs exchanges through this build's registry, as the server would: an exception in
    an operation becomes the server's 500 problem (its text kept as a note), an exchange
    over ``timeout`` seconds is stopped, one over ``limits`` (the server's
    ``PLOTGATE_LIMITS`` caps) is not run.

    What does not change from one exchange to the next is paid once. The registry is
    imported when the runner is made. In the main thread the deadline is a real-time alarm:
    inside ``with`` the runner installs its handler once for the whole run and each
    exchange only arms and disarms the timer; called outside ``with``, each exchange
    installs and removes the handler itself. In another thread (a Dask worker's task), where
    no signal is delivered, an exception the one watchdog thread sets on it
    (:func:`_thread_alarm`). The
    request body sent is the recorded one's bytes (:func:`sent_body`: nothing parsed or
    encoded again), and the answer's values are built by msgspec (:func:`answer_values`).
    """

    def __init__(
        self,
        timeout: float | None = DEFAULT_TIMEOUT_S,
        limits: Mapping[str, Mapping[str, int]] | None = None,
        load: Callable[[str], object] | None = None,
    ) -> None:
        from plotgate.service import registry

        self._registry = registry
        self._timeout = min(timeout or 0.0, LONGEST_DEADLINE_S)
        """Seconds an exchange may take; 0: no deadline."""
        self._limits = limits or {}
        self._load = load
        """Called with an operation's name before its first exchange runs (the CLI loads
        its kernels there, saying when they compile; its failure ends the replay)."""
        self._met: set[str] = set()
        self._previous: Any = None
        self._installed = False

    def __enter__(self) -> "InProcess":
        if self._alarmed():
            self._previous = signal.signal(signal.SIGALRM, _ring)
            self._installed = True
        return self

    def _alarmed(self) -> bool:
        """Whether exchanges run here get a deadline: one is set, in the main thread."""
        return bool(self._timeout) and threading.current_thread() is threading.main_thread()

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)
            self._installed = False

    def __call__(self, exchange: Exchange, rid: str) -> Answer:
        if not self._installed and self._alarmed():
            with self:
                return self(exchange, rid)
        op = self._registry.OPERATIONS[exchange.operation]
        # imported here, not in the answer's try below: an import that fails (a damaged
        # kernel cache) ends the replay, it is no 500
        self.meet(op.name)
        try:
            # The timer is disarmed in the inner finally, so an alarm that rings late
            # still lands in the except clauses below, never in the caller.
            try:
                if self._installed:
                    signal.setitimer(signal.ITIMER_REAL, self._timeout)
                    outcome = self._outcome(op, exchange, rid)
                elif self._timeout:  # a thread no signal reaches: a Dask worker's task
                    with _thread_alarm(self._timeout):
                        outcome = self._outcome(op, exchange, rid)
                else:
                    outcome = self._outcome(op, exchange, rid)
            finally:
                if self._installed:
                    signal.setitimer(signal.ITIMER_REAL, 0)
        except _Overtime:
            return Answer(None, note=f"no answer within {self._timeout:g} s (--timeout)")
        except Exception as exc:  # noqa: BLE001 - a bug in an operation: the server's 500
            note = f"{exchange.operation} {exchange.request_id}: {type(exc).__name__}: {exc}"
            outcome = self._registry.internal_error(op, rid)
            return Answer(outcome.status, answer_values(outcome.content), note)
        if outcome is None:
            return Answer(None, skip=OVER_CAPS)
        return Answer(outcome.status, answer_values(outcome.content))

    def meet(self, operation: str) -> None:
        """Load ``operation`` if this runner has not met it yet (``load``, then its handler's
        module); :func:`replay` calls it before it starts an exchange's clock, so a
        replayed duration holds no import or compilation."""
        if operation not in self._met:
            if self._load is not None:
                self._load(operation)
            importlib.import_module(self._registry.OPERATIONS[operation].module)
            self._met.add(operation)

    def _outcome(self, op: "Operation", exchange: Exchange, rid: str) -> "Answered | None":
        """The registry's outcome, or None for a request over the caps whose recorded
        answer is not that cap's refusal."""
        registry = self._registry
        parsed = registry.parse(op, sent_body(exchange))
        if parsed.request is None:
            return registry.failed(op, parsed.problem, rid)
        over = registry.over_caps(op, parsed.request, self._limits.get(op.name, {}))
        if over is None:
            return registry.run(op, parsed.request, rid)
        if _refused_alike(exchange, over.status, [e.field for e in over.errors]):
            return registry.failed(op, over, rid)  # the recorded cap refusal, again
        return None


def answer_values(content: bytes) -> Any:
    """The values of an answer's JSON: msgspec's (a third of the ``json`` module's time on
    these answers; the same values, integers past 64 bits kept), or ``json``'s where msgspec
    refuses (a NaN or Infinity token)."""
    try:
        return _VALUES.decode(content)
    except msgspec.DecodeError:
        return json.loads(content)


def _loaded_by_the_server(operation: str) -> None:
    """Over HTTP, nothing to load before an exchange: the server has every operation."""


def in_process(
    timeout: float | None = DEFAULT_TIMEOUT_S,
    limits: Mapping[str, Mapping[str, int]] | None = None,
) -> InProcess:
    """An :class:`InProcess` runner (use it in ``with`` to install its alarm once)."""
    return InProcess(timeout, limits)


def sent_body(exchange: Exchange) -> bytes:
    """The request body to send again: read from a recording, the body's JSON as it stands
    in the record (the recorder embeds it as it came: nothing is parsed or encoded again);
    made from values, the recorded JSON serialized by pydantic-core (:class:`InProcess` says
    why), or :attr:`Exchange.body` (raw text, or what it refuses)."""
    from pydantic_core import PydanticSerializationError, to_json

    if exchange.request_bytes is not None:
        recorded = body_bytes(exchange.request_bytes)
        if recorded is not None:
            return recorded
    request = exchange.request or {}
    if "body" in request:
        try:
            return to_json(request["body"])
        except PydanticSerializationError:
            pass
    return exchange.body


def over_http(http: "httpx.Client") -> Runner:
    """Send exchanges to a live server through ``http`` (its base URL is the server; its
    read timeout the time an exchange may take), each under its new id and marked as a
    replay of its original."""
    import httpx

    from plotgate.clients.errors import TransportError

    def answer(exchange: Exchange, rid: str) -> Answer:
        url = f"{http.base_url}".rstrip("/") + ENDPOINTS[exchange.operation].path
        try:
            response = http.post(
                ENDPOINTS[exchange.operation].path,
                content=sent_body(exchange),
                headers={
                    "content-type": "application/json",
                    "x-request-id": rid,
                    "x-plotgate-replay-of": exchange.request_id,
                },
            )
        except httpx.TimeoutException:
            return Answer(None, note=f"no answer within {http.timeout.read} s (--timeout)")
        except httpx.TransportError as exc:
            raise TransportError(f"cannot reach {url}: {exc}") from None
        try:
            content = response.json()
        except ValueError:
            return Answer(response.status_code, None, "the answer is not JSON")
        return Answer(response.status_code, content)

    return answer


def replay(
    paths: Path | str | Iterable[Path | str],
    *,
    server: str | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    out: Path | None = None,
    progress: bool | None = None,
    filters: Filters | None = None,
    timeout: float | None = DEFAULT_TIMEOUT_S,
    limits: Mapping[str, Mapping[str, int]] | None = None,
    load: Callable[[str], object] | None = None,
    rules: Rules | None = None,
    observe: Observer | None = None,
    cases: bool = False,
    pace: float | None = None,
) -> ReplayReport:
    """Replay every exchange in the files at ``paths`` (files or folders) and compare.

    Parameters
    ----------
    server : base URL of a live server; None runs in-process.
    rtol, atol : float tolerances of the comparison.
    out : write the replayed session (each request under its new id, marked as a replay
        of its original, with its new answer) to this MCAP file, and a ``foxglove.Log``
        per changed exchange on its ``/replay/diff`` channel
        (:mod:`plotgate.clients.replay_diff`).
    progress : show a progress bar; None shows it only on a terminal.
    filters : replay only these operations and request times.
    timeout : seconds each exchange may take (None: no limit).
    limits : in-process work caps, ``{operation: {size: cap}}`` (the server's are
        ``Settings().limits``: the defaults with ``PLOTGATE_LIMITS`` over them); exchanges
        over them are not run. None runs every exchange.
    load : in-process, called with an operation's name before its first exchange runs
        (the registry imports each operation when it first runs; the CLI loads its kernels
        here, saying when they compile).
    rules : per-field tolerances (:mod:`plotgate.clients.tolerances`) over ``rtol`` and
        ``atol``; None: those two everywhere.
    observe : called with every compared exchange's recorded and replayed answers.
    cases : keep every compared exchange's name in :attr:`ReplayReport.cases`.
    pace : with ``server`` (and without ``out``): send at the recorded pace times this
        speed, open-loop (:mod:`plotgate.clients.pace`); ``inf``: as fast as possible.

    Raises :class:`plotgate.clients.TransportError` when the server cannot be reached, and
    ``FileNotFoundError`` for a path that does not exist.
    """
    report = ReplayReport(cases=[] if cases else None)
    reader = Reader(paths, filters)
    with contextlib.ExitStack() as resources:
        if server:
            import httpx

            http = resources.enter_context(
                httpx.Client(base_url=server, timeout=httpx.Timeout(timeout, connect=10.0))
            )
            run: Runner = over_http(http)
            meet: Callable[[str], None] = _loaded_by_the_server
        else:
            runner = resources.enter_context(InProcess(timeout, limits, load))
            run, meet = runner, runner.meet
        writer = resources.enter_context(_SessionWriter(out, reader.paths)) if out else None
        from tqdm import tqdm

        quiet = None if progress is None else not progress
        judging = _Judging(rtol, atol, rules, observe)
        durations = Durations() if server else None
        shown = tqdm(reader, desc="replay", unit="exchange", disable=quiet)
        for exchange, outcome in _judged(shown, run, judging, writer, meet, report, pace):
            tally(report, exchange, outcome)
            if writer is not None and outcome.differences:
                writer.changed(exchange, outcome.differences)
            if durations is not None and outcome.duration_s is not None:
                durations.add(exchange.operation, exchange.duration_s, outcome.duration_s)
        report.latency = durations.percentiles() if durations is not None else {}
    if writer is not None and writer.diff_note and report.changed:
        report.notes.append(writer.diff_note)
    report.files = [rec.summary() for rec in reader.files]
    report.unreadable = list(reader.unreadable)
    report.skipped = list(reader.skipped)
    report.recordings = reader.recordings
    report.written_twice = reader.written_twice
    report.conflict_count, report.conflicts = reader.conflict_count, list(reader.conflicts)
    return report


def _judged(
    exchanges: Iterable[Exchange],
    run: Runner,
    judging: "_Judging",
    writer: "_SessionWriter | None",
    meet: Callable[[str], None],
    report: ReplayReport,
    pace: float | None,
) -> Iterator[tuple[Exchange, "Outcome"]]:
    """Each exchange with its outcome, in the order read: one after the other, or sent
    at the recorded pace (``pace``: its speed), the pacing kept in ``report``."""
    if pace is None:
        for exchange in exchanges:
            yield exchange, judge(exchange, run, judging, writer=writer, meet=meet)
        return
    from plotgate.clients.pace import Pacing, paced

    pacing = Pacing(pace)
    try:
        yield from paced(exchanges, lambda ex: judge(ex, run, judging, meet=meet), pacing)
    finally:
        report.pacing = pacing.to_json()
        report.pacing_text = pacing.text()


@dataclass(frozen=True)
class Outcome:
    """What replaying one exchange found: ``skip`` says why it was not compared; else the
    ``differences`` (none: unchanged) and a ``note`` (an exception raised in process)."""

    skip: str | None = None
    differences: tuple[tuple[str, Any, Any, str], ...] = ()
    """Each: the field, its recorded and replayed values, and what judged it."""
    note: str | None = None
    duration_s: float | None = field(default=None, compare=False)
    """How long the replayed answer took (s); not part of the judgement."""


@dataclass(frozen=True)
class _Judging:
    rtol: float
    atol: float
    rules: Rules | None = None
    observe: Observer | None = None


def judge(
    exchange: Exchange,
    run: Runner,
    rtol: "float | _Judging",
    atol: float = 0.0,
    writer: Callable[[Exchange, str, Answer, float], None] | None = None,
    meet: Callable[[str], None] | None = None,
    rules: Rules | None = None,
) -> Outcome:
    """Run one exchange again (when it can be compared) and compare its answer; ``writer``
    writes the replayed exchange, ``meet`` loads its operation before its clock starts (so
    a written duration holds no import or compilation). The serial replay and the fleet's
    workers both judge with this, and :func:`tally` counts the outcomes in the serial
    order. ``rtol`` may carry the whole judging (tolerances, rules, observer); ``rules``
    judges fields by their tolerance rules."""
    how = rtol if isinstance(rtol, _Judging) else _Judging(rtol, atol, rules)
    reason = _not_comparable(exchange)
    if reason is None and exchange.operation not in ENDPOINTS:
        return Outcome(
            differences=(
                ("operation", exchange.operation, "not an operation of this build", DEFAULT),
            )
        )
    if reason is not None:
        return Outcome(skip=reason)
    rid = uuid.uuid4().hex
    if meet is not None:
        meet(exchange.operation)
    started = time.perf_counter()
    answer = run(exchange, rid)
    took = time.perf_counter() - started
    if answer.skip is not None:
        return Outcome(skip=answer.skip)
    if writer is not None and answer.status is not None:
        writer(exchange, rid, answer, took)
    if answer.status == 503:  # a fault of the server now, set aside as a recorded one is
        return Outcome(skip=FAULT_NOW)
    found = tuple(_differences(exchange, answer, how))
    return Outcome(None, found, answer.note, took if answer.status is not None else None)


def tally(report: ReplayReport, exchange: Exchange, outcome: Outcome) -> None:
    """Count one exchange's outcome into ``report``, in the order exchanges are read."""
    report.exchanges += 1
    if outcome.skip is not None:
        report.not_compared[outcome.skip] = report.not_compared.get(outcome.skip, 0) + 1
        return
    if outcome.note and len(report.notes) < MAX_LISTED:
        report.notes.append(outcome.note)
    _count(report, exchange, outcome.differences)


def _refused_alike(exchange: Exchange, status: int, fields: list[str]) -> bool:
    """Whether the recording holds the refusal a cap gives now (its status and fields): the
    server recorded it under the same cap, so it compares; any other recorded answer was
    given under other caps, and is not compared."""
    recorded = exchange.response or {}
    old = _failure(recorded.get("status", 0), recorded.get("error"))
    return old["status"] == status and old["fields"] == sorted(fields)


def _not_comparable(exchange: Exchange) -> str | None:
    """Why the exchange is not compared, or None; from its envelope (the status), without
    building the records' values."""
    if exchange.request_bytes is None and exchange.request is None:
        return REQUEST_LOST
    if exchange.response_bytes is None and exchange.response is None:
        return NEVER_ANSWERED
    if exchange.status == 408:
        return BODY_TIMEOUT
    if exchange.status == 503:  # says nothing of what the operation answers
        return REFUSED_FOR_THE_SERVER
    if exchange.status == 499:
        return CLIENT_GONE
    if exchange.original_read:
        return REPLAYED_ORIGINAL
    return None


def _differences(
    exchange: Exchange, answer: Answer, how: _Judging
) -> list[tuple[str, Any, Any, str]]:
    recorded = exchange.response or {}
    status = recorded.get("status", 0)
    if answer.status is None:
        return [("answer", f"status {status}", answer.note, DEFAULT)]
    if status < 400 and answer.status < 400:
        old, new = recorded.get("result"), answer.content
    else:
        old = _failure(status, recorded.get("error"))
        new = _failure(answer.status, answer.content if answer.status >= 400 else {})
    if how.observe is not None:
        how.observe(exchange.operation, old, new)
    if old == new:
        # Equal trees have no difference to find (1 and 1.0, true and 1 are equal and
        # not reported either); NaN is unequal to itself, so a NaN is still walked to.
        # Exact only for trees parsed apart, as these are: no float object is shared.
        return []
    found = []
    fields = how.rules.for_operation(exchange.operation) if how.rules is not None else None
    for where, a, b in diff(old, new, how.rtol, how.atol, rules=fields):
        rule = DEFAULT if fields is None else fields.at(where).rule
        found.append((where or "result", a, b, rule))
        if len(found) == FIELDS_PER_EXCHANGE:
            break
    return found


def _count(
    report: ReplayReport, exchange: Exchange, differences: tuple[tuple[str, Any, Any, str], ...]
) -> None:
    report.compared += 1
    row = report.operations.get(exchange.operation)
    if row is None:
        row = report.operations[exchange.operation] = {"compared": 0, "changed": 0}
    row["compared"] += 1
    if report.cases is not None:
        case = (exchange.operation, exchange.request_id, exchange.log_time, bool(differences))
        report.cases.append(case)
    if not differences:
        report.unchanged += 1
        return
    report.changed += 1
    row["changed"] += 1
    when = iso_time(exchange.log_time) or ""
    for where, a, b, rule in differences:
        if len(report.changes) < MAX_CHANGES:
            report.changes.append(
                Change(
                    exchange.file,
                    exchange.operation,
                    exchange.request_id,
                    when,
                    where,
                    a,
                    b,
                    rule,
                )
            )


class _SessionWriter:
    """Writes the replayed session (each request under its new id, marked as a replay of
    its original, with its new answer) to one MCAP file: a temporary beside ``out``, renamed
    into place at the end (:mod:`plotgate.files`; an ``out`` that is a link, FIFO, device or
    folder is refused before anything is replayed)."""

    def __init__(self, out: Path, sources: list[Path]) -> None:
        from plotgate.service.provenance import VERSION
        from plotgate.service.recording import Recorder, RecordingError
        from plotgate.service.registry import OPERATIONS

        out = self._out = Path(out)
        check_target(out)
        fd, self._partial = temporary_beside(out, suffix=".writing")
        os.close(fd)
        self._partial.unlink()  # the recorder creates it again with O_EXCL|O_NOFOLLOW
        metadata = {
            "plotgate_version": VERSION,
            "replayed_from": ", ".join(map(str, sources))[:10_000],
        }
        diff_channel = log_channel()
        self.diff_note = None if diff_channel else NO_SDK
        self._recorder = Recorder(
            out.parent,
            OPERATIONS.values(),
            file_name=self._partial.name,
            metadata=metadata,
            other_channels=[diff_channel] if diff_channel else (),
        ).start()
        self._failed = RecordingError
        self._last: tuple[Exchange, str, int] | None = None
        """The exchange written last, its new id and when its replay was sent (ns)."""

    def __call__(self, exchange: Exchange, rid: str, answer: Answer, duration_s: float) -> None:
        """Write one replayed exchange; ``OSError`` naming ``--out`` when it cannot be
        written (a full disk), so the run ends with that message and exit 2, not as a bug,
        and never with records silently missing."""
        from plotgate.service.recording import RecordingError, request_record, response_record

        op = exchange.operation
        try:
            written = self._recorder.request(
                op, request_record(rid, op, sent_body(exchange), replay_of=exchange.request_id)
            )
            content = json.dumps(answer.content).encode()
            self._recorder.response(
                written, response_record(rid, op, answer.status or 0, duration_s, content)
            )
            flushed = self._recorder.flush()
        except RecordingError as exc:
            raise self._unwritable(exc.__cause__ or exc) from exc
        if not flushed:
            raise self._unwritable(self._recorder.error)
        self._last = exchange, rid, written.request_time

    def changed(
        self, exchange: Exchange, differences: tuple[tuple[str, Any, Any, str], ...]
    ) -> None:
        """Log on ``/replay/diff`` how the exchange just written changed (each difference:
        field, recorded, replayed, rule); nothing without foxglove-sdk."""
        if self.diff_note is not None or self._last is None or self._last[0] is not exchange:
            return
        _, rid, log_time = self._last
        data = diff_log(log_time, exchange.operation, (rid, exchange.request_id), differences)
        try:
            self._recorder.message(DIFF_TOPIC, data, log_time)
            flushed = self._recorder.flush()
        except self._failed as exc:
            raise self._unwritable(exc.__cause__ or exc) from exc
        if not flushed:
            raise self._unwritable(self._recorder.error)

    def _unwritable(self, failure: BaseException | None) -> OSError:
        code = failure.errno if isinstance(failure, OSError) and failure.errno else errno.EIO
        return OSError(code, f"the replayed session cannot be written: {failure}", str(self._out))

    def __enter__(self) -> "_SessionWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        """Close the session and put it in place, a failed run's too: the recorder's file is
        a readable recording of every exchange written before the failure, as before."""
        self._recorder.close()
        if self._partial.exists():
            replace_into(self._partial, self._out)
