"""The operations as the service runs them, from the table of declarations.

Each :class:`Operation` is one declaration of :data:`plotgate.service.table.ENDPOINTS`
(name, HTTP path, request and response models) with its pure handler ``(request) ->
response`` that calls core, and its field map. Handlers are imported when first used
(:class:`Operation`); the service imports them all before it answers (:func:`load_all`).

:func:`execute` runs an operation on a raw request body exactly as the HTTP route does,
so an in-process replay answers byte for byte what the server would.
"""

import functools
import importlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ValidationError

from plotgate.core import PlotgateError
from plotgate.service.bodies import is_strict_json, shape_problem, value_ceiling
from plotgate.service.cluster import ClusterTimeout, ClusterUnavailable, workers
from plotgate.service.fields import FieldMap, resolve
from plotgate.service.problems import ProblemError, from_core, from_validation, problem_json
from plotgate.service.schemas import MEMORY_BUDGET_MIB, TIME_BUDGET_S, Endpoint, FieldError
from plotgate.service.table import ENDPOINTS

__all__ = [
    "OPERATIONS",
    "Operation",
    "Outcome",
    "Parsed",
    "check_limits",
    "execute",
    "failed",
    "internal_error",
    "load_all",
    "misshapen",
    "over_caps",
    "parse",
    "run",
]

Handler = Callable[[Any], BaseModel]
"""A pure function from a validated request model to a response model."""


@dataclass(frozen=True)
class Operation:
    """One declaration as the service runs it: its handler and error-field mapping.

    The handler's module, and with it the part of core it calls (its kernels, scipy), is
    imported when the handler or its field map is first asked for, so a process that runs
    one operation (a replay of gate tests, a ``call``) does not wait for all of them.
    """

    endpoint: Endpoint

    @functools.cached_property
    def handler(self) -> Handler:
        """The pure function answering the operation (importing its module)."""
        handler: Handler = self.endpoint.handler.load()
        return handler

    @functools.cached_property
    def fields(self) -> FieldMap:
        """Where core's errors point in the request (:mod:`plotgate.service.fields`)."""
        fields: FieldMap = self.endpoint.fields.load()
        return fields

    @property
    def module(self) -> str:
        """The module of :mod:`plotgate.service.operations` holding the handler."""
        return self.endpoint.handler.module

    @property
    def name(self) -> str:
        return self.endpoint.name

    @property
    def path(self) -> str:
        return self.endpoint.path

    @property
    def request(self) -> type[BaseModel]:
        return self.endpoint.request

    @property
    def response(self) -> type[BaseModel]:
        return self.endpoint.response


OPERATIONS: dict[str, Operation] = {name: Operation(e) for name, e in ENDPOINTS.items()}
"""Every operation of the table, by name."""


def load_all() -> None:
    """Import every operation's handler, and so every compiled kernel of core: what the
    service does before it answers, so that no request pays for an import or a
    compilation."""
    for op in OPERATIONS.values():
        importlib.import_module(op.module)


@dataclass(frozen=True)
class Outcome:
    """The answer to one request: HTTP status and JSON body (result or problem)."""

    status: int
    content: bytes
    error: ProblemError | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    def json(self) -> Any:
        return json.loads(self.content)


def check_limits(limits: Mapping[str, Mapping[str, int]]) -> None:
    """Refuse (ValueError) caps for unknown operations or sizes, or below 1."""
    for name, caps in limits.items():
        if name not in OPERATIONS:
            raise ValueError(f"PLOTGATE_LIMITS: no operation {name!r}")
        for size, cap in caps.items():
            if size not in OPERATIONS[name].endpoint.work:
                sizes = ", ".join(OPERATIONS[name].endpoint.work) or "none"
                raise ValueError(f"PLOTGATE_LIMITS: {name} has no size {size!r} (it has: {sizes})")
            if cap < 1:
                raise ValueError(f"PLOTGATE_LIMITS: {name}.{size} must be >= 1, got {cap}")


def over_caps(op: Operation, request: BaseModel, caps: Mapping[str, int]) -> ProblemError | None:
    """The 422 refusing ``request`` for the first work size over its cap in ``caps``, or None.

    Work sizes are read from the validated request alone, so this runs before any work. The
    problem names the size as its field and says whether the cap is the operation's default
    (:attr:`~plotgate.service.schemas.Endpoint.caps`, set to a memory and time budget), an
    operator's, or a cluster's.

    A default cap that a Dask cluster widens (:attr:`~plotgate.service.schemas.Endpoint.
    cluster_caps`, the chunked operations) is widened only when the request passes it and
    the process has a cluster: only then is the scheduler asked for its worker threads
    (:func:`plotgate.service.cluster.workers`), so a request within the one-core caps never
    waits for it. An operator's cap (``PLOTGATE_LIMITS``) is never widened: it is the
    operator's word, cluster or not.

    Raises
    ------
    ClusterUnavailable
        The request needs the cluster's cap and the scheduler cannot be reached, or reports
        no workers (503 with ``Retry-After``, as the work itself would be).
    """
    for size, cap in caps.items():
        value = op.endpoint.work[size](request)
        if value <= cap:
            continue
        origin = _cap_origin(op, size, cap)
        if size in op.endpoint.cluster_caps and op.endpoint.caps[size] == cap:
            threads = workers()
            if threads == 0:  # workers may join: the cluster is unavailable, not too small
                raise ClusterUnavailable(
                    f"{size} is {value}, over the one-core cap {cap}, and the Dask scheduler "
                    "reports no workers to widen it"
                )
            if threads is None:
                origin += f"; {_on_a_cluster(op, size)}"
            else:
                cap = op.endpoint.cluster_cap(size, threads)
                if value <= cap:
                    continue
                origin = _cluster_origin(op, size, threads)
        reason = f"is {value}; this server allows at most {cap} ({origin})"
        return ProblemError(
            "invalid-input", 422, f"{size}: {reason}", [FieldError(field=size, reason=reason)]
        )
    return None


def _cap_origin(op: Operation, size: str, cap: int) -> str:
    if op.endpoint.caps.get(size) == cap:
        return (
            f"the default, which bounds one request's work (under {MEMORY_BUDGET_MIB} MiB of "
            f"memory and {TIME_BUDGET_S:g} s on one core); PLOTGATE_LIMITS sets another"
        )
    return "PLOTGATE_LIMITS"


def _per_thread(op: Operation, size: str) -> int:
    return op.endpoint.cluster_cap(size, 1)


def _on_a_cluster(op: Operation, size: str) -> str:
    return (
        f"a Dask cluster (PLOTGATE_DASK_SCHEDULER, --dask, --local-workers) takes "
        f"{_per_thread(op, size)} per worker thread, at most {op.endpoint.cluster_caps[size]}"
    )


def _cluster_origin(op: Operation, size: str, threads: int) -> str:
    return (
        f"the cluster's cap: {_per_thread(op, size)} per worker thread x the {threads} its "
        f"scheduler reports, at most {op.endpoint.cluster_caps[size]}, the ceiling of the "
        "results gathered in the service"
    )


@dataclass(frozen=True)
class Parsed:
    """A request body parsed once: the validated request, or the problem refusing it, and
    whether the body is strict JSON (recorded as ``body``; anything else as ``raw`` text)."""

    request: BaseModel | None
    problem: ProblemError | None
    json: bool


def parse(op: Operation, body: bytes, *, sized_up: bool = False) -> Parsed:
    """Size up ``body`` (:func:`plotgate.service.bodies.shape_problem`) and validate it, once.

    A body holding more JSON values than any valid request of the operation could, or a
    megabyte without JSON structure, is refused (422 on ``body``) before anything is built
    from it; ``sized_up`` says the caller already scanned it so as it arrived. Bodies are
    validated strictly: a JSON ``true`` is not the number 1 and ``"5"`` is not 5, so what
    the OpenAPI schema refuses, the service refuses. Validation parses the JSON itself;
    pydantic's parser also takes ``NaN`` and ``Infinity`` tokens, so a body holding those
    letters is checked once more before it is called strict JSON.
    """
    if not sized_up:
        reason = shape_problem(body, value_ceiling(op.request))
        if reason is not None:
            return misshapen(reason)
    try:
        request = op.request.model_validate_json(body, strict=True)
    except ValidationError as exc:
        problem = from_validation(exc)
        return Parsed(None, problem, problem.kind != "malformed-json" and _strict_json(body))
    return Parsed(request, None, _strict_json(body))


def misshapen(reason: str) -> Parsed:
    """A body refused by its shape (:class:`plotgate.service.bodies.ShapeScan`): 422 on ``body``,
    recorded as raw text, as nothing was parsed."""
    problem = ProblemError(
        "invalid-input", 422, f"body: {reason}", [FieldError(field="body", reason=reason)]
    )
    return Parsed(None, problem, json=False)


def _strict_json(body: bytes) -> bool:
    """For a body pydantic parsed: True unless it holds a NaN or Infinity token."""
    return (b"NaN" not in body and b"Infinity" not in body) or is_strict_json(body)


def run(
    op: Operation,
    request: BaseModel,
    request_id: str | None = None,
    limits: Mapping[str, int] | None = None,
) -> Outcome:
    """Run a validated request and serialize the answer.

    Bad input (a server cap passed, core's errors) becomes an :class:`Outcome` whose content
    is an RFC 9457 problem naming the field (``instance`` is the operation's path). Anything
    else that escapes is a bug. ``limits`` are the caps on the operation's work sizes, checked
    before the handler runs: a server's are the defaults with ``PLOTGATE_LIMITS`` laid over
    them (:attr:`plotgate.service.config.Settings.limits`); None runs without any (in-process
    replay's ``--no-limits``).
    """
    try:
        try:
            over = over_caps(op, request, limits or {})
            if over is not None:
                raise over
            response = op.handler(request)
        except PlotgateError as exc:
            raise from_core(exc, resolve(op.fields, request, exc)) from exc
        except ClusterTimeout as exc:
            raise ProblemError("cluster-timeout", 504, str(exc)) from exc
        except ClusterUnavailable as exc:
            raise ProblemError("cluster-unavailable", 503, str(exc)) from exc
    except ProblemError as exc:
        return failed(op, exc, request_id)
    return Outcome(status=200, content=response.model_dump_json().encode())


def execute(
    op: Operation,
    body: bytes,
    request_id: str | None = None,
    limits: Mapping[str, int] | None = None,
) -> Outcome:
    """:func:`parse` then :func:`run`: what the HTTP route answers for ``body``, so an
    in-process replay answers byte for byte what the server would."""
    parsed = parse(op, body)
    if parsed.request is None:
        assert parsed.problem is not None
        return failed(op, parsed.problem, request_id)
    return run(op, parsed.request, request_id, limits)


def failed(op: Operation, err: ProblemError, request_id: str | None) -> Outcome:
    """The outcome of a refused request: ``err`` as a problem body."""
    return Outcome(err.status, problem_json(err, op.path, request_id), err)


def internal_error(op: Operation, request_id: str | None) -> Outcome:
    """The 500 answered when an operation raised something unexpected: a bug, never input
    (the route and in-process replay answer it alike)."""
    err = ProblemError("internal", 500, f"{op.name} failed unexpectedly; this is a bug")
    return failed(op, err, request_id)
