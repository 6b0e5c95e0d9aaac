"""Every default a request takes is in the OpenAPI schema: a field a client may omit
states the value it then has (null where null means "derived", as its description says)."""

from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.table import ENDPOINTS


def _requests_and_their_parts(spec: dict) -> dict[str, dict]:
    """The component schemas reachable from the operations' request bodies."""
    components = spec["components"]["schemas"]
    reached: dict[str, dict] = {}
    todo = [ep.request.__name__ for ep in ENDPOINTS.values()]
    while todo:
        name = todo.pop()
        if name in reached or name not in components:
            continue
        reached[name] = components[name]
        text = str(components[name])
        todo += [part.split("'")[0] for part in text.split("#/components/schemas/")[1:]]
    return reached


def test_every_optional_request_field_has_its_default_in_openapi(settings):
    with TestClient(create_app(settings)) as client:
        spec = client.get("/openapi.json").json()
    missing = [
        f"{name}.{prop}"
        for name, schema in _requests_and_their_parts(spec).items()
        for prop, described in schema.get("properties", {}).items()
        if prop not in schema.get("required", []) and "default" not in described
    ]
    assert missing == []


def test_the_combined_gate_states_its_gating_probability(settings):
    with TestClient(create_app(settings)) as client:
        spec = client.get("/openapi.json").json()
    assert spec["components"]["schemas"]["CombinedGate"]["properties"]["P_G"]["default"] == 0.9
