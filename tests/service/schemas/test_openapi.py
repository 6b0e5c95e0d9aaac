"""The OpenAPI document explains itself: every operation has a description (with its
paper, units and an example request), and every property of every schema has one."""

import json
from collections.abc import Iterator
from typing import Any

import pytest

from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS


@pytest.fixture(scope="module")
def document(tmp_path_factory) -> dict[str, Any]:
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    settings = Settings(
        log_dir=tmp_path_factory.mktemp("rec"), git_commit="test", api_key="k" * 32
    )
    with TestClient(create_app(settings)) as client:
        answer = client.get("/openapi.json", headers={"X-API-Key": "k" * 32})
    assert answer.status_code == 200
    return answer.json()


def _operations(doc: dict[str, Any]) -> Iterator[tuple[str, dict[str, Any]]]:
    for path, item in doc["paths"].items():
        for method, operation in item.items():
            yield f"{method.upper()} {path}", operation


def _properties(schema: Any, where: str) -> Iterator[tuple[str, Any]]:
    """Every property of every object schema inside ``schema``, however deeply nested
    (inline objects, items, anyOf/oneOf/allOf branches), with its dotted place."""
    if isinstance(schema, dict):
        for name, sub in (schema.get("properties") or {}).items():
            yield f"{where}.{name}", sub
            yield from _properties(sub, f"{where}.{name}")
        for key, sub in schema.items():
            if key != "properties":
                yield from _properties(sub, where)
    elif isinstance(schema, list):
        for sub in schema:
            yield from _properties(sub, where)


def test_every_operation_has_a_description(document):
    bare = [name for name, op in _operations(document) if not op.get("description", "").strip()]
    assert bare == []


def test_every_property_has_a_description(document):
    places = [("components", document["components"]["schemas"]), ("paths", document["paths"])]
    found = [p for where, tree in places for p in _properties(tree, where)]
    assert len(found) > 400  # the walk reaches the schemas
    bare = [name for name, sub in found if not (isinstance(sub, dict) and sub.get("description"))]
    assert bare == []


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_each_registry_operation_cites_units_and_shows_its_example(document, name):
    op = OPERATIONS[name]
    text = document["paths"][op.path]["post"]["description"]
    assert text.startswith(op.endpoint.description)
    example = text.split("```json\n", 1)[1].split("\n```", 1)[0]
    assert json.loads(example) == op.endpoint.example
    assert op.request.model_validate(json.loads(example))  # the example is a valid request
    paper = ("Konovalov", "Fadeev", "Mu et al.", "Kvasnov", "textbook")
    assert any(author in text for author in paper), f"{name} cites no paper"
