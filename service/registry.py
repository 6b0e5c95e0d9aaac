"""The operation registry: the one table that routes, recorder and replay all read.

Each :class:`Operation` binds a wire contract (:class:`~plotgate.service.schemas.Endpoint`: name
such
as ``gates.test``, HTTP path, request and response models) to a pure handler
``(request) -> response`` that calls core. Adding a capability means declaring its endpoint
in :mod:`plotgate.service.schemas.endpoints` and adding one line to ``_HANDLERS``.

:func:`execute` runs an operation on a raw request body exactly as the HTTP route does,
so an in-process replay answers byte for byte what the server would.
"""

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ValidationError

from plotgate.core import PlotgateError
from plotgate.service.bodies import is_strict_json, shape_problem, value_ceiling
from plotgate.service.cluster import ClusterTimeout, ClusterUnavailable
from plotgate.service.fields import FieldMap, resolve
from plotgate.service.operations import (
    gates,
    identification,
    initiation,
    probability,
    solves,
    study,
)
from plotgate.service.problems import ProblemError, from_core, from_validation, problem_json
from plotgate.service.schemas import ENDPOINTS, MEMORY_BUDGET_MIB, Endpoint, FieldError

__all__ = [
    "OPERATIONS",
    "Operation",
    "Outcome",
    "Parsed",
    "check_limits",
    "execute",
    "failed",
    "internal_error",
    "misshapen",
    "over_caps",
    "parse",
    "run",
]

Handler = Callable[[Any], BaseModel]
"""A pure function from a validated request model to a response model."""


@dataclass(frozen=True)
class Operation:
    """One capability: its wire contract, handler and error-field mapping."""

    endpoint: Endpoint
    handler: Handler
    fields: FieldMap
    """Where core's errors point in the request (:mod:`plotgate.service.fields`)."""

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


_HANDLERS: dict[str, tuple[Handler, FieldMap]] = {
    "gates.test": (gates.test, gates.TEST_FIELDS),
    "gates.pairs": (gates.pairs, gates.PAIRS_FIELDS),
    "gates.probability": (probability.probability, probability.PROBABILITY_FIELDS),
    "gates.probability_curve": (probability.curve, probability.CURVE_FIELDS),
    "gates.analysis": (probability.analysis, probability.ANALYSIS_FIELDS),
    "gates.design": (probability.design, probability.DESIGN_FIELDS),
    "solves.position": (solves.position, solves.POSITION_FIELDS),
    "solves.trajectory": (solves.trajectory, solves.TRAJECTORY_FIELDS),
    "solves.crlb": (solves.crlb, solves.CRLB_FIELDS),
    "solves.noise": (solves.noise, solves.NOISE_FIELDS),
    "solves.study": (study.study, study.STUDY_FIELDS),
    "initiation.initiate": (initiation.initiate, initiation.INITIATE_FIELDS),
    "initiation.simulate": (initiation.simulate, initiation.SIMULATE_FIELDS),
    "initiation.evaluate": (initiation.evaluate, initiation.EVALUATE_FIELDS),
    "identification.pair": (identification.pair, identification.PAIR_FIELDS),
    "identification.picture": (identification.picture, identification.PICTURE_FIELDS),
    "identification.simulate": (identification.simulate, identification.SIMULATE_FIELDS),
}

OPERATIONS: dict[str, Operation] = {
    name: Operation(ENDPOINTS[name], handler, fields)
    for name, (handler, fields) in _HANDLERS.items()
}


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
    (:attr:`~plotgate.service.schemas.Endpoint.caps`, set to a memory budget) or an
    operator's.
    """
    for size, cap in caps.items():
        value = op.endpoint.work[size](request)
        if value > cap:
            reason = f"is {value}; this server allows at most {cap} ({_cap_origin(op, size, cap)})"
            return ProblemError(
                "invalid-input", 422, f"{size}: {reason}", [FieldError(field=size, reason=reason)]
            )
    return None


def _cap_origin(op: Operation, size: str, cap: int) -> str:
    if op.endpoint.caps.get(size) == cap:
        return (
            f"the default, which bounds one request's work (under {MEMORY_BUDGET_MIB} MiB of "
            "memory); PLOTGATE_LIMITS sets another"
        )
    return "PLOTGATE_LIMITS"


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
        over = over_caps(op, request, limits or {})
        if over is not None:
            raise over
        try:
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
