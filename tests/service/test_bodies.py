"""Sizing up bodies before parsing them: the value count is an upper bound, every operation
has a finite ceiling, structurally absurd bodies are refused on ``body`` without a parse,
and the request record keeps any body exactly."""

import json
import random

import pytest

from plotgate.service.bodies import (
    MAX_BODY_VALUES,
    SLICE_BYTES,
    ShapeScan,
    is_strict_json,
    shape_problem,
    value_ceiling,
    value_count,
)
from plotgate.service.recording import request_record
from plotgate.service.registry import OPERATIONS, execute, parse
from tests.support.requests import GOOD


def _values(value: object) -> int:
    """The exact number of JSON values in a decoded document."""
    if isinstance(value, list):
        return 1 + sum(_values(v) for v in value)
    if isinstance(value, dict):
        return 1 + sum(_values(v) for v in value.values())
    return 1


def _document(rng: random.Random, depth: int = 0) -> object:
    kind = rng.randrange(6 if depth < 4 else 3)
    if kind == 0:
        return rng.uniform(-1e6, 1e6)
    if kind == 1:
        return rng.choice(["", "a,b", "[{", 'x\\"y', "é"])
    if kind == 2:
        return rng.choice([True, None, 0])
    if kind in (3, 4):
        return [_document(rng, depth + 1) for _ in range(rng.randrange(4))]
    return {f"k{i}": _document(rng, depth + 1) for i in range(rng.randrange(4))}


def test_value_count_bounds_the_true_count_from_above():
    rng = random.Random(12)
    for _ in range(500):
        document = _document(rng)
        body = json.dumps(document, indent=rng.choice([None, 1])).encode()
        assert _values(document) <= value_count(body)
    assert value_count(b"[]") == 2 and value_count(b"[1,2,3]") == 4  # the bound is tight


def test_the_ceiling_counts_every_field_and_list_at_its_longest():
    gates_test = value_ceiling(OPERATIONS["gates.test"].request)
    # the object; the gate (at most 6: first_association's object, kind and 4 numbers); the
    # first plot and 100,000 candidates, each at most 14 (a Cartesian plot: object, frame,
    # x, y, the covariance's 7 and the sensor's 3)
    assert gates_test == 1 + 6 + 14 + (1 + 100_000 * 14)
    assert value_count(json.dumps(GOOD).encode()) <= gates_test
    for op in OPERATIONS.values():
        assert 1 < value_ceiling(op.request) <= MAX_BODY_VALUES, op.name


@pytest.mark.parametrize(
    "body",
    [
        b'{"gate": [' + b"{}," * 2_000_000 + b"{}]}",
        b'{"candidates": [' + b"0," * 3_000_000 + b"0]}",
    ],
)
def test_a_body_with_more_values_than_any_valid_request_is_refused_unparsed(body):
    op = OPERATIONS["gates.test"]
    outcome = execute(op, body)
    assert outcome.status == 422 and outcome.json()["errors"][0]["field"] == "body"
    assert "JSON values" in outcome.json()["detail"]


def test_a_megabyte_without_structure_is_refused_and_a_shorter_run_is_not():
    assert shape_problem(b'{"a": "' + b"x" * SLICE_BYTES * 2 + b'"}', 10) is not None
    assert shape_problem(b'{"a": "' + b"x" * (SLICE_BYTES // 2) + b'"}', 10) is None
    assert shape_problem(b" " * (3 * SLICE_BYTES) + b"[]", 10) is not None


@pytest.mark.parametrize(
    "body",
    [
        json.dumps(GOOD).encode(),  # strict JSON, valid
        json.dumps(dict(GOOD, extra="NaN")).encode(),  # strict JSON holding the letters
        b'{"gate": NaN}',
        b'{"gate": -Infinity}',  # JSON to pydantic, not strict JSON
        b'{"gate": 1e400}',  # strict JSON (a number too large for a double)
        b'{"gate": 1',
        b"\xff\xfe",
        b'"\\u0001 \\" \\\\"',
        b'{"gate": "caf\xc3\xa9"}',
        b"",
    ],
)
def test_parsing_once_tells_strict_json_as_a_full_check_would(body):
    parsed = parse(OPERATIONS["gates.test"], body)
    assert parsed.json == is_strict_json(body)
    record = json.loads(request_record("r", "gates.test", body, parsed.json))
    if parsed.json:
        assert record["body"] == json.loads(body)
    else:
        assert record["raw"] == body.decode("utf-8", "backslashreplace")


def _unbounded_lists(node: object, path: str = "") -> list[str]:
    """Where a JSON schema has an array without maxItems."""
    found = []
    if isinstance(node, dict):
        if node.get("type") == "array" and "items" in node and "maxItems" not in node:
            found.append(path)
        for key, value in node.items():
            found += _unbounded_lists(value, f"{path}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            found += _unbounded_lists(value, f"{path}/{i}")
    return found


def test_every_list_of_every_request_has_a_longest():
    for op in OPERATIONS.values():
        assert _unbounded_lists(op.request.model_json_schema()) == [], op.name


def test_scanning_piece_by_piece_refuses_as_scanning_the_whole_body():
    rng = random.Random(5)
    shapes = [b"{}", b"[]", b"0", b'"k":0', b" " * 5000, b"x" * 70_000]
    for _ in range(200):
        body = b",".join(rng.choice(shapes) for _ in range(rng.randrange(1, 400)))
        ceiling = rng.choice([10, 100, 1000, 10_000])
        whole = shape_problem(body, ceiling)
        scan = ShapeScan(ceiling)
        cuts = sorted(rng.sample(range(len(body) + 1), min(len(body) + 1, 5)))
        pieces = [body[a:b] for a, b in zip([0, *cuts], [*cuts, len(body)], strict=True)]
        streamed = None
        for piece in pieces:
            streamed = scan.feed(piece)
        assert streamed == whole
    long_run = b"[" + b" " * (SLICE_BYTES // 2) + b"1" * (SLICE_BYTES // 2 + 2) + b"]"
    assert shape_problem(long_run, 10) is not None  # a run across two pieces
