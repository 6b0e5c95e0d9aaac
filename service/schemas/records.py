"""Envelopes of the MCAP records: one request and one response message per exchange.

Topic ``<operation>/request`` carries :class:`RequestRecord`, topic ``<operation>/response``
carries :class:`ResponseRecord`; the two share ``request_id``. A request body that is
strict JSON is kept as ``body`` (even when it later fails validation); any other body is
kept verbatim as ``raw`` text so replay can send the same bytes again. A request sent by
``plotgate replay`` carries a new id of its own and names the exchange it replays in
``replay_of``.

Each channel's JSON schema (:func:`request_schema`, :func:`response_schema`) is the
envelope with the operation's own models embedded: ``body`` is the request model,
``result`` the response model, ``error`` the problem, each as its own schema (not a union
with "anything" or null), so a viewer such as Foxglove lists every field of them.
"""

from typing import Any, Generic, TypeVar

from pydantic import BaseModel, Field

from plotgate.service.schemas.common import Problem

__all__ = [
    "REQUEST_ID_PATTERN",
    "RequestRecord",
    "ResponseRecord",
    "request_schema",
    "response_schema",
]

REQUEST_ID_PATTERN = r"^[A-Za-z0-9._:-]{1,128}$"
"""Request ids the service takes from ``X-Request-ID`` (otherwise it makes one), and the
ids ``X-Plotgate-Replay-Of`` may name."""

Req = TypeVar("Req")
Resp = TypeVar("Resp")


class RequestRecord(BaseModel, Generic[Req]):
    """What arrived: written before the request is processed."""

    request_id: str = Field(pattern=REQUEST_ID_PATTERN)
    operation: str
    replay_of: str | None = Field(
        default=None,
        pattern=REQUEST_ID_PATTERN,
        description="For a replay (X-Plotgate-Replay-Of): the request id of the exchange "
        "it replays.",
    )
    body: Req | None = Field(default=None, description="The JSON body as received.")
    raw: str | None = Field(default=None, description="The body when it was not JSON.")


class ResponseRecord(BaseModel, Generic[Resp]):
    """What was answered: written, and flushed, before the answer is sent."""

    request_id: str = Field(pattern=REQUEST_ID_PATTERN)
    operation: str
    status: int = Field(description="HTTP status of the answer.")
    duration_s: float = Field(description="Time from arrival to the result, s.")
    result: Resp | None = Field(default=None, description="The answer, when it succeeded.")
    error: Problem | None = Field(default=None, description="The problem, when it failed.")


def _embedded(envelope: type[BaseModel], models: dict[str, type[BaseModel]]) -> dict[str, Any]:
    """The envelope's JSON schema with each named property replaced by its model's schema
    (their definitions merged into the envelope's ``$defs``)."""
    schema = envelope.model_json_schema()
    defs = schema.pop("$defs", {})
    for name, model in models.items():
        own = model.model_json_schema()
        for key, value in own.pop("$defs", {}).items():
            if defs.setdefault(key, value) != value:
                raise ValueError(f"two different models named {key} in {envelope.__name__}")
        own["description"] = schema["properties"][name]["description"]
        schema["properties"][name] = own
    if defs:
        schema["$defs"] = defs
    return schema


def request_schema(request: type[BaseModel]) -> dict[str, Any]:
    """JSON schema of an operation's request channel: ``body`` is ``request``'s schema."""
    return _embedded(RequestRecord, {"body": request})


def response_schema(response: type[BaseModel]) -> dict[str, Any]:
    """JSON schema of an operation's response channel: ``result`` is ``response``'s schema,
    ``error`` the problem's."""
    return _embedded(ResponseRecord, {"result": response, "error": Problem})
