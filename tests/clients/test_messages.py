"""The fast check of the recorder's messages (msgspec) against the reference (json): the same
verdict and reason for every byte string, the same values for every message taken."""

import json
import math
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plotgate.clients.messages import MAX_DEPTH, Envelope, check_messages, loads, parse_record

HEAD = b'{"request_id": "r1", "operation": "gates.test", '
"""A request record's envelope; a field's value follows."""


def _reference(kind: str, data: bytes) -> str | dict:
    try:
        return parse_record(kind, "gates.test", data)
    except ValueError as exc:
        return str(exc)


def _agree(kind: str, data: bytes, verdict: Envelope | str) -> None:
    """``verdict`` (the fast check's) is the reference's, and a message taken reads back as
    ``json`` reads it."""
    reference = _reference(kind, data)
    if isinstance(reference, str):
        assert verdict == reference, data[:200]
        return
    assert isinstance(verdict, Envelope), (verdict, data[:200])
    assert verdict.request_id == reference["request_id"]
    assert verdict.replay_of == reference.get("replay_of")
    if kind == "response":
        assert (verdict.status, verdict.duration_s) == (
            reference["status"],
            reference["duration_s"],
        )
    assert _same(loads(data), reference), data[:200]


def _same(a: object, b: object) -> bool:
    """Equal, with the types json gives (an int stays an int, -0.0 stays -0.0)."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b and math.copysign(1, a) == math.copysign(1, b)
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)  # type: ignore[index]
    if isinstance(a, list):
        return len(a) == len(b) and all(map(_same, a, b))  # type: ignore[arg-type]
    return a == b


def _check(kind: str, *texts: bytes) -> None:
    verdicts = check_messages([(kind, "gates.test", t) for t in texts])
    for text, verdict in zip(texts, verdicts, strict=True):
        _agree(kind, text, verdict)


def _body(value: bytes) -> bytes:
    return HEAD + b'"body": ' + value + b"}"


# Where msgspec and json differ, and what the reader must keep doing.
DIFFERENCES = {
    "NaN token (json takes it unless told; the reader refuses)": _body(b"[NaN]"),
    "Infinity token": _body(b"[Infinity]"),
    "-Infinity token": _body(b'{"a": -Infinity}'),
    "1e999 (json: infinity; msgspec: out of range)": _body(b"[1e999, -1e999]"),
    "1e-400 (both: zero)": _body(b"[1e-400]"),
    "duplicate keys (the last wins)": HEAD + b'"body": {"a": 1, "a": 2}, "request_id": "r2"}',
    "a 30-digit integer (orjson: a float)": _body(b"[123456789012345678901234567890]"),
    "a 4300-digit integer (json's limit)": _body(b"7" * 4300),
    "a 4301-digit integer (over json's limit)": _body(b"7" * 4301),
    "a 5000-digit integer": _body(b"-" + b"7" * 5000),
    "5000 digits in a string": _body(b'"' + b"7" * 5000 + b'"'),
    "many long numbers": _body(b"[" + b", ".join([b"1" * 3000] * 20) + b"]"),
    "a lone high surrogate (msgspec refuses, json takes)": _body(b'"\\ud800"'),
    "a lone low surrogate": _body(b'"\\udc00x"'),
    "a high surrogate then a letter": _body(b'"\\ud800\\u0041"'),
    "a surrogate pair": _body(b'"\\ud83d\\ude00"'),
    "raw UTF-8 in a skipped string": _body('"Ω Привет"'.encode()),
    "invalid UTF-8 in a skipped string": _body(b'"\xff\xfe"'),
    "an overlong UTF-8 sequence": _body(b'"\xc0\xaf"'),
    "a UTF-8 BOM": b"\xef\xbb\xbf" + _body(b"{}"),
    "a control character in a string": _body(b'"a\x01b"'),
    "a form feed as whitespace": _body(b"\x0c[]"),
    "a non-breaking space as whitespace": _body(b"\xc2\xa0[]"),
    "trailing data": _body(b"{}") + b" {}",
    "a trailing comma": _body(b"[1, 2,]"),
    "a leading zero": _body(b"[01]"),
    "a lone minus": _body(b"[-]"),
    "single quotes": _body(b"{'a': 1}"),
    "a comment": _body(b"[1 /* x */]"),
    "escaped key": b'{"request\\u005fid": "r1", "operation": "gates.test"}',
    "brackets in strings": _body(b'["[[[{{{", "]]]}}}", "\\"[", "\\\\"]'),
    f"nested {MAX_DEPTH} deep": _body(b"[" * (MAX_DEPTH - 2) + b"]" * (MAX_DEPTH - 2)),
    f"nested {MAX_DEPTH + 1} deep": _body(b"[" * (MAX_DEPTH - 1) + b"]" * (MAX_DEPTH - 1)),
    "nested 300 deep with escapes": _body(b'["\\"' + b'", ' + b"[" * 300 + b"]" * 300 + b"]"),
    "nested 300 deep in objects": _body(b'{"a": ' * 300 + b"1" + b"}" * 300),
    "nested 1000 deep": _body(b"[" * 1000 + b"]" * 1000),
    "nested 100000 deep": _body(b"[" * 10**5 + b"]" * 10**5),
    "deep brackets inside a string only": _body(b'"' + b"[" * 1000 + b'"'),
    "a list at the top": b"[" + _body(b"{}") + b"]",
    "a number at the top": b"42",
    "empty": b"",
    "whitespace around": b" \n\t" + _body(b"{}") + b"\r\n ",
    "raw not text": HEAD + b'"raw": [1]}',
    "raw null": HEAD + b'"raw": null}',
    "raw text": HEAD + b'"raw": "{\\"gate\\": "}',
    "replay_of an id": HEAD + b'"body": {}, "replay_of": "abc"}',
    "replay_of null": HEAD + b'"body": {}, "replay_of": null}',
    "replay_of a number": HEAD + b'"body": {}, "replay_of": 5}',
    "request id with a space": b'{"request_id": "a b", "operation": "gates.test"}',
    "no operation": b'{"request_id": "a"}',
    "another operation": b'{"request_id": "a", "operation": "solves.noise"}',
    "operation null": b'{"request_id": "a", "operation": null}',
}


@pytest.mark.parametrize("data", list(DIFFERENCES.values()), ids=list(DIFFERENCES))
def test_requests_get_the_reference_verdict(data):
    _check("request", data)


RESPONSE = b'{"request_id": "r1", "operation": "gates.test", "status": '
RESPONSES = {
    "200 with a result": RESPONSE + b'200, "duration_s": 0.5, "result": {"a": [1, 2]}}',
    "200 with a null result": RESPONSE + b'200, "duration_s": 0, "result": null}',
    "200 without a result": RESPONSE + b'200, "duration_s": 0.5}',
    "a float status": RESPONSE + b'200.0, "duration_s": 0.5, "result": 1}',
    "a boolean duration": RESPONSE + b'200, "duration_s": true, "result": 1}',
    "an infinite duration": RESPONSE + b'200, "duration_s": 1e999, "result": 1}',
    "a negative duration": RESPONSE + b'200, "duration_s": -0.0, "result": 1}',
    "a huge integer duration": RESPONSE + b'200, "duration_s": ' + b"9" * 40 + b', "result": 1}',
    "422 with a problem": RESPONSE
    + b'422, "duration_s": 1, "error": {"type": "t", "title": "t", "status": 422, '
    b'"detail": "d \\"quoted\\" [x]"}}',
    "422 without a problem": RESPONSE + b'422, "duration_s": 1}',
    "422 with a list": RESPONSE + b'422, "duration_s": 1, "error": [1]}',
    "status twice": RESPONSE + b'200, "status": "x", "duration_s": 1, "result": 1}',
    "a result nested too deep": RESPONSE
    + b'200, "duration_s": 1, "result": '
    + b"[" * 300
    + b"]" * 300
    + b"}",
}


@pytest.mark.parametrize("data", list(RESPONSES.values()), ids=list(RESPONSES))
def test_responses_get_the_reference_verdict(data):
    _check("response", data)


def test_one_deep_message_among_many_is_found_and_only_it():
    """The nesting is screened over all the messages together: the screen fires for the
    batch, and the verdicts still fall message by message."""
    shallow = _body(b'{"covariance": [[1, 0], [0, 1]], "s": "]]]]"}')
    deep = _body(b"[" * 400 + b"]" * 400)
    texts = [shallow] * 50 + [deep] + [shallow] * 50
    verdicts = check_messages([("request", "gates.test", t) for t in texts])
    assert [isinstance(v, str) for v in verdicts] == [False] * 50 + [True] + [False] * 50
    assert verdicts[50] == f"JSON nested deeper than {MAX_DEPTH} levels"


def test_the_integer_limit_is_the_interpreters():
    """json's limit on an integer's digits is the interpreter's setting, and so is the
    check's: with no limit, 5000 digits are a number like any other."""
    data = _body(b"7" * 5000)
    limit = sys.get_int_max_str_digits()
    try:
        sys.set_int_max_str_digits(0)
        [verdict] = check_messages([("request", "gates.test", data)])
        assert isinstance(verdict, Envelope)
        _agree("request", data, verdict)
    finally:
        sys.set_int_max_str_digits(limit)


JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**30), max_value=10**30)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner),
    max_leaves=30,
)


@settings(max_examples=300, deadline=None)
@given(JSON, st.booleans())
def test_any_body_reads_back_as_json_reads_it(body, ascii_only):
    data = _body(json.dumps(body, ensure_ascii=ascii_only).encode())
    _check("request", data)


@settings(max_examples=500, deadline=None)
@given(st.data())
def test_any_damage_gets_the_reference_verdict(data):
    """A valid message with bytes changed, cut or inserted: the same verdict either way."""
    body = data.draw(JSON)
    text = bytearray(_body(json.dumps(body).encode()))
    for _ in range(data.draw(st.integers(1, 3))):
        at = data.draw(st.integers(0, len(text)))
        byte = data.draw(st.sampled_from(b'[]{}",:\\0123456789eE.-+ \x00\xffNaIfinty'))
        action = data.draw(st.sampled_from(["set", "insert", "cut"]))
        if action == "insert" or at == len(text):
            text.insert(at, byte)
        elif action == "set":
            text[at] = byte
        else:
            del text[at:]
    _check("request", bytes(text))


USUAL_REQUEST = HEAD + b'"body": {"covariance": [[1, 0], [0, 1]]}}'
USUAL_RESPONSE = RESPONSE + b'200, "duration_s": 0.5, "result": {"inside": [true]}}'
ONE_AMONG_USUAL = [("request", text) for text in DIFFERENCES.values()] + [
    ("response", text) for text in RESPONSES.values()
]


@pytest.mark.parametrize("kind, text", ONE_AMONG_USUAL)
def test_one_unusual_message_in_a_usual_batch_gets_its_own_verdict(kind, text):
    """A batch is checked together (its screens, its envelopes) only while every message is
    usual: one that is not, anywhere in it, gets the reference verdict, the others theirs."""
    usual = [("request", USUAL_REQUEST), ("response", USUAL_RESPONSE)] * 3
    batch = usual[:3] + [(kind, text)] + usual[3:]
    verdicts = check_messages([(k, "gates.test", t) for k, t in batch])
    for (k, t), verdict in zip(batch, verdicts, strict=True):
        _agree(k, t, verdict)


def test_a_usual_batch_is_checked_together_with_the_verdicts_of_one_by_one():
    ids = [b"r1", b"a.b:c-D_9", b"x" * 128]
    batch = [
        (kind, text.replace(b'"r1"', b'"' + rid + b'"'))
        for rid in ids
        for kind, text in (("request", USUAL_REQUEST), ("response", USUAL_RESPONSE))
    ]
    verdicts = check_messages([(k, "gates.test", t) for k, t in batch])
    assert all(isinstance(v, Envelope) for v in verdicts)
    for (k, t), verdict in zip(batch, verdicts, strict=True):
        _agree(k, t, verdict)
        assert [verdict] == check_messages([(k, "gates.test", t)])


@pytest.mark.parametrize("rid", ["a\nb", "ab\n", "a b", "x" * 129, "", "r\u00e9"])
def test_request_ids_the_bulk_check_does_not_take_are_judged_one_by_one(rid):
    """The ids of a batch are matched together, a newline after each: an id the pattern
    refuses, or one holding or ending with a newline (which the pattern's ``$`` takes), gets
    the verdict it gets alone."""
    text = USUAL_REQUEST.replace(b'"r1"', json.dumps(rid).encode())
    batch = [("request", USUAL_REQUEST), ("request", text)]
    verdicts = check_messages([(k, "gates.test", t) for k, t in batch])
    for (k, t), verdict in zip(batch, verdicts, strict=True):
        _agree(k, t, verdict)
