"""Errors say what to do: a missing tag names its choices, an unknown path points at /docs
and the nearest operation, another method names the one to use."""

import pytest

from plotgate.service.table import ENDPOINTS
from plotgate.service.tags import choices_at

PLOT = {"frame": "cartesian", "x": 0, "y": 0, "covariance": [[1, 0], [0, 1]]}


def _problem(response, status: int) -> dict:
    assert response.status_code == status, response.text
    assert response.headers["content-type"] == "application/problem+json"
    return response.json()


def test_a_plot_without_frame_names_the_frames(client):
    body = {"gate": {"kind": "ellipse"}, "first": {"x": 0, "y": 0}, "candidates": [PLOT]}
    problem = _problem(client.post("/v1/gates/test", json=body), 422)
    assert problem["errors"] == [
        {"field": "first", "reason": "missing 'frame': 'cartesian' or 'polar'"}
    ]


def test_an_unknown_frame_names_the_frames(client):
    body = {"gate": {"kind": "ellipse"}, "first": PLOT, "candidates": [{"frame": "pol"}]}
    problem = _problem(client.post("/v1/gates/test", json=body), 422)
    assert problem["errors"][0]["field"] == "candidates[0]"
    assert problem["errors"][0]["reason"] == (
        "'frame' is 'pol', not one of the choices: 'cartesian' or 'polar'"
    )


def test_a_gate_without_kind_names_the_kinds_of_that_operation(client):
    body = dict(ENDPOINTS["gates.design"].example)
    body["gate"] = {k: v for k, v in body["gate"].items() if k != "kind"}
    problem = _problem(client.post("/v1/gates/design", json=body), 422)
    assert problem["errors"][0] == {
        "field": "gate",
        "reason": "missing 'kind': 'combined' or 'expanded'",
    }


@pytest.mark.parametrize("name", sorted(ENDPOINTS))
def test_every_discriminated_union_of_the_requests_names_its_choices(name):
    """Each tagged union in a request's OpenAPI schema is found by its error location."""
    request = ENDPOINTS[name].request
    for loc, tag in _tagged_locations(request.model_json_schema()):
        found = choices_at(request, loc)
        assert found is not None and found[0] == tag and len(found[1]) >= 2, (name, loc)


def _tagged_locations(schema: dict) -> list[tuple[tuple, str]]:
    """The error locations of the discriminated unions reachable in ``schema`` (list items
    as index 0, union members by their tag), one per union."""
    defs = schema.get("$defs", {})
    found: list[tuple[tuple, str]] = []
    seen: set[str] = set()

    def walk(node: dict, loc: tuple) -> None:
        while "$ref" in node:
            ref = node["$ref"].rsplit("/", 1)[-1]
            if ref in seen:
                return
            seen.add(ref)
            node = defs[ref]
        if "discriminator" in node:
            tag = node["discriminator"]["propertyName"]
            found.append((loc, tag))
            for value, ref in node["discriminator"]["mapping"].items():
                walk({"$ref": ref}, (*loc, value))
            return
        for options in ("anyOf", "oneOf", "allOf"):
            for option in node.get(options, []):
                walk(option, loc)
        if "items" in node:
            walk(node["items"], (*loc, 0))
        for key, prop in node.get("properties", {}).items():
            walk(prop, (*loc, key))

    walk(schema, ())
    return found


def test_an_unknown_path_points_at_the_docs_and_the_nearest_operation(client):
    problem = _problem(client.post("/v1/gates/tset", json={}), 404)
    assert problem["type"] == "urn:plotgate:problem:not-found"
    assert "did you mean POST /v1/gates/test?" in problem["detail"]
    assert "/docs" in problem["detail"]
    far = _problem(client.get("/nothing/here"), 404)
    assert "did you mean" not in far["detail"] and "/docs" in far["detail"]


def test_another_method_on_a_route_is_a_problem_naming_the_method_to_use(client):
    problem = _problem(client.post("/healthz"), 405)
    assert problem["type"] == "urn:plotgate:problem:method-not-allowed"
    assert "use GET" in problem["detail"]
