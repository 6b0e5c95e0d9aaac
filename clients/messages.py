"""The recorder's messages checked: one reference check on Python's json, one fast check on
msgspec's compiled parser, and the two agree on every byte string.

A message of channel ``<operation>/<kind>`` is what the recorder writes when it is a JSON
object of at most :data:`MAX_DEPTH` levels, in UTF-8, whose numbers are JSON numbers (no
``NaN`` or ``Infinity`` tokens; an integer of more digits than Python's
``sys.get_int_max_str_digits()`` is refused, as ``json`` refuses it), with a request id the
service could have given, ``raw`` as text for a request (without ``body`` or ``raw``, its
body was empty), a status and a result or problem for a response.

:func:`parse_record` is the reference: ``json.loads``, then the checks. :func:`check_messages`
gives the same verdicts for many messages at once, five times faster (9.4 against 46.7 us
a message of the bench's recording), without building the messages' values: msgspec
validates every byte of each message's JSON while decoding only the envelope (request id,
operation, status, duration, replay_of, raw, error), and the rest is checked over all the
messages together (UTF-8, long integers, depth) with C-level byte operations. Where the two
parsers differ, the message goes to the reference:

- msgspec refuses a lone UTF-16 surrogate escape (``"\\ud800"``), which ``json`` takes; such
  a message is checked by the reference, and accepted;
- msgspec skips an integer of any length, which ``json`` refuses past 4300 digits; a run of
  digits that long sends the message to the reference;
- msgspec does not check the UTF-8 of the strings it skips; a message that is not ASCII is
  decoded first;
- msgspec's nesting limit is the interpreter's recursion limit; depth is counted here.

Duplicate keys (the last wins), ``1e999`` (``json``: infinity; msgspec refuses, so the
reference decides) and whitespace are alike or decided by the reference. :func:`loads` builds
a checked message's values, with msgspec, or ``json`` where msgspec refuses; msgspec keeps
integers past 64 bits as integers, as ``json`` does (orjson makes them floats).
"""

import json
import re
import sys
from collections.abc import Sequence
from typing import Any, NamedTuple, cast

import msgspec
import numpy as np

from plotgate.service.schemas import REQUEST_ID_PATTERN, Problem

__all__ = [
    "MAX_DEPTH",
    "MAX_DURATION_S",
    "MAX_TIME_NS",
    "Envelope",
    "body_bytes",
    "check_messages",
    "check_time",
    "loads",
    "parse_record",
]

MAX_DEPTH = 256
"""Deepest JSON a record may hold. The service records a body as ``body`` only when its
JSON parser (nesting limit 200) takes it, inside a one-level envelope."""
MAX_DURATION_S = 1e7
"""Longest duration a response record may state, s (116 days, past any request's timeout).
A duration is a finite number in [0, MAX_DURATION_S]: a 400-digit integer or ``1e308``,
which JSON and the recorder's schema allow, overflowed the readers' arithmetic (ms, ns)."""
MAX_TIME_NS = 2**63 - 1
"""Latest message time a recording may hold, ns since the epoch (an int64: the year 2262).
MCAP allows any 64-bit unsigned time; the readers keep times in int64 arrays, and add
durations to them."""
REQUEST_ID = re.compile(REQUEST_ID_PATTERN)
UNSET: Any = msgspec.UNSET
"""A field the message does not have (``null`` is a value)."""


class Envelope(NamedTuple):
    """What the readers use of a checked message without building its values."""

    request_id: str
    replay_of: str | None
    status: int | None
    """The response's HTTP status (None for a request)."""
    duration_s: float | None


class _Fields(msgspec.Struct):
    """The envelope's fields; every other field is skipped, its JSON syntax still checked."""

    request_id: Any = UNSET
    operation: Any = UNSET
    replay_of: Any = UNSET
    raw: Any = UNSET
    status: Any = UNSET
    duration_s: Any = UNSET
    result: msgspec.Raw | msgspec.UnsetType = UNSET
    error: Any = UNSET


class _Body(msgspec.Struct):
    """A request record's body, its JSON kept as bytes; every other field skipped."""

    body: msgspec.Raw | msgspec.UnsetType = UNSET


_FIELDS = msgspec.json.Decoder(_Fields)
_BODY = msgspec.json.Decoder(_Body)
_VALUES = msgspec.json.Decoder()


def _no_constant(token: str) -> Any:
    raise ValueError(f"{token} is not JSON")


def _shape(kind: str, operation: str, record: Any) -> Envelope:
    """The checks after parsing, on a record or its envelope (absent fields UNSET), or
    ValueError saying what is wrong."""
    rid = record.request_id
    if not isinstance(rid, str) or not REQUEST_ID.match(rid):
        raise ValueError("no request_id the service could have given")
    if record.operation != operation:
        named = None if record.operation is UNSET else record.operation
        raise ValueError(f"operation {str(named)[:100]!r} on the channel of {operation}")
    if kind == "request":
        replay_of = None if record.replay_of is UNSET else record.replay_of
        if replay_of is not None and not (
            isinstance(replay_of, str) and REQUEST_ID.match(replay_of)
        ):
            raise ValueError("replay_of is not a request id")
        if record.raw is not UNSET and not isinstance(record.raw, str):
            raise ValueError("a request record whose raw body is not text")
        return Envelope(rid, replay_of, None, None)
    status, duration = record.status, record.duration_s
    if not (type(status) is int and 100 <= status <= 599):
        raise ValueError("a response record without an HTTP status")
    if not (isinstance(duration, int | float) and type(duration) is not bool):
        raise ValueError("a response record without a duration")
    if not 0 <= duration <= MAX_DURATION_S:  # NaN, infinities and long integers included
        raise ValueError(
            f"a response record whose duration_s {str(duration)[:40]} is not a number of "
            f"seconds in [0, {MAX_DURATION_S:g}]"
        )
    if status < 400 and record.result is UNSET:
        raise ValueError(f"a {status} response record without a result")
    if status >= 400:
        try:
            Problem.model_validate(None if record.error is UNSET else record.error)
        except ValueError:
            raise ValueError(f"a {status} response record without a problem") from None
    return Envelope(rid, None, status, float(duration))


class _Record:
    """A parsed record seen through the envelope's field names (absent fields UNSET)."""

    def __init__(self, record: dict[str, Any]) -> None:
        self.record = record

    def __getattr__(self, name: str) -> Any:
        return self.record.get(name, UNSET)


def _reference(kind: str, operation: str, data: bytes) -> tuple[dict[str, Any], Envelope]:
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
    return record, _shape(kind, operation, _Record(record))


def parse_record(kind: str, operation: str, data: bytes) -> dict[str, Any]:
    """A message of channel ``<operation>/<kind>`` as the recorder writes it, or ValueError
    saying why it is not one (the reference check, on ``json``)."""
    return _reference(kind, operation, data)[0]


def check_messages(messages: Sequence[tuple[str, str, bytes]]) -> list[Envelope | str]:
    """For each ``(kind, operation, data)``, its envelope, or why it is not a message the
    recorder writes: exactly :func:`parse_record`'s verdict, and its reason.

    A message goes to the reference when msgspec refuses it (the reference says why, or
    takes it), when it is not ASCII, may hold an integer past the interpreter's limit, or
    nests too deep. In the usual batch (every message taken by msgspec, ASCII, without
    escapes or long runs of digits) those screens, nesting included, are one pass each over
    the batch's bytes (each message is valid JSON, so the nesting of one ends before the
    next starts), and its envelopes are checked together (:func:`_usual`); otherwise, or
    when a screen fires, message by message."""
    decode = _FIELDS.decode
    fields: list[_Fields | None] = []
    for _, _, data in messages:
        try:
            fields.append(decode(data))
        except Exception:  # noqa: BLE001 - any refusal: the reference says why, or accepts
            fields.append(None)
    limit = sys.get_int_max_str_digits()
    if None not in fields:
        batch = b"".join([data for _, _, data in messages])
        if (
            batch.isascii()
            and b"\\" not in batch
            and not (limit and len(batch) > limit and _long_digits(batch, limit))
            and not _structure_deeper(batch.translate(_PARENTHESES, _NOT_STRUCTURE))
        ):
            usual = _usual(messages, cast("list[_Fields]", fields))
            if usual is not None:
                return usual
            return [_verdict(m, f, False) for m, f in zip(messages, fields, strict=True)]
    suspects: set[int] = set()
    structures = []
    for i, ((_, _, data), f) in enumerate(zip(messages, fields, strict=True)):
        if f is None:
            continue
        if not data.isascii() or limit and len(data) > limit and _long_digits(data, limit):
            suspects.add(i)
        elif b"\\" in data:  # escapes: the reference finds its strings
            if _too_deep(data):
                suspects.add(i)
        else:
            structure = data.translate(_PARENTHESES, _NOT_STRUCTURE)
            if len(structure) > MAX_DEPTH:  # else too few brackets to nest that deep
                structures.append(structure)
    deep = _structure_deeper(b"".join(structures))
    return [
        _verdict(m, f, i in suspects or deep and _too_deep(m[2]))
        for i, (m, f) in enumerate(zip(messages, fields, strict=True))
    ]


def _verdict(
    message: tuple[str, str, bytes], fields: _Fields | None, suspect: bool
) -> Envelope | str:
    """One message's verdict: by the reference when msgspec refused it or a screen fired
    on it, from its envelope's fields otherwise."""
    kind, operation, data = message
    try:
        if fields is None or suspect:
            return _reference(kind, operation, data)[1]
        return _shape(kind, operation, fields)
    except ValueError as exc:
        return str(exc)


_ID = REQUEST_ID_PATTERN.removeprefix("^").removesuffix("$")
_REQUEST_IDS = re.compile(f"(?:{_ID}\n)*")
"""Request ids, each followed by a newline: what :data:`REQUEST_ID` takes of ids without
one (an id the pattern's ``$`` lets end with a newline, or holding one, sends the batch to
:func:`_shape`)."""


def _usual(
    messages: Sequence[tuple[str, str, bytes]], fields: list[_Fields]
) -> list[Envelope | str] | None:
    """The envelopes of a batch whose every message is usual, checked together: what
    :func:`_shape` gives each; None when any is not (a replay, an error response, a
    request id or field the bulk checks do not take), and then :func:`_shape` judges each.

    Usual: a request id the service could have given, the channel's operation; a request
    without ``replay_of`` whose ``raw``, if any, is text; a response of a status below 400
    with a result and a duration in [0, :data:`MAX_DURATION_S`]."""
    ids = [f.request_id for f in fields]
    if {type(i) for i in ids} != {str}:
        return None
    joined = "\n".join(ids) + "\n"
    if (
        joined.count("\n") != len(ids)  # an id holds a newline
        or _REQUEST_IDS.fullmatch(joined) is None
        or [f.operation for f in fields] != [m[1] for m in messages]
    ):
        return None
    requests = [f for f, m in zip(fields, messages, strict=True) if m[0] == "request"]
    responses = [f for f, m in zip(fields, messages, strict=True) if m[0] != "request"]
    if (
        any(f.replay_of is not UNSET and f.replay_of is not None for f in requests)
        or {type(f.raw) for f in requests} - {str, msgspec.UnsetType}
        or {type(f.status) for f in responses} - {int}
        or {type(f.duration_s) for f in responses} - {int, float}
        or any(f.result is UNSET for f in responses)
    ):
        return None
    statuses = [f.status for f in responses]
    if statuses and not (100 <= min(statuses) and max(statuses) < 400):
        return None
    if not all(0 <= f.duration_s <= MAX_DURATION_S for f in responses):
        return None
    return [
        Envelope(f.request_id, None, None, None)
        if m[0] == "request"
        else Envelope(f.request_id, None, f.status, float(f.duration_s))
        for m, f in zip(messages, fields, strict=True)
    ]


def check_time(log_time: int) -> str | None:
    """Why a message's ``log_time`` (ns) is not one a reader computes with, or None: the
    one check of a record's time, before any arithmetic."""
    if 0 <= log_time <= MAX_TIME_NS:
        return None
    return f"a message whose log_time {log_time} ns is past {MAX_TIME_NS} (the year 2262)"


def loads(data: bytes) -> Any:
    """The values of a checked message: msgspec's, or ``json``'s where msgspec refuses (a lone
    surrogate escape, a number past a double's range)."""
    try:
        return _VALUES.decode(data)
    except Exception:  # noqa: BLE001 - json takes what the check took
        return json.loads(data.decode("utf-8"), parse_constant=_no_constant)


def body_bytes(data: bytes) -> bytes | None:
    """The ``body`` of a checked request record, its bytes as they stand in the record (the
    recorder embeds a strict-JSON body as it came); None for a record without one (its body
    was ``raw`` text, or empty) and where msgspec refuses the record (a lone surrogate
    escape: the values, built by ``json``, say what was sent)."""
    try:
        body = _BODY.decode(data).body
    except Exception:  # noqa: BLE001 - checked already: json takes what msgspec refuses
        return None
    return bytes(body) if isinstance(body, msgspec.Raw) else None


def _long_digits(text: bytes, limit: int) -> bool:
    """True when ``text`` may hold an integer ``json`` refuses: a run of more than ``limit``
    digits. Such a run holds every byte between two neighbouring multiples of half the
    limit, so only the spans between two sampled digits are looked at."""
    step = limit // 2
    marks = text[::step].translate(_DIGIT_MARKS)
    at = marks.find(b"11")
    while at >= 0:
        if text[at * step : (at + 1) * step + 1].isdigit():
            return True
        at = marks.find(b"11", at + 1)
    return False


_DIGIT_MARKS = bytes(ord("1") if c in b"0123456789" else ord("0") for c in range(256))
_STRINGS = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)
_BARE_STRINGS = re.compile(rb'"[^"]*"')
_NOT_STRUCTURE = bytes(set(range(256)) - set(b'[]{}"'))
_PARENTHESES = bytes.maketrans(b"[{]}", b"(())")
_STEPS = bytes.maketrans(b"()", b"\x01\xff")
"""A parenthesis as the step it makes in the nesting (an int8: +1 or -1)."""


def _too_deep(text: bytes) -> bool:
    """True when the JSON ``text`` nests deeper than :data:`MAX_DEPTH`."""
    return text.count(b"[") + text.count(b"{") > MAX_DEPTH and _deeper(text)


def _deeper(text: bytes) -> bool:
    """True when the JSON ``text`` nests deeper than :data:`MAX_DEPTH`, from its bytes."""
    if b"\\" in text:  # escapes: strings found in the whole text
        return _structure_deeper(_STRINGS.sub(b"", text).translate(_PARENTHESES, _NOT_STRUCTURE))
    return _structure_deeper(text.translate(_PARENTHESES, _NOT_STRUCTURE))


def _structure_deeper(structure: bytes) -> bool:
    """True when ``structure`` (the quotes and brackets of JSON texts without escapes, the
    brackets as parentheses) nests deeper than :data:`MAX_DEPTH`.

    Every quote delimits a string. When every quote pairs with the next one, each string
    encloses no bracket and the quotes simply go; otherwise the strings go with a regular
    expression (slower). The nesting is then counted with numpy (a walk over the parsed
    values in Python cost more than the parse itself)."""
    if 2 * structure.count(b'""') == structure.count(b'"'):
        return _depth(structure.translate(None, b'"')) > MAX_DEPTH
    return _depth(_BARE_STRINGS.sub(b"", structure)) > MAX_DEPTH


def _depth(parentheses: bytes) -> int:
    """The deepest nesting of balanced ``parentheses``, counted a mebibyte at a time (a
    piece's running sum, at most its 2**20 steps, fits an int32: half the memory of int64)."""
    level, deepest = 0, 0
    for start in range(0, len(parentheses), 2**20):
        steps = parentheses[start : start + 2**20].translate(_STEPS)
        run = np.cumsum(np.frombuffer(steps, np.int8), dtype=np.int32)
        deepest = max(deepest, level + int(run.max()))
        level += int(run[-1])
    return deepest
