"""What the recorder writes for viewers and for replay: each channel's schema embeds its
operation's own models (so Foxglove lists every field), and a replay is recorded as a
replay of its original."""

import pytest
from fastapi.testclient import TestClient

from plotgate.clients.recordings import read_recording
from plotgate.service.app import create_app
from plotgate.service.registry import OPERATIONS
from plotgate.service.schemas import Problem, request_schema, response_schema
from tests.support.requests import GOOD


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_each_channel_schema_embeds_its_models(name):
    op = OPERATIONS[name]
    request, response = request_schema(op.request), response_schema(op.response)
    for schema in (request, response):
        assert schema["type"] == "object" and "$ref" not in schema  # a self-contained object
    body = request["properties"]["body"]
    assert body["type"] == "object"
    assert body["properties"].keys() == op.request.model_json_schema()["properties"].keys()
    assert body["title"] == op.request.__name__
    result, error = response["properties"]["result"], response["properties"]["error"]
    assert result["properties"].keys() == op.response.model_json_schema()["properties"].keys()
    assert error["properties"].keys() == Problem.model_json_schema()["properties"].keys()
    definitions = {**request.get("$defs", {}), **response.get("$defs", {})}
    refs = _refs(request) | _refs(response)
    assert refs <= {f"#/$defs/{n}" for n in definitions}  # every reference resolves


def _refs(node) -> set[str]:
    if isinstance(node, dict):
        own = {node["$ref"]} if isinstance(node.get("$ref"), str) else set()
        return own.union(*(_refs(v) for v in node.values()))
    if isinstance(node, list):
        return set().union(*(_refs(v) for v in node))
    return set()


def test_the_independent_reader_sees_typed_bodies(settings, mcap_check):
    with TestClient(create_app(settings)) as c:
        assert c.post("/v1/gates/test", json=GOOD).status_code == 200
    [path] = settings.log_dir.glob("*.mcap")
    code, report = mcap_check(path, schemas=True)
    assert code == 0, report["errors"]
    schemas = {ch["topic"]: ch["schema"] for ch in report["channels"]}
    assert len(schemas) == 2 * len(OPERATIONS)
    body = schemas["gates.test/request"]["properties"]["body"]
    assert set(body["properties"]) == {"gate", "first", "candidates"}
    candidates = body["properties"]["candidates"]
    assert candidates["type"] == "array" and candidates["maxItems"] == 100_000
    result = schemas["gates.test/response"]["properties"]["result"]
    assert {"inside", "statistic", "threshold", "count_inside"} <= set(result["properties"])
    for name, op in OPERATIONS.items():
        typed = schemas[f"{name}/request"]["properties"]["body"]["properties"]
        assert set(typed) == set(op.request.model_fields), name


def test_a_replay_is_recorded_as_a_replay_of_its_original(settings):
    with TestClient(create_app(settings)) as c:
        for rid, replay_of in (
            ("first", None),
            ("again", "first"),
            ("odd", "not an id"),
            ("long", "x" * 200),
        ):
            headers = {"x-request-id": rid}
            if replay_of is not None:
                headers["x-plotgate-replay-of"] = replay_of
            assert c.post("/v1/gates/test", json=GOOD, headers=headers).status_code == 200
    [path] = settings.log_dir.glob("*.mcap")
    recorded = {ex.request_id: ex.request for ex in read_recording(path).exchanges}
    assert recorded["again"]["replay_of"] == "first"
    assert "replay_of" not in recorded["first"]
    assert "replay_of" not in recorded["odd"] and "replay_of" not in recorded["long"]
