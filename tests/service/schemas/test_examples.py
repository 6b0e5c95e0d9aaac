"""Every operation has a small valid example request: it validates against the request
model, answers 200 through the app, and is the request body's example in the OpenAPI
schema (what /docs shows and Schemathesis sends)."""

import json

import pytest

from plotgate.service.registry import OPERATIONS
from plotgate.service.table import ENDPOINTS
from tests.support.requests import answer

EXAMPLES = {name: e.example for name, e in ENDPOINTS.items()}


def test_every_operation_has_an_example():
    assert set(EXAMPLES) == set(ENDPOINTS) == set(OPERATIONS)


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_example_is_valid_and_answers_200(client, name):
    op = OPERATIONS[name]
    example = op.endpoint.example
    # strictly, as the service validates (a JSON true is not 1, "5" is not 5)
    op.request.model_validate_json(json.dumps(example), strict=True)
    body = answer(client.post(op.path, json=example))
    op.response.model_validate(body)


def test_example_is_a_copy():
    endpoint = ENDPOINTS["gates.test"]
    endpoint.example["gate"]["tau"] = -1.0
    assert endpoint.example == EXAMPLES["gates.test"]
    assert EXAMPLES["gates.test"]["gate"]["tau"] == 5.0


def test_openapi_shows_each_example(client):
    spec = client.get("/openapi.json").json()
    for op in OPERATIONS.values():
        media = spec["paths"][op.path]["post"]["requestBody"]["content"]["application/json"]
        assert media["example"] == EXAMPLES[op.name]
