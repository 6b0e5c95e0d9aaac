"""HTTP routes: the operations, answered as pure ASGI, plus the unversioned ops routes.

Every operation (:class:`Operations`) does the same steps, in this order:

1. take the request id (``X-Request-ID`` if the caller sent a sane one, else a new one);
2. receive the body within ``PLOTGATE_BODY_TIMEOUT_S`` (408 after it, recorded);
3. parse it once (:func:`plotgate.service.registry.parse`: sized up against the operation's
   value ceiling as it arrives, then validated) and run the operation
   (:func:`plotgate.service.offload.outcome`): a small body on the event loop (an
   operation whose endpoint is marked ``slow`` runs in a worker thread), a body over
   ``INLINE_BODY_BYTES`` in the worker process of :mod:`plotgate.service.offload`, parse,
   run and answer's encoding alike, so a large body never stalls the loop;
4. add the request record (the body as it came: embedded when it is strict JSON, as text
   otherwise), before running a small body's operation, with the answer for a large one;
5. add the response record and wait for the flush that hands both records to the operating
   system;
6. with a live view (``--foxglove-port``), offer both records to its bounded queue, which
   never waits (:mod:`plotgate.service.scenes.live`);
7. answer (:class:`plotgate.service.guards.RequestId` puts ``X-Request-ID`` on every response).

If the records cannot be written the answer is a 503 problem with ``Retry-After``: nothing
is acknowledged unrecorded. With ``PLOTGATE_RECORD_BEST_EFFORT`` the exchange is answered
anyway and counted in ``plotgate_unrecorded_total``.
"""

import asyncio
import json
import logging
import math
import time
from collections.abc import Awaitable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from starlette.datastructures import State

from plotgate.service.bodies import (
    BodyRefused,
    BodyTimeout,
    ClientGone,
    ShapeScan,
    read_body,
    value_ceiling,
)
from plotgate.service.cluster import Cancellable
from plotgate.service.config import Settings
from plotgate.service.guards import (
    ASGIApp,
    Receive,
    Scope,
    Send,
    replay_of,
    request_id,
    route_path,
)
from plotgate.service.metrics import CONTENT_TYPE as METRICS_CONTENT_TYPE
from plotgate.service.offload import INLINE_BODY_BYTES, LargeBodies, outcome
from plotgate.service.problems import ProblemError, problem_json
from plotgate.service.recording import (
    Exchange,
    Recorder,
    RecordingError,
    request_record,
    response_record,
)
from plotgate.service.registry import (
    OPERATIONS,
    Operation,
    Outcome,
    Parsed,
    misshapen,
    parse,
)
from plotgate.service.schemas import FieldError
from plotgate.service.warmup import readiness

if TYPE_CHECKING:  # foxglove-sdk is imported only with a live view
    from plotgate.service.scenes.live import LiveView

_T = TypeVar("_T")

__all__ = ["PROBLEM_JSON", "Operations", "health_router", "request_id_of", "retry_after"]

log = logging.getLogger("plotgate")
PROBLEM_JSON = "application/problem+json"

Header = tuple[bytes, bytes]


def request_id_of(request: Request) -> str:
    """The request's id (:func:`plotgate.service.guards.request_id`: the sane X-Request-ID or
    new)."""
    return request_id(request.scope)


def retry_after(settings: Settings) -> str:
    """``Retry-After`` of a 503, whole seconds: the recorder's probe interval, after which a
    folder that came back is writable again."""
    return str(math.ceil(settings.probe_interval_s))


def _timed_out(exc: BodyTimeout) -> Parsed:
    reason = (
        f"did not arrive within {exc.deadline_s:g} s ({len(exc.received)} bytes "
        "received; PLOTGATE_BODY_TIMEOUT_S)"
    )
    err = ProblemError(
        "request-timeout", 408, f"body: {reason}", [FieldError(field="body", reason=reason)]
    )
    return Parsed(None, err, json=False)


@dataclass
class _Received:
    """A request's body as it arrived, with the problem refusing it when it could not be
    read whole or its shape is refused, and whether to close the connection after
    answering (the body was not read to its end)."""

    body: bytes
    refused: Parsed | None
    close: bool
    large: bool = field(init=False)
    """Over ``INLINE_BODY_BYTES``: parsed in the worker process, its record copied in a
    thread."""

    def __post_init__(self) -> None:
        self.large = len(self.body) > INLINE_BODY_BYTES


class Operations:
    """The operations, as pure ASGI: ``POST`` on a registry path is answered here.

    It sits inside the guards (:mod:`plotgate.service.guards`) and in front of FastAPI's
    router, which serves everything else (health, metrics, the docs, 404). Measured with
    ``bench/bench_service.py``, FastAPI's routing, dependency solving and exception layers
    cost about 85 us per request, a quarter of a gate test's whole cost; answering here
    spends none of it. Another method on an operation path answers 405 with ``Allow:
    POST``. The OpenAPI description of these paths is built from the same registry
    (:mod:`plotgate.service.openapi`).
    """

    def __init__(self, app: ASGIApp, state: State) -> None:
        self.app = app
        self.state = state
        self.operations = {op.path: op for op in OPERATIONS.values()}
        self.large_bodies: LargeBodies = state.large_bodies

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        path = route_path(scope)
        op = self.operations.get(path)
        if op is None and path.endswith("/") and path[:-1] in self.operations:
            await _redirect(send, scope, path[:-1])  # as FastAPI's router did
            return
        if op is None:
            await self.app(scope, receive, send)
            return
        if scope["method"] != "POST":
            err = ProblemError("method-not-allowed", 405, "Method Not Allowed")
            body = problem_json(err, op.path, request_id(scope))
            await _send(send, 405, body, [(b"allow", b"POST")])
            return
        status, content, headers = await self._exchange(op, scope, receive)
        await _send(send, status, content, headers)

    async def _exchange(
        self, op: Operation, scope: Scope, receive: Receive
    ) -> tuple[int, bytes, list[Header]]:
        """One exchange, the steps of this module's docstring: status, body, headers."""
        rid = request_id(scope)
        settings: Settings = self.state.settings
        started = time.perf_counter()
        arrived = time.time_ns()  # the live view's stamp of the exchange
        received = await self._receive_body(op, receive)
        if received is None:
            return 499, b"", []  # nobody to answer, nothing acknowledged
        limits = settings.limits.get(op.name)
        parsed, answer, strict = await self._parse(op, received, rid, limits)
        asked = await self._request_record(op, received, strict, rid, replay_of(scope))
        received.body = b""  # the record holds it from here on
        try:
            answer, told = await self._answer_recorded(
                op, asked, parsed, answer, rid, limits, receive, started
            )
        except RecordingError as exc:
            self.state.metrics.observe(op.name, 503, time.perf_counter() - started)
            err = ProblemError(
                "recording-unavailable", 503, f"the exchange was not recorded: {exc}"
            )
            return 503, problem_json(err, op.path, rid), [self._retry_after()]
        self.state.metrics.observe(op.name, answer.status, time.perf_counter() - started)
        live: LiveView | None = self.state.live
        if live is not None:  # after the records are flushed: the picture never delays them
            live.offer(op.name, arrived, asked, told)
        headers = [(b"connection", b"close")] if received.close else []
        if answer.status == 503:  # the cluster: try again after the recorder's probe
            headers.append(self._retry_after())
        return answer.status, answer.content, headers

    async def _receive_body(self, op: Operation, receive: Receive) -> "_Received | None":
        """Step 2: the body within ``PLOTGATE_BODY_TIMEOUT_S``, sized up as it arrives; a
        body cut off by its deadline or refused by its shape comes with its problem, and
        None when the client went away (nobody to answer)."""
        settings: Settings = self.state.settings
        try:
            body = await read_body(
                receive, settings.body_timeout_s, ShapeScan(value_ceiling(op.request))
            )
        except ClientGone:
            return None
        except BodyTimeout as exc:
            return _Received(exc.received, _timed_out(exc), close=True)
        except BodyRefused as exc:
            return _Received(exc.received, misshapen(exc.reason), close=not exc.drained)
        return _Received(body, None, close=False)

    async def _parse(
        self, op: Operation, received: "_Received", rid: str, limits: dict[str, int] | None
    ) -> tuple[Parsed | None, Outcome | None, bool]:
        """Step 3's parse: a small body (or a refused one: nothing to parse) parsed here, a
        large one parsed, run and answered in the worker process. The parsed request, the
        answer when it is known already, and whether the body is strict JSON."""
        if received.refused is None and received.large:
            work = self.large_bodies.answer(op, received.body, rid, limits)
            answered = await self._before_stopping(work)
            # cut off by the shutdown: recorded as text, as its parse never came back
            strict, answer = answered or (False, _stopping(op, rid))
            return None, answer, strict
        parsed = received.refused or parse(op, received.body, sized_up=True)
        return parsed, None, parsed.json

    async def _request_record(
        self, op: Operation, received: "_Received", strict: bool, rid: str, replay: str | None
    ) -> bytes:
        """Step 4's record of the request (empty when nothing records nor shows it)."""
        if self.state.recorder is None and self.state.live is None:
            return b""
        if received.large:  # a copy of every byte: tens of milliseconds for the largest
            return await run_in_threadpool(
                request_record, rid, op.name, received.body, strict, replay
            )
        return request_record(rid, op.name, received.body, strict, replay)

    async def _answer_recorded(
        self,
        op: Operation,
        asked: bytes,
        parsed: Parsed | None,
        answer: Outcome | None,
        rid: str,
        limits: dict[str, int] | None,
        receive: Receive,
        started: float,
    ) -> tuple[Outcome, bytes]:
        """Steps 4 and 5: add the request record, run a small body's operation, add the
        response record and wait for both to be flushed. The answer and the response's
        record (empty when nothing records nor shows it).

        Raises
        ------
        RecordingError
            A record could not be written (and ``PLOTGATE_RECORD_BEST_EFFORT`` is off).
        """
        recorder: Recorder | None = self.state.recorder
        exchange = None if recorder is None else await self._record_request(op, recorder, asked)
        try:
            if answer is None:
                assert parsed is not None
                answer = await self._answer_small(op, parsed, rid, limits, receive)
            told = b""
            if exchange is not None or self.state.live is not None:
                elapsed = time.perf_counter() - started
                told = response_record(rid, op.name, answer.status, elapsed, answer.content)
            if recorder is not None and exchange is not None:
                await self._record_response(op, recorder, exchange, told)
        finally:
            if recorder is not None and exchange is not None:
                recorder.forget(exchange)
        return answer, told

    async def _record_request(
        self, op: Operation, recorder: Recorder, record: bytes
    ) -> Exchange | None:
        """Step 4: the request's record added; None when best effort answers this exchange
        unrecorded (counted)."""
        try:
            return await recorder.arequest(op.name, record)
        except RecordingError:
            if not self.state.settings.record_best_effort:
                raise
            self.state.metrics.unrecorded(op.name)  # best effort: answered unrecorded
            return None

    async def _record_response(
        self, op: Operation, recorder: Recorder, exchange: Exchange, record: bytes
    ) -> None:
        """Step 5: the response's record added and both flushed to the operating system."""
        try:
            await recorder.aresponse(exchange, record)
        except RecordingError:
            if not self.state.settings.record_best_effort:
                raise
            self.state.metrics.unrecorded(op.name)

    async def _answer_small(
        self,
        op: Operation,
        parsed: Parsed,
        rid: str,
        limits: dict[str, int] | None,
        receive: Receive,
    ) -> Outcome:
        """A small body's answer: on the event loop (a thread hand-off costs more than a
        gate test of a few hundred plots), in a worker thread for an operation whose
        endpoint is marked ``slow`` (quadratures that take tenths of a second or more, and
        release the interpreter in compiled kernels).

        A slow operation's batch work is cancelled when its client goes away before the
        answer (:class:`plotgate.service.cluster.Cancellable`: its chunks on the cluster
        and the next chunk in this process) or at the end of the graceful shutdown. The
        exchange is still recorded: as 499 ``client-disconnected`` (nginx's "client closed
        request"), an answer nobody received, so a replay or an audit sees the request was
        given up rather than missing. Only a small body's operation is watched: a large
        body's runs in the worker process of :mod:`plotgate.service.offload`."""
        if parsed.request is None or not op.endpoint.slow:
            return outcome(op, parsed, rid, limits)
        cancellable = Cancellable()
        gone = asyncio.ensure_future(_disconnect(receive))
        try:
            work = run_in_threadpool(cancellable.run, outcome, op, parsed, rid, limits)
            answer = await self._before_stopping(work, gone)
        finally:
            gone.cancel()
        if answer is not None:
            return answer
        cancellable.cancel()
        if gone.done() and not gone.cancelled():
            return _client_gone(op, rid)
        return _stopping(op, rid)

    async def _before_stopping(
        self, work: Awaitable[_T], gone: "asyncio.Future[None] | None" = None
    ) -> _T | None:
        """``work``'s result, or None when the server reaches the end of its graceful
        shutdown first (:func:`plotgate.service.app.create_app` sets ``stopping`` a second
        before uvicorn would cancel this request and answer a bare 500, unrecorded), or
        ``gone`` (the client's disconnect) comes first. The wait for a thread's work is not
        cancelled: a thread cannot be stopped, and cancelling the wait for one would wait
        for it; its result is dropped."""
        stopping: asyncio.Event = self.state.stopping
        if stopping.is_set():  # too late to start it
            if asyncio.iscoroutine(work):
                work.close()
            return None
        task = asyncio.ensure_future(work)
        waiter = asyncio.ensure_future(stopping.wait())
        await asyncio.wait(
            {task, waiter} | ({gone} if gone is not None else set()),
            return_when=asyncio.FIRST_COMPLETED,
        )
        waiter.cancel()
        if task.done():
            return task.result()
        task.add_done_callback(_drop)
        return None

    def _retry_after(self) -> Header:
        return b"retry-after", retry_after(self.state.settings).encode()


async def _disconnect(receive: Receive) -> None:
    """Return when the client disconnects: after the whole body, the only message left for
    a request is ``http.disconnect`` (sent when the connection closes, or by the server
    once the response is complete)."""
    while (await receive())["type"] != "http.disconnect":
        pass


def _client_gone(op: Operation, rid: str) -> Outcome:
    """The exchange of a client that went away before its answer: 499, recorded, sent to
    nobody."""
    err = ProblemError(
        "client-disconnected",
        499,
        "the client closed the connection before the answer: its work was cancelled",
    )
    return Outcome(499, problem_json(err, op.path, rid), err)


def _stopping(op: Operation, rid: str) -> Outcome:
    """The answer to a request the graceful shutdown cut off: 503, retried elsewhere."""
    err = ProblemError("shutting-down", 503, "the server is shutting down: send the request again")
    return Outcome(503, problem_json(err, op.path, rid), err)


def _drop(task: "asyncio.Future[Any]") -> None:
    """Take the outcome of work whose answer was given up, so asyncio logs nothing."""
    if not task.cancelled():
        task.exception()


async def _redirect(send: Send, scope: Scope, path: str) -> None:
    """307 to ``path`` (under the root path, the query kept): a trailing slash, as
    Starlette's ``redirect_slashes`` answers it, so a client follows with its body."""
    query = scope.get("query_string", b"")
    location = (scope.get("root_path", "") + path).encode() + (b"?" + query if query else b"")
    await send(
        {
            "type": "http.response.start",
            "status": 307,
            "headers": [(b"location", location), (b"content-length", b"0")],
        }
    )
    await send({"type": "http.response.body", "body": b""})


async def _send(send: Send, status: int, body: bytes, headers: list[Header]) -> None:
    """Answer ``body``: JSON below 400, problem+json from 400."""
    media_type = b"application/json" if status < 400 else PROBLEM_JSON.encode()
    start = [(b"content-type", media_type), (b"content-length", b"%d" % len(body)), *headers]
    await send({"type": "http.response.start", "status": status, "headers": start})
    await send({"type": "http.response.body", "body": body})


def health_router() -> APIRouter:
    """``/healthz`` (the process answers), ``/readyz`` (and it can record), ``/metrics``."""
    router = APIRouter(tags=["ops"])

    @router.get(
        "/healthz",
        summary="Liveness: the process answers",
        description='Answers `{"status": "ok"}` whenever the process runs its event '
        "loop, even while the heaviest legal request computes; for a liveness probe. Says "
        "nothing about recording: see `/readyz`.",
    )
    async def healthz() -> dict[str, str]:
        return {"status": "ok"}

    @router.get(
        "/readyz",
        summary="Readiness: requests can be answered and recorded",
        description='200 `{"status": "ready", "operations": {"ready": [...], "compiling": '
        "[...]}}` when an exchange can be recorded now "
        "(the recordings folder is writable and has room; always, with recording off); "
        "`operations` names the operations whose numerical kernels are loaded and those "
        "still compiling after a start with an empty cache (a request for one of those "
        "waits for it, it is not refused); "
        "else 503 problem+json with `Retry-After`, and the server recovers by itself. "
        "For a readiness probe: every operation answers 503 while this does.",
    )
    async def readyz(request: Request) -> Response:
        recorder: Recorder | None = request.app.state.recorder
        if recorder is None or recorder.probe():
            body = {"status": "ready", "operations": readiness(request.app.state.warmup)}
            return Response(json.dumps(body), 200, media_type="application/json")
        err = ProblemError("recording-unavailable", 503, "the recorder cannot write")
        return Response(
            problem_json(err, "/readyz"),
            503,
            {"retry-after": retry_after(request.app.state.settings)},
            media_type=PROBLEM_JSON,
        )

    @router.get(
        "/metrics",
        summary="Prometheus metrics: requests, latencies, recorder",
        description="Counters and histograms in the Prometheus text format: requests by "
        "operation and status, latencies in seconds, exchanges recorded, refused or "
        "answered unrecorded, and the recorder's state.",
        response_class=Response,
        responses={
            200: {
                "content": {"text/plain": {"schema": {"type": "string"}}},
                "description": "Prometheus text exposition format.",
            }
        },
    )
    async def metrics(request: Request) -> Response:
        return Response(request.app.state.metrics.render(), 200, media_type=METRICS_CONTENT_TYPE)

    return router
