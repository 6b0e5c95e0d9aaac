"""No request model has an untyped field: a validated body is strict JSON.

The service embeds a validated request body verbatim in its JSON recording, so it must
know every value in it is typed: pydantic's JSON parser lets NaN and Infinity tokens (and
anything else) into an ``Any`` field, and an untyped object or array carries them too.
"""

import pytest

from plotgate.service.table import ENDPOINTS

TYPING = {"type", "$ref", "anyOf", "oneOf", "allOf", "enum", "const"}


def untyped(schema, path: str = "") -> list[str]:
    """Paths of the sub-schemas of a JSON schema that admit any value."""
    if schema is True or not isinstance(schema, dict) or not TYPING & set(schema):
        return [path or "(root)"]
    found = []
    for key in ("anyOf", "oneOf", "allOf", "prefixItems"):
        for i, sub in enumerate(schema.get(key, [])):
            found += untyped(sub, f"{path}/{key}[{i}]")
    for name, sub in schema.get("properties", {}).items():
        found += untyped(sub, f"{path}.{name}")
    for name, sub in schema.get("$defs", {}).items():
        found += untyped(sub, f"$defs.{name}")
    if schema.get("type") == "array" and "items" not in schema and "prefixItems" not in schema:
        found.append(f"{path}[] (array of anything)")
    if "items" in schema:
        found += untyped(schema["items"], f"{path}[]")
    if schema.get("type") == "object":
        extra = schema.get("additionalProperties", True if "properties" not in schema else None)
        if extra is True:
            found.append(f"{path}{{}} (object of anything)")
        elif isinstance(extra, dict):
            found += untyped(extra, f"{path}{{}}")
    return found


@pytest.mark.parametrize("name", sorted(ENDPOINTS))
def test_every_request_field_is_typed(name):
    schema = ENDPOINTS[name].request.model_json_schema()
    assert untyped(schema) == [], f"{name}: untyped fields"


@pytest.mark.parametrize(
    ("schema", "expected"),
    [
        ({"type": "object", "properties": {"state": {"description": "anything"}}}, [".state"]),
        (
            {
                "type": "object",
                "properties": {"s": {"type": "object", "additionalProperties": True}},
            },
            [".s{} (object of anything)"],
        ),
        (
            {
                "type": "object",
                "properties": {
                    "s": {
                        "anyOf": [
                            {"type": "object", "additionalProperties": True},
                            {"type": "null"},
                        ]
                    }
                },
            },
            [".s/anyOf[0]{} (object of anything)"],
        ),
        ({"type": "object", "properties": {"a": {"type": "array"}}}, [".a[] (array of anything)"]),
        ({"type": "object", "properties": {"a": {"type": "array", "items": {}}}}, [".a[]"]),
        (
            {
                "type": "object",
                "properties": {"a": {"type": "array", "items": {"type": "number"}}},
                "additionalProperties": False,
            },
            [],
        ),
    ],
    ids=["any", "dict-of-any", "optional-dict-of-any", "bare-array", "array-of-any", "typed"],
)
def test_the_walk_finds_untyped_fields(schema, expected):
    assert untyped(schema) == expected
