"""The FastAPI application factory.

``create_app(settings)`` builds the app: the registry's operations under ``/v1``,
answered as pure ASGI (:class:`plotgate.service.routes.Operations`), ``/healthz``,
``/readyz`` and ``/metrics`` at the root, the docs served offline
(:mod:`plotgate.service.openapi`), RFC 9457 problem bodies for every error FastAPI or
Starlette raise themselves (404, 405, ...), the guards in front
(:mod:`plotgate.service.guards`, outermost first: request ids on every response,
authentication when a key or token is set, so an unauthenticated caller cannot make the
service read a body, then the body-size limit), and a lifespan that opens the MCAP
recorder on start and closes it (summary and index written) on shutdown, after stopping
the worker process that answers large bodies (:mod:`plotgate.service.offload`).
Run it with ``plotgate serve`` or ``uvicorn --factory service.app:create_app``.
"""

import asyncio
import difflib
import gc
import logging
import signal
import sys
import threading
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import asynccontextmanager
from types import FrameType
from typing import TYPE_CHECKING

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException

from plotgate.service.access import Keys, binding_refusal
from plotgate.service.cluster import cancel_calls, configure
from plotgate.service.config import Settings, get_settings
from plotgate.service.guards import Auth, BodyLimit, RequestId
from plotgate.service.logs import REDACT_QUERY
from plotgate.service.metrics import Metrics
from plotgate.service.offload import LargeBodies
from plotgate.service.openapi import ASSETS_PATH, assets_folder, docs_router, openapi
from plotgate.service.problems import ProblemError, field_errors, problem_json
from plotgate.service.provenance import VERSION, provenance
from plotgate.service.recording import Recorder, rotation_bytes
from plotgate.service.registry import OPERATIONS, check_limits
from plotgate.service.routes import PROBLEM_JSON, Operations, health_router, request_id_of
from plotgate.service.warmup import KernelsFirst, Warmup

if TYPE_CHECKING:  # foxglove-sdk is imported only with a live view
    from plotgate.service.scenes.live import LiveView

__all__ = ["create_app"]

log = logging.getLogger("plotgate")

_KINDS = {404: "not-found", 405: "method-not-allowed"}

_ANSWER_S = 1.0
"""Time left, at the end of the graceful shutdown, for the requests still computing to be
answered 503 and recorded, s: the cluster calls are cancelled then, the rest given up half
of it later."""


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the plotgate app; ``settings`` default to the ``PLOTGATE_*`` environment."""
    settings = settings or get_settings()
    check_limits(settings.limits)
    logging.getLogger("uvicorn.access").addFilter(REDACT_QUERY)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        recorder = None
        if settings.record:
            recorder = Recorder(
                settings.log_dir,
                OPERATIONS.values(),
                max_bytes=rotation_bytes(settings.rotate_bytes),
                max_age_s=settings.rotate_age_s,
                metadata=provenance(settings),
                on_flush=app.state.metrics.flush.observe,
                compaction_wait_s=settings.graceful_shutdown_s,
            ).start()
        app.state.recorder = recorder
        # listening now; the kernels load meanwhile, each request waiting for its own
        app.state.warmup = Warmup(_say, loaded=_freeze_again).start()
        app.state.live = _live_view(settings)
        configure(settings.dask_scheduler, settings.dask_timeout_s)
        if gc.get_freeze_count() == 0:
            # what start-up built lives as long as the process: keep it out of every
            # collection (measured: a 100,000-plot body validates in 0.42 s instead of
            # 0.73 s, and holds the interpreter that much less)
            gc.collect()
            gc.freeze()
        watch = None
        if recorder is not None:
            watch = asyncio.create_task(_watch(recorder, settings.probe_interval_s))
        app.state.stopping = asyncio.Event()
        restore_signals = _stop_within(settings.graceful_shutdown_s, app.state.stopping)
        try:
            yield
        finally:
            restore_signals()
            app.state.warmup.close()
            if watch is not None:
                watch.cancel()
            if app.state.live is not None:
                app.state.live.close()
            try:
                app.state.large_bodies.close()
            finally:  # the last file closed and compacted, whatever stopping the worker raised
                if recorder is not None:
                    recorder.close()
                configure(None)

    app = FastAPI(
        title="plotgate",
        version=VERSION,
        summary="Radar track initiation and target localization, every exchange recorded.",
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.recorder = None
    app.state.warmup = None
    app.state.live = None
    app.state.stopping = asyncio.Event()  # the lifespan makes its own, on its loop
    app.state.metrics = Metrics(lambda: app.state.recorder, lambda: app.state.live)
    app.state.large_bodies = LargeBodies(settings.dask_scheduler, settings.dask_timeout_s)
    app.include_router(health_router())
    app.include_router(docs_router(app.title))
    app.mount(ASSETS_PATH, StaticFiles(directory=assets_folder()), name="docs-assets")
    app.add_exception_handler(HTTPException, _http_problem)
    app.add_exception_handler(RequestValidationError, _validation_problem)
    app.openapi = lambda: openapi(app)  # type: ignore[method-assign]
    app.add_middleware(Operations, state=app.state)
    app.add_middleware(KernelsFirst, state=app.state)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    keys = Keys.from_settings(settings)
    if keys.required:
        app.add_middleware(Auth, keys=keys)
    app.add_middleware(RequestId)
    return app


def _say(text: str) -> None:
    """A line on the server's console (stderr), such as the kernels' warm-up progress."""
    print(f"plotgate: {text}", file=sys.stderr, flush=True)


def _freeze_again() -> None:
    """What the warm-up imported lives as long as the process, like what start-up built:
    out of every collection too (when start-up froze its own)."""
    if gc.get_freeze_count():
        gc.collect()
        gc.freeze()


def _live_view(settings: Settings) -> "LiveView | None":
    """The live view of ``--foxglove-port``, or None when it is off. One that cannot start
    (foxglove-sdk missing, the port taken) is logged and kept without a publisher: the
    service answers and records as ever, and counts the exchanges it could not show."""
    if settings.foxglove_port is None:
        return None
    try:
        from plotgate.service.scenes.live import LiveView
    except ImportError as exc:
        log.error("no live view: foxglove-sdk is missing (%s): pip install 'plotgate[view]'", exc)
        return None
    keys = Keys.from_settings(settings)
    refusal, warning = binding_refusal(
        "the live view", settings.foxglove_host, keys, settings.allow_unauthenticated
    )
    if refusal is not None:
        log.error("no live view: %s", refusal)
        return None
    if warning is not None:
        log.warning("%s", warning)
    live = LiveView(
        settings.foxglove_host, settings.foxglove_port, keys, settings.live_max_clients
    )
    try:
        live.start()
    except RuntimeError as exc:
        log.error("no live view: %s", exc)
        return live
    log.info("Foxglove live view on ws://%s:%d", settings.foxglove_host, live.port)
    return live


def _stop_within(grace_s: float, stopping: asyncio.Event) -> Callable[[], None]:
    """On SIGTERM or SIGINT, :data:`_ANSWER_S` before uvicorn's graceful shutdown
    (``grace_s``) runs out, cancel the cluster calls still in flight and set ``stopping``,
    so every request still computing (on the cluster, in a worker thread or in the
    large-body worker) is answered 503 and recorded, instead of being cancelled by uvicorn
    unrecorded (which answers a bare 500). uvicorn's own handler still runs first, and is
    put back on shutdown; the function returned does that. Outside the main thread (a
    test's client), or when no server handles the signals (their default: the process
    just ends), they are not ours to take.
    """
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT)}
    handlers = {sig: handler for sig, handler in previous.items() if callable(handler)}
    if len(handlers) < len(previous):
        return lambda: None
    loop = asyncio.get_running_loop()
    delay = max(grace_s - _ANSWER_S, 0.0)

    def stop() -> None:
        cancel_calls()
        # the cluster's callers answer cluster-unavailable first; what is left, shutting-down
        loop.call_later(_ANSWER_S / 2, stopping.set)

    def signalled(sig: int, frame: FrameType | None) -> None:
        handlers[signal.Signals(sig)](sig, frame)
        loop.call_soon_threadsafe(loop.call_later, delay, stop)

    for sig in previous:
        signal.signal(sig, signalled)

    def restore() -> None:
        for sig, handler in previous.items():
            signal.signal(sig, handler)

    return restore


async def _watch(recorder: Recorder, interval_s: float) -> None:
    """Probe the recorder's folder every ``interval_s``: a deleted folder is created again
    and readiness comes back by itself, with no traffic."""
    while True:
        await asyncio.sleep(interval_s)
        try:
            recorder.probe()
        except Exception:
            log.exception("the recorder's probe failed")


def _render(
    err: ProblemError, request: Request, headers: Mapping[str, str] | None = None
) -> Response:
    return Response(
        problem_json(err, request.url.path, request_id_of(request)),
        err.status,
        headers,
        media_type=PROBLEM_JSON,
    )


async def _http_problem(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    kind = _KINDS.get(exc.status_code, "invalid-input")
    detail = str(exc.detail)
    if exc.status_code == 404:
        detail = _not_found(request.method, request.url.path)
    elif exc.status_code == 405:
        allowed = (exc.headers or {}).get("Allow", "another method")
        detail = f"{request.url.path} does not take {request.method}: use {allowed} (see /docs)"
    # Starlette's own headers (405: Allow, as RFC 9110 requires) go out with the problem
    return _render(ProblemError(kind, exc.status_code, detail), request, exc.headers)


def _not_found(method: str, path: str) -> str:
    """What a 404 says: the path is none of the service's, the nearest operation path when
    one is close (a typo: ``/v1/gates/tset``), and where the list of them is."""
    paths = [op.path for op in OPERATIONS.values()]
    near = difflib.get_close_matches(path, paths, n=1, cutoff=0.8)
    hint = f"did you mean POST {near[0]}? " if near else ""
    return f"no route {method} {path}; {hint}every operation is listed at /docs"


async def _validation_problem(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, RequestValidationError)
    errors = field_errors(exc.errors())
    detail = "; ".join(f"{e.field}: {e.reason}" for e in errors)
    return _render(ProblemError("invalid-input", 422, detail, errors), request)
