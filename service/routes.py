"""HTTP routes: one POST route per registry operation, plus the unversioned ops routes.

Every operation route does the same five steps, in this order:

1. take the request id (``X-Request-ID`` if the caller sent a sane one, else a new one);
2. add the request record, raw body included, before anything can fail;
3. run :func:`service.registry.execute`: on the event loop for a small body (a thread
   hand-off costs more than a gate test of a few hundred plots), in a worker thread for a
   body over ``INLINE_BODY_BYTES`` or an operation whose endpoint is marked ``slow``
   (quadratures that take tenths of a second or more), so it does not stall the others;
4. add the response record and wait for the flush that hands it to the operating system;
5. answer (:class:`service.guards.RequestId` puts ``X-Request-ID`` on every response).

If the record cannot be written the answer is a 503 problem: nothing is acknowledged
unrecorded. With ``PLOTGATE_RECORD_BEST_EFFORT`` the exchange is answered anyway and
counted in ``plotgate_unrecorded_total``.
"""

import logging
import time
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool

from service.guards import request_id
from service.metrics import CONTENT_TYPE as METRICS_CONTENT_TYPE
from service.problems import ProblemError, problem_json
from service.recorder import Recorder, RecordingError, request_record, response_record
from service.registry import OPERATIONS, Operation, Outcome, execute
from service.schemas import Problem

__all__ = ["PROBLEM_JSON", "health_router", "operations_router", "request_id_of"]

log = logging.getLogger("plotgate")
PROBLEM_JSON = "application/problem+json"
INLINE_BODY_BYTES = 64 * 1024
"""Bodies up to this size are executed on the event loop, larger ones in a worker thread."""


def request_id_of(request: Request) -> str:
    """The request's id (:func:`service.guards.request_id`: the sane X-Request-ID or new)."""
    return request_id(request.scope)


def _run(op: Operation, body: bytes, request_id: str, limits: dict[str, int] | None) -> Outcome:
    try:
        return execute(op, body, request_id, limits)
    except Exception:
        log.exception("operation %s failed on request %s", op.name, request_id)
        err = ProblemError("internal", 500, f"{op.name} failed unexpectedly; this is a bug")
        return Outcome(500, problem_json(err, op.path, request_id), err)


def _unrecorded(op: Operation, request_id: str, exc: RecordingError) -> Response:
    err = ProblemError("recording-unavailable", 503, f"the exchange was not recorded: {exc}")
    content = problem_json(err, op.path, request_id)
    return Response(content, 503, media_type=PROBLEM_JSON)


def _endpoint(op: Operation):
    async def endpoint(request: Request) -> Response:
        request_id = request_id_of(request)
        recorder: Recorder | None = request.app.state.recorder
        best_effort: bool = request.app.state.settings.record_best_effort
        metrics = request.app.state.metrics
        started = time.perf_counter()
        body = await request.body()
        try:
            if recorder is not None:
                try:
                    recorder.request(op.name, request_record(request_id, op.name, body))
                except RecordingError:
                    if not best_effort:
                        raise
                    recorder = None  # best effort: answer this exchange unrecorded
                    metrics.unrecorded(op.name)
            limits = request.app.state.settings.limits.get(op.name)
            if len(body) <= INLINE_BODY_BYTES and not op.endpoint.slow:
                outcome = _run(op, body, request_id, limits)
            else:
                outcome = await run_in_threadpool(_run, op, body, request_id, limits)
            if recorder is not None:
                record = response_record(
                    request_id, op.name, outcome.status, time.perf_counter() - started,
                    outcome.content,
                )
                try:
                    await recorder.aresponse(op.name, record)
                except RecordingError:
                    if not best_effort:
                        raise
                    metrics.unrecorded(op.name)
        except RecordingError as exc:
            metrics.observe(op.name, 503, time.perf_counter() - started)
            return _unrecorded(op, request_id, exc)
        metrics.observe(op.name, outcome.status, time.perf_counter() - started)
        return Response(outcome.content, outcome.status,
                        media_type="application/json" if outcome.ok else PROBLEM_JSON)

    endpoint.__name__ = op.name.replace(".", "_")
    return endpoint


def operations_router() -> APIRouter:
    """One POST route per operation in the registry."""
    router = APIRouter()
    problems: dict[int | str, dict[str, Any]] = {
        status: {"model": Problem, "description": text}
        for status, text in (
            (400, "The body is not JSON."),
            (422, "A field is invalid; `errors` names each one."),
            (503, "The exchange could not be recorded, so it was refused."),
        )
    }
    for op in OPERATIONS.values():
        router.add_api_route(
            op.path,
            _endpoint(op),
            methods=["POST"],
            name=op.name,
            summary=op.endpoint.summary,
            tags=[op.endpoint.tag],
            operation_id=op.name,
            response_model=None,
            responses={200: {"model": op.response}, **problems},
            openapi_extra={
                "requestBody": {
                    "required": True,
                    "content": {
                        "application/json": {
                            "schema": {"$ref": f"#/components/schemas/{op.request.__name__}"}
                        }
                    },
                }
            },
        )
    return router


def health_router() -> APIRouter:
    """``/healthz`` (the process answers), ``/readyz`` (and it can record), ``/metrics``."""
    router = APIRouter(tags=["ops"])

    @router.get("/healthz", summary="Liveness: the process answers")
    async def healthz() -> dict[str, str]:
        return {"status": "ok"}

    @router.get("/readyz", summary="Readiness: requests can be answered and recorded")
    async def readyz(request: Request) -> Response:
        recorder: Recorder | None = request.app.state.recorder
        if recorder is None or recorder.probe():
            return Response('{"status":"ready"}', 200, media_type="application/json")
        err = ProblemError("recording-unavailable", 503, "the recorder cannot write")
        return Response(problem_json(err, "/readyz"), 503, media_type=PROBLEM_JSON)

    @router.get("/metrics", summary="Prometheus metrics: requests, latencies, recorder",
                response_class=Response,
                responses={200: {"content": {"text/plain": {"schema": {"type": "string"}}},
                                 "description": "Prometheus text exposition format."}})
    async def metrics(request: Request) -> Response:
        return Response(request.app.state.metrics.render(), 200,
                        media_type=METRICS_CONTENT_TYPE)

    return router
