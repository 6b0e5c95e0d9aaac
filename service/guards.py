"""ASGI guards in front of the routes: request ids, the body size limit, authentication.

* :class:`RequestId` (outermost) gives every request an id, the caller's
  ``X-Request-ID`` when it is sane (1-128 of [A-Za-z0-9._:-]) or a new one, keeps it in
  the request state for the routes and the recorder, and puts it on every response,
  health checks and refusals included.

* :class:`BodyLimit` answers 413 problem+json (field ``body``) for a body over
  ``Settings.max_body_bytes``: at once when ``Content-Length`` says so, or as soon as a
  streamed body passes the limit, so an oversized body is never held in memory. Such a
  request never reaches an operation, so it is not recorded (like a 404).
* :class:`Auth` requires, when ``Settings.api_key`` or ``Settings.bearer_token`` is set,
  an ``X-API-Key`` header or an ``Authorization: Bearer`` token on every path but the
  open ones (``/healthz``, ``/readyz``, the docs with their assets and the OpenAPI
  schema), checked by the one policy every listener shares
  (:meth:`plotgate.service.access.Keys.allows`, in constant time); anything else answers
  401 problem+json with ``WWW-Authenticate``. Keys in the URL are not taken here: a URL
  ends up in logs. The recorder writes request bodies only, never
  headers, so the key is never recorded.
"""

import re
import uuid
from collections.abc import Awaitable, Callable, MutableMapping, Sequence
from typing import Any

from starlette.datastructures import Headers

from plotgate.service.access import Keys
from plotgate.service.problems import ProblemError, problem_json
from plotgate.service.schemas import REQUEST_ID_PATTERN, FieldError

__all__ = [
    "OPEN_PATHS",
    "OPEN_PREFIX",
    "Auth",
    "BodyLimit",
    "RequestId",
    "replay_of",
    "request_id",
    "route_path",
]

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

OPEN_PATHS = frozenset(
    {"/healthz", "/readyz", "/docs", "/docs/oauth2-redirect", "/redoc", "/openapi.json"}
)
"""Paths that stay open when authentication is on."""
OPEN_PREFIX = "/docs/assets/"
"""And the docs' scripts, styles and icon under this prefix."""


_SANE_ID = re.compile(REQUEST_ID_PATTERN)


def route_path(scope: Scope) -> str:
    """The request's path below the app's ``root_path`` (``--root-path /api``, or the app
    mounted under a prefix): what the routes are matched against, as Starlette does."""
    path: str = scope.get("path", "")
    root: str = scope.get("root_path", "")
    return path[len(root) :] if root and path.startswith(root) else path


def request_id(scope: Scope) -> str:
    """The request's id: set by :class:`RequestId`, else the sane header or a new one."""
    state = scope.get("state") or {}
    if "request_id" in state:
        return str(state["request_id"])
    given = Headers(scope=scope).get("x-request-id") or ""
    return given if _SANE_ID.match(given) else uuid.uuid4().hex


def replay_of(scope: Scope) -> str | None:
    """For a request sent by ``plotgate replay``: the id of the exchange it replays (the
    ``X-Plotgate-Replay-Of`` header, when it is a sane id); None otherwise."""
    given = Headers(scope=scope).get("x-plotgate-replay-of") or ""
    return given if _SANE_ID.match(given) else None


class RequestId:
    """Give every request an id and every response its X-Request-ID header."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        rid = request_id(scope)
        scope.setdefault("state", {})["request_id"] = rid

        async def tagged(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = [h for h in message.get("headers", ()) if h[0] != b"x-request-id"]
                message["headers"] = [*headers, (b"x-request-id", rid.encode())]
            await send(message)

        await self.app(scope, receive, tagged)


async def _problem(
    send: Send, scope: Scope, err: ProblemError, extra: Sequence[tuple[bytes, bytes]] = ()
) -> None:
    body = problem_json(err, scope.get("path", ""), request_id(scope))
    headers = [
        (b"content-type", b"application/problem+json"),
        (b"content-length", str(len(body)).encode()),
        *extra,
    ]
    await send({"type": "http.response.start", "status": err.status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class _TooLarge(Exception):
    pass


class BodyLimit:
    """Refuse request bodies over ``max_bytes`` with 413 problem+json."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    def _error(self, size: str) -> ProblemError:
        reason = f"is {size} bytes; at most {self.max_bytes} (PLOTGATE_MAX_BODY_BYTES)"
        return ProblemError(
            "payload-too-large", 413, f"body: {reason}", [FieldError(field="body", reason=reason)]
        )

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = Headers(scope=scope).get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.max_bytes:
            await _problem(send, scope, self._error(declared))
            return
        received = 0

        async def counted() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    raise _TooLarge
            return message

        try:
            await self.app(scope, counted, send)
        except _TooLarge:
            await _problem(send, scope, self._error(f"more than {received - 1}"))


class Auth:
    """Require an API key or a bearer token on every path but :data:`OPEN_PATHS`."""

    def __init__(self, app: ASGIApp, keys: Keys) -> None:
        self.app = app
        self.keys = keys

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        path = route_path(scope)
        if (
            scope["type"] != "http"
            or path in OPEN_PATHS
            or path.startswith(OPEN_PREFIX)
            or self.keys.allows(Headers(scope=scope))
        ):
            await self.app(scope, receive, send)
            return
        reason = f"is missing or wrong: send {' or '.join(self.keys.ways())}"
        err = ProblemError(
            "unauthorized",
            401,
            f"credentials: {reason}",
            [FieldError(field="credentials", reason=reason)],
        )
        challenge = (
            b'Bearer realm="plotgate"' if self.keys.bearer_token else b'ApiKey realm="plotgate"'
        )
        await _problem(send, scope, err, [(b"www-authenticate", challenge)])
