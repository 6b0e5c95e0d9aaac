"""Envelopes of the MCAP records: one request and one response message per exchange.

Topic ``<operation>/request`` carries :class:`RequestRecord`, topic ``<operation>/response``
carries :class:`ResponseRecord`; the two share ``request_id``. A request body that is
strict JSON is kept as ``body`` (even when it later fails validation); any other body is
kept verbatim as ``raw`` text so replay can send the same bytes again.
"""

from typing import Any, Generic, TypeVar

from pydantic import BaseModel, Field

from service.schemas.common import Problem

__all__ = ["RequestRecord", "ResponseRecord"]

Req = TypeVar("Req")
Resp = TypeVar("Resp")


class RequestRecord(BaseModel, Generic[Req]):
    """What arrived: written before the request is processed."""

    request_id: str
    operation: str
    body: Req | Any | None = Field(default=None, description="The JSON body as received.")
    raw: str | None = Field(default=None, description="The body when it was not JSON.")


class ResponseRecord(BaseModel, Generic[Resp]):
    """What was answered: written, and flushed, before the answer is sent."""

    request_id: str
    operation: str
    status: int = Field(description="HTTP status of the answer.")
    duration_s: float = Field(description="Time from arrival to the result, s.")
    result: Resp | None = None
    error: Problem | None = None
