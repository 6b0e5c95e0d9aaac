"""RFC 9457 problem details: the one place errors become HTTP answers.

Kinds of problem (the ``type`` member), each with its status:

- ``malformed-json`` (400): the body is not JSON;
- ``invalid-input`` (422): a field fails the schema or the mathematics (core's errors);
- ``unauthorized`` (401): authentication is on and the credentials are missing or wrong;
- ``not-found`` (404), ``method-not-allowed`` (405): no such route;
- ``payload-too-large`` (413): the body is over the size limit;
- ``request-timeout`` (408): the body did not arrive within the deadline;
- ``recording-unavailable`` (503): the exchange could not be recorded, so it is refused;
- ``cluster-unavailable`` (503): the Dask scheduler (``PLOTGATE_DASK_SCHEDULER``) cannot
  be reached;
- ``worker-lost`` (503): the worker process answering large bodies died (killed, out of
  memory) during the request; a fault, not an answer: send it again;
- ``workers-busy`` (503): the large-body worker's lane holds its bound of bodies
  (:data:`plotgate.service.offload.LANE_BODIES`);
- ``shutting-down`` (503): the server reached the end of its graceful shutdown
  (``PLOTGATE_GRACEFUL_SHUTDOWN_S``) before the operation finished; another replica, or
  this one restarted, will answer it;
- ``client-disconnected`` (499, nginx's "client closed request"): the client went away
  before the answer and its work was cancelled; recorded, sent to nobody;
- ``cluster-timeout`` (504): the work on the cluster did not finish within
  ``PLOTGATE_DASK_TIMEOUT_S`` (its tasks are cancelled; not worth retrying as it is);
- ``internal`` (500): a bug; never bad input.
"""

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ValidationError

from plotgate.core import PlotgateError
from plotgate.service.schemas import FieldError, Problem
from plotgate.service.table import ENDPOINTS
from plotgate.service.tags import tag_reason

__all__ = ["ProblemError", "field_errors", "from_core", "from_validation", "problem_json"]

PROBLEM_BASE = "urn:plotgate:problem:"
MAX_FIELD_ERRORS = 100
"""Most field errors one problem lists; ``detail`` counts the rest."""
TITLES = {
    "malformed-json": "Malformed JSON body",
    "invalid-input": "Invalid input",
    "unauthorized": "Unauthorized",
    "payload-too-large": "Payload too large",
    "request-timeout": "Request timeout",
    "not-found": "Not found",
    "method-not-allowed": "Method not allowed",
    "recording-unavailable": "Recording unavailable",
    "cluster-unavailable": "Cluster unavailable",
    "shutting-down": "Shutting down",
    "worker-lost": "Worker lost",
    "workers-busy": "Workers busy",
    "client-disconnected": "Client closed request",
    "cluster-timeout": "Cluster timeout",
    "internal": "Internal error",
}


@dataclass
class ProblemError(Exception):
    """An answer that is a problem: raised by operations, rendered by the service."""

    kind: str
    status: int
    detail: str
    errors: list[FieldError] = field(default_factory=list)

    def __str__(self) -> str:
        return self.detail


def problem_json(
    err: ProblemError, instance: str | None = None, request_id: str | None = None
) -> bytes:
    """Render a :class:`ProblemError` as an RFC 9457 JSON body (members left unset omitted)."""
    body = Problem(
        type=PROBLEM_BASE + err.kind,
        title=TITLES[err.kind],
        status=err.status,
        detail=err.detail,
        instance=instance,
        request_id=request_id,
        errors=err.errors,
    )
    return body.model_dump_json(exclude_none=True).encode()


def _path(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "body"


def field_errors(errors: Sequence[Any], model: type[BaseModel] | None = None) -> list[FieldError]:
    """Pydantic's (or FastAPI's) error dicts as field paths like ``candidates[3].r``; a
    missing or unknown tag of a discriminated union of ``model`` names the tag's choices
    (:func:`plotgate.service.tags.tag_reason`)."""
    return [
        FieldError(field=_path(tuple(e["loc"])), reason=tag_reason(e, model) or e["msg"])
        for e in errors
    ]


@functools.cache
def _requests() -> dict[str, type[BaseModel]]:
    return {ep.request.__name__: ep.request for ep in ENDPOINTS.values()}


def from_validation(exc: ValidationError) -> ProblemError:
    """Map pydantic's errors to field paths; a body that is not JSON is a 400. The
    request model is found by the error's title (its class name), so that a missing tag
    names its choices."""
    errors = exc.errors(include_url=False, include_input=False)
    if any(e["type"] == "json_invalid" for e in errors):
        reason = "; ".join(str(e.get("ctx", {}).get("error", e["msg"])) for e in errors)
        return ProblemError(
            "malformed-json",
            400,
            f"body is not valid JSON: {reason}",
            [FieldError(field="body", reason=reason)],
        )
    fields = field_errors(errors[:MAX_FIELD_ERRORS], _requests().get(exc.title))
    detail = "; ".join(f"{f.field}: {f.reason}" for f in fields)
    if len(errors) > MAX_FIELD_ERRORS:
        detail += f"; and {len(errors) - MAX_FIELD_ERRORS} more errors"
    return ProblemError("invalid-input", 422, detail, fields)


def from_core(exc: PlotgateError, field: str) -> ProblemError:
    """Map a core error to a 422 naming ``field``, the request path of the offending value."""
    return ProblemError(
        "invalid-input",
        422,
        f"{field}: {exc.reason}",
        [FieldError(field=field, reason=exc.reason)],
    )
