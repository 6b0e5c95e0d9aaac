"""Typed HTTP clients of plotgate, sync and async, built on httpx and the shared schemas.

Each operation of the table (:data:`plotgate.service.table.ENDPOINTS`) is reachable through
``call(name, request)``, and through the typed method its declaration names
(``client_method``: ``test_gate``, ``gate_probability``, ``solve_position``, ``initiate``,
``identify_pair`` ...), written once for both clients (:class:`TypedMethod`). Every typed method
but the gate tests' (``test_gate(gate, first, candidates)``, ``test_gate_pairs(gate,
pairs)``) takes its request model or the same as a dict (validated here, so a bad dict raises
pydantic's ``ValidationError`` before any call).
Errors are the exceptions of :mod:`plotgate.clients.errors`. The README shows a full example.

Both clients retry a 503 and a failed connection, with jittered exponential backoff (see
:class:`Client`): every operation is a pure function of its body, so sending one twice is
harmless.

Every failure is a :class:`~plotgate.clients.errors.PlotgateClientError`: no answer is a
``TransportError``, a problem answer a ``ProblemError``, and an answer that is not the
operation's (HTML, JSON cut short, the wrong schema, NaN where the schema has none, nesting
too deep) an ``InvalidResponseError``. Bodies are read in pieces and refused once they pass
``max_response_bytes`` (:data:`DEFAULT_MAX_RESPONSE_BYTES`), a ``ResponseTooLarge``: a
server, or something in its place, that streams without end costs the caller that much
memory and no more.
"""

import math
import re
import uuid
from asyncio import sleep as async_sleep
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass
from random import uniform
from time import monotonic, sleep
from typing import Any, Generic, ParamSpec, Protocol, TypeVar, overload

import httpx
from pydantic import BaseModel, ValidationError

from plotgate.clients.errors import (
    MESSAGE_CHARS,
    InvalidResponseError,
    ResponseTooLarge,
    TransportError,
    raise_for_problem,
)
from plotgate.service.schemas import (
    CrlbRequest,
    CrlbResult,
    Endpoint,
    EvaluateRequest,
    EvaluateResult,
    Gate,
    GateAnalysisRequest,
    GateAnalysisResult,
    GateDesignRequest,
    GateDesignResult,
    GatePair,
    GatePairsRequest,
    GateProbabilityCurve,
    GateProbabilityCurveRequest,
    GateProbabilityRequest,
    GateProbabilityResult,
    GateResults,
    GateTestRequest,
    IdentifyPairRequest,
    IdentifyPairResult,
    IdentifyPictureRequest,
    IdentifyPictureResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
    InitiateRequest,
    InitiateResult,
    NoiseRequest,
    NoiseResult,
    Plot,
    PositionSolveRequest,
    PositionSolveResult,
    SimulateRequest,
    SimulateResult,
    StudyRequest,
    StudyResult,
    TrajectorySolveRequest,
    TrajectorySolveResult,
)
from plotgate.service.table import ENDPOINTS

__all__ = [
    "DEFAULT_BACKOFF",
    "DEFAULT_BACKOFF_MAX",
    "DEFAULT_MAX_RESPONSE_BYTES",
    "DEFAULT_RETRIES",
    "DEFAULT_TIMEOUT",
    "DEFAULT_URL",
    "RETRIED_ERRORS",
    "SLOW_TIMEOUT",
    "AsyncClient",
    "Client",
    "parse_answer",
]

DEFAULT_URL = "http://127.0.0.1:8000"
DEFAULT_TIMEOUT = httpx.Timeout(30.0, connect=5.0)
"""No call can hang forever: 30 s for an answer's headers, 30 s more for its whole body
(however slowly it trickles), 5 s to connect."""
SLOW_TIMEOUT = httpx.Timeout(600.0, connect=5.0)
"""For operations whose endpoint is marked ``slow`` (quadratures, gate design)."""
DEFAULT_RETRIES = 3
"""Retries after the first attempt: four requests at most."""
DEFAULT_BACKOFF = 0.5
"""Seconds: the longest wait before the first retry, doubled for each one after it."""
DEFAULT_BACKOFF_MAX = 30.0
"""Seconds: no wait between attempts is longer, whatever the doubling or ``Retry-After``."""
DEFAULT_MAX_RESPONSE_BYTES = 2**27
"""The largest answer body a client reads, decoded (128 MiB); past it the call raises
``ResponseTooLarge``.

The service sets no cap on the size of its answers; its default work caps bound them. The
largest is ``identification.picture`` at its cap of 2,500,000 track pairs
(``passive_deg x active_deg``): about 45 bytes of JSON a pair (measured at 200 x 200), some
112 MB, under this cap. 128 MiB is also the largest record plotgate's own MCAP readers hold
(``plotgate.clients.mcap_reader.MAX_RECORD_BYTES``): an answer over it could not be replayed
either. Other operations' largest answers are far below it (measured: a gate test of
100,000 candidates is 2.0 MB, a simulation of 100,000 plots 12 MB). A server whose
``PLOTGATE_LIMITS`` raise the picture's cap needs clients with a larger
``max_response_bytes``."""
RETRIED_ERRORS: tuple[type[httpx.TransportError], ...] = (
    httpx.NetworkError,  # ConnectError, ReadError, WriteError, CloseError
    httpx.ConnectTimeout,
    httpx.PoolTimeout,
    httpx.RemoteProtocolError,  # the server closed the connection without answering
)
"""The transport errors a call retries: the request did not get through, or the connection
broke. A ReadTimeout is not among them: the server may still be working on the request, a
long Monte Carlo say, and a second copy would double its load; nor a WriteTimeout: a server
too slow to take the body is overloaded already."""
_DELTA_SECONDS = re.compile(r"[0-9]+")
_Invalid = TypeVar("_Invalid", bound=InvalidResponseError)
_P = ParamSpec("_P")
_Req = TypeVar("_Req", bound=BaseModel)
_Res = TypeVar("_Res", bound=BaseModel)
_BY_METHOD = {e.client_method: e for e in ENDPOINTS.values() if e.client_method is not None}
"""Each operation's declaration, by the name of its typed method."""


def _check_type(operation: str, request: BaseModel) -> None:
    """Refuse a request of the wrong type before sending anything."""
    expected = ENDPOINTS[operation].request
    if not isinstance(request, expected):
        raise TypeError(f"{operation} takes {expected.__name__}, not {type(request).__name__}")


def _request(
    operation: str, body: bytes, request_id: str | None, http: httpx.Client | httpx.AsyncClient
) -> httpx.Request:
    """The POST of a call, sent as it is by every attempt.

    Every attempt of a call carries one ``X-Request-ID``: ``request_id``, else the client's
    own header, else a new one, so that the server's records of a retried call share its
    id. Slow operations get :data:`SLOW_TIMEOUT`; the others the client's own timeout.
    """
    endpoint = ENDPOINTS[operation]
    headers = {"content-type": "application/json"}
    if request_id or "x-request-id" not in http.headers:
        headers["x-request-id"] = request_id or uuid.uuid4().hex
    timeout = SLOW_TIMEOUT if endpoint.slow else httpx.USE_CLIENT_DEFAULT
    return http.build_request(
        "POST", endpoint.path, content=body, headers=headers, timeout=timeout
    )


def parse_answer(operation: str, response: httpx.Response, attempts: int = 1) -> Any:
    """The response model of ``operation`` from ``response``, the last of ``attempts``
    requests (what :meth:`Client.call` returns): a non-2xx answer raises its
    :class:`~plotgate.clients.errors.ProblemError`, a 2xx body that is not the operation's
    response :class:`InvalidResponseError`. For an answer got with :meth:`Client.send`."""
    raise_for_problem(response, attempts)
    model = ENDPOINTS[operation].response
    try:
        return model.model_validate_json(response.content)
    except ValidationError as exc:
        reason = f"not a {model.__name__}: {_what_was_wrong(exc)}"
        raise _invalid(InvalidResponseError, reason, response, attempts) from exc


def _what_was_wrong(exc: ValidationError, shown: int = 3) -> str:
    """The first ``shown`` of pydantic's errors, without the input (the body may be huge),
    within :data:`~plotgate.clients.errors.MESSAGE_CHARS` (a key may be huge too)."""
    errors = exc.errors(include_url=False, include_input=False, include_context=False)
    parts = [f"{'.'.join(str(p) for p in e['loc']) or 'body'}: {e['msg']}" for e in errors[:shown]]
    more = f" (and {len(errors) - shown} more)" if len(errors) > shown else ""
    what = "; ".join(parts) + more
    return what if len(what) <= MESSAGE_CHARS else what[:MESSAGE_CHARS] + "..."


def _invalid(
    kind: type[_Invalid], reason: str, response: httpx.Response, attempts: int
) -> _Invalid:
    """An :class:`InvalidResponseError` of ``kind`` about ``response``, the last of
    ``attempts`` requests."""
    request = response.request
    request_id = response.headers.get("x-request-id") or request.headers.get("x-request-id")
    return kind(reason, response.status_code, str(request.url), request_id, attempts)


def _undecodable(
    response: httpx.Response, exc: httpx.DecodingError, attempts: int
) -> InvalidResponseError:
    reason = f"body does not decode as its Content-Encoding says: {exc}"
    return _invalid(InvalidResponseError, reason, response, attempts)


def _check_max_bytes(max_response_bytes: int) -> int:
    if isinstance(max_response_bytes, bool) or not isinstance(max_response_bytes, int):
        raise ValueError(f"max_response_bytes must be an integer, got {max_response_bytes!r}")
    if max_response_bytes < 1:
        raise ValueError(f"max_response_bytes must be >= 1, got {max_response_bytes}")
    return max_response_bytes


class _Body:
    """An answer's body, taken piece by piece as it arrives and refused past ``max_bytes``,
    or when it is still coming a read timeout after the headers.

    The cap applies to the decoded body (what the caller would hold), so a compressed answer
    is bounded too; a ``Content-Length`` over the cap is refused before reading anything.
    httpx's read timeout bounds each wait for the next bytes only: a body trickling a byte
    every few seconds would never end, so the whole body must also come within that timeout
    (checked as each piece arrives), else ``httpx.ReadTimeout``, not retried, as any other.
    """

    def __init__(self, response: httpx.Response, max_bytes: int, attempts: int) -> None:
        self.response = response
        self.max_bytes = max_bytes
        self.attempts = attempts
        self.pieces: list[bytes] = []
        self.size = 0
        timeouts = response.request.extensions.get("timeout", {})
        self.read_timeout: float | None = timeouts.get("read")
        self.deadline = math.inf if self.read_timeout is None else monotonic() + self.read_timeout
        declared = response.headers.get("content-length", "")
        if declared.isdigit() and int(declared) > max_bytes:
            raise self._too_large(f"Content-Length {declared}")

    def add(self, piece: bytes) -> None:
        self.size += len(piece)
        if self.size > self.max_bytes:
            raise self._too_large(f"more than {self.size - len(piece)} bytes")
        if monotonic() > self.deadline:
            raise httpx.ReadTimeout(
                f"the body was still coming {self.read_timeout:g} s after the headers "
                f"({self.size} bytes so far)",
                request=self.response.request,
            )
        self.pieces.append(piece)

    def _too_large(self, size: str) -> ResponseTooLarge:
        reason = f"body is {size}; the client reads at most {self.max_bytes} (max_response_bytes)"
        return _invalid(ResponseTooLarge, reason, self.response, self.attempts)

    def whole(self) -> httpx.Response:
        """The answer with its body in memory, decoded: the headers that described the bytes
        on the wire (encoding, length, framing) are dropped, since they no longer apply."""
        wire = {"content-encoding", "content-length", "transfer-encoding"}
        headers = [(k, v) for k, v in self.response.headers.multi_items() if k not in wire]
        return httpx.Response(
            self.response.status_code,
            headers=headers,
            content=b"".join(self.pieces),
            request=self.response.request,
            extensions=self.response.extensions,
        )


def _retry_after(response: httpx.Response) -> float:
    """A 503's ``Retry-After`` in seconds; 0 when absent or not delta-seconds (plotgate
    sends whole seconds; an HTTP date, which only a proxy would send, is ignored)."""
    value = response.headers.get("retry-after", "").strip()
    return float(value) if _DELTA_SECONDS.fullmatch(value) else 0.0


@dataclass(frozen=True)
class _Retries:
    """When to try a call again, and how long to wait before."""

    retries: int
    backoff: float
    backoff_max: float

    def __post_init__(self) -> None:
        if not isinstance(self.retries, int) or self.retries < 0:
            raise ValueError(f"retries must be an integer >= 0, got {self.retries!r}")
        for name in ("backoff", "backoff_max"):
            value = getattr(self, name)
            if not 0 <= value < math.inf:
                raise ValueError(f"{name} must be a finite number of seconds >= 0, got {value!r}")

    def wait(self, attempt: int, outcome: httpx.Response | httpx.TransportError) -> float | None:
        """Seconds to wait after ``attempt`` (1 for the first request) ended in ``outcome``
        before trying again; None when ``outcome`` is final.

        Full jitter: uniform in [0, min(backoff_max, backoff * 2**(attempt - 1))], so clients
        turned away together do not come back together; at least a 503's ``Retry-After``,
        capped by ``backoff_max`` all the same.
        """
        if attempt > self.retries:
            return None
        if isinstance(outcome, httpx.Response):
            if outcome.status_code != 503:
                return None
            at_least = _retry_after(outcome)
        elif isinstance(outcome, RETRIED_ERRORS):
            at_least = 0.0
        else:
            return None
        # 2.0 ** 1024 overflows; long before that the doubling is past any cap
        ceiling = min(self.backoff_max, self.backoff * 2.0 ** min(attempt - 1, 1023))
        return min(self.backoff_max, max(at_least, uniform(0.0, ceiling)))


def _unreachable(
    operation: str, where: httpx.URL, exc: httpx.TransportError, attempts: int
) -> TransportError:
    """What a call raises when its last attempt, the ``attempts``-th, got no answer (named
    by its type when it says nothing, as a connection reset under asyncio does)."""
    tries = f" (after {attempts} attempts)" if attempts > 1 else ""
    return TransportError(f"{operation} at {where}: {str(exc) or type(exc).__name__}{tries}")


class _Builds(Protocol[_Req]):
    """How a typed method builds its request: from the model itself or the same as a dict."""

    def __call__(self, request: _Req | Mapping[str, Any]) -> _Req: ...


def _given(model: type[_Req]) -> _Builds[_Req]:
    """The request ``model`` itself, or validated from a dict (a bad dict raises pydantic's
    ``ValidationError`` before any call)."""

    def validated(request: _Req | Mapping[str, Any]) -> _Req:
        return model.model_validate(request) if isinstance(request, Mapping) else request

    return validated


def _gate_test(gate: Gate, first: Plot, candidates: Sequence[Plot]) -> GateTestRequest:
    return GateTestRequest(gate=gate, first=first, candidates=list(candidates))


def _gate_pairs(gate: Gate, pairs: Sequence[GatePair]) -> GatePairsRequest:
    return GatePairsRequest(gate=gate, pairs=list(pairs))


class TypedMethod(Generic[_P, _Req, _Res]):
    """One typed method of both clients, written once: it builds its operation's request
    from its arguments and calls the operation the table names for this method
    (:attr:`plotgate.service.schemas.Endpoint.client_method`). On a :class:`Client` it
    returns the response model; on an :class:`AsyncClient`, an awaitable of it.
    ``tests/clients/test_client_table.py`` holds the methods to the table: names, request
    and response types."""

    def __init__(self, request: type[_Req], response: type[_Res], build: Callable[_P, _Req]):
        self.request = request
        self.response = response
        self.build = build
        self.endpoint: Endpoint | None = None

    def __set_name__(self, owner: type, name: str) -> None:
        self.endpoint = _BY_METHOD[name]
        self.__doc__ = f"{self.endpoint.summary} (operation ``{self.endpoint.name}``)."

    @overload
    def __get__(self, client: None, owner: type) -> "TypedMethod[_P, _Req, _Res]": ...

    @overload
    def __get__(self, client: "Client", owner: type) -> Callable[_P, _Res]: ...

    @overload
    def __get__(self, client: "AsyncClient", owner: type) -> Callable[_P, Awaitable[_Res]]: ...

    def __get__(self, client: "Client | AsyncClient | None", owner: type) -> Any:
        if client is None:
            return self
        assert self.endpoint is not None
        name = self.endpoint.name

        def method(*args: _P.args, **kwargs: _P.kwargs) -> Any:
            return client.call(name, self.build(*args, **kwargs))

        method.__doc__ = self.__doc__
        method.__name__ = self.endpoint.client_method or name
        return method


class OperationMethods:
    """The typed method of every operation, shared by :class:`Client` and
    :class:`AsyncClient` (the common ones; :meth:`Client.call` runs any by name)."""

    test_gate = TypedMethod(GateTestRequest, GateResults, _gate_test)
    test_gate_pairs = TypedMethod(GatePairsRequest, GateResults, _gate_pairs)
    gate_probability = TypedMethod(
        GateProbabilityRequest, GateProbabilityResult, _given(GateProbabilityRequest)
    )
    gate_probability_curve = TypedMethod(
        GateProbabilityCurveRequest, GateProbabilityCurve, _given(GateProbabilityCurveRequest)
    )
    gate_analysis = TypedMethod(
        GateAnalysisRequest, GateAnalysisResult, _given(GateAnalysisRequest)
    )
    gate_design = TypedMethod(GateDesignRequest, GateDesignResult, _given(GateDesignRequest))
    solve_position = TypedMethod(
        PositionSolveRequest, PositionSolveResult, _given(PositionSolveRequest)
    )
    solve_trajectory = TypedMethod(
        TrajectorySolveRequest, TrajectorySolveResult, _given(TrajectorySolveRequest)
    )
    crlb = TypedMethod(CrlbRequest, CrlbResult, _given(CrlbRequest))
    estimate_noise = TypedMethod(NoiseRequest, NoiseResult, _given(NoiseRequest))
    accuracy_study = TypedMethod(StudyRequest, StudyResult, _given(StudyRequest))
    initiate = TypedMethod(InitiateRequest, InitiateResult, _given(InitiateRequest))
    simulate_scans = TypedMethod(SimulateRequest, SimulateResult, _given(SimulateRequest))
    evaluate_initiation = TypedMethod(EvaluateRequest, EvaluateResult, _given(EvaluateRequest))
    identify_pair = TypedMethod(
        IdentifyPairRequest, IdentifyPairResult, _given(IdentifyPairRequest)
    )
    identify_picture = TypedMethod(
        IdentifyPictureRequest, IdentifyPictureResult, _given(IdentifyPictureRequest)
    )
    simulate_identification = TypedMethod(
        IdentifySimulateRequest, IdentifySimulateResult, _given(IdentifySimulateRequest)
    )


class Client(OperationMethods):
    """Blocking client. Use as a context manager, or call :meth:`close`.

    A call is retried when it may well get through later: on a 503 answer (the service
    cannot record, or its cluster cannot be had, or a proxy has no server for it) and when
    the request did not get through or the connection broke (:data:`RETRIED_ERRORS`:
    connection refused or reset, connect or pool timeout, the server closing without an
    answer). It is not retried on a read (or write) timeout, since the server may still be
    working on it (a long Monte Carlo, say) and a second copy would double its load, nor on
    any other answer: a 4xx is wrong the same way every time and a 500 is a bug.

    Retry ``k`` (0, 1, ...) waits a random time in [0, min(backoff_max, backoff * 2**k)]
    ("full jitter", so that clients turned away together do not all come back together), and
    at least the 503's ``Retry-After`` seconds, capped by ``backoff_max`` too. Every attempt
    of a call carries the same ``X-Request-ID`` (the caller's, else a new one), so the
    server's records of a retried call share one id. When the last attempt fails the call
    raises what it failed with, saying how many attempts there were. (The waits go through
    this module's ``sleep``, ``async_sleep`` and ``uniform``, and the body's deadline through
    its ``monotonic``, which tests replace.)

    Parameters
    ----------
    base_url : where the service listens.
    timeout : an ``httpx.Timeout`` or seconds; defaults to :data:`DEFAULT_TIMEOUT`. Its read
        timeout also bounds the whole of an answer's body, from its headers.
    transport : an httpx transport, e.g. ``httpx.ASGITransport(app)`` to call an app in-process.
    headers : extra headers for every call (an API key, say).
    retries : how many times a call is tried again (default 3); 0 turns retries off.
    backoff : seconds, the longest wait before the first retry, doubled for each one after it
        (default 0.5).
    backoff_max : seconds, the longest wait before any retry (default 30).
    max_response_bytes : the largest answer body read, decoded (default
        :data:`DEFAULT_MAX_RESPONSE_BYTES`, 128 MiB); a larger one raises
        ``ResponseTooLarge``, whatever its status, and is not retried.
    """

    def __init__(
        self,
        base_url: str = DEFAULT_URL,
        *,
        timeout: httpx.Timeout | float = DEFAULT_TIMEOUT,
        transport: httpx.BaseTransport | None = None,
        headers: dict[str, str] | None = None,
        retries: int = DEFAULT_RETRIES,
        backoff: float = DEFAULT_BACKOFF,
        backoff_max: float = DEFAULT_BACKOFF_MAX,
        max_response_bytes: int = DEFAULT_MAX_RESPONSE_BYTES,
    ) -> None:
        self._retries = _Retries(retries, backoff, backoff_max)
        self._max_response_bytes = _check_max_bytes(max_response_bytes)
        self._http = httpx.Client(
            base_url=base_url, timeout=timeout, transport=transport, headers=headers
        )

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def call(self, operation: str, request: BaseModel, request_id: str | None = None) -> Any:
        """Run any operation by name, retried as the class says; returns its response model."""
        _check_type(operation, request)
        body = request.model_dump_json().encode()
        return parse_answer(operation, *self._post(operation, body, request_id))

    def send(self, operation: str, body: bytes, request_id: str | None = None) -> httpx.Response:
        """POST a JSON body as it is (the server validates it) to ``operation``, retried as
        :meth:`call` is; returns the last answer whatever its status, its body read and
        decoded within ``max_response_bytes`` (else ``ResponseTooLarge``). :func:`parse_answer`
        turns it into the operation's response model or the error :meth:`call` would raise."""
        return self._post(operation, body, request_id)[0]

    def _post(
        self, operation: str, body: bytes, request_id: str | None
    ) -> tuple[httpx.Response, int]:
        """The last answer and the number of attempts it took."""
        request = _request(operation, body, request_id, self._http)
        attempts = 0
        while True:
            attempts += 1
            outcome: httpx.Response | httpx.TransportError
            try:
                outcome = self._exchange(request, attempts)
            except httpx.TransportError as exc:
                outcome = exc
            wait = self._retries.wait(attempts, outcome)
            if wait is None:
                break
            sleep(wait)
        if isinstance(outcome, httpx.TransportError):
            raise _unreachable(operation, self._http.base_url, outcome, attempts) from outcome
        return outcome, attempts

    def _exchange(self, request: httpx.Request, attempts: int) -> httpx.Response:
        """Send ``request`` (the ``attempts``-th time) and read its answer within the cap."""
        response = self._http.send(request, stream=True)
        try:
            body = _Body(response, self._max_response_bytes, attempts)
            for piece in response.iter_bytes():
                body.add(piece)
        except httpx.DecodingError as exc:
            raise _undecodable(response, exc, attempts) from exc
        finally:
            response.close()
        return body.whole()

    def ready(self) -> bool:
        """True when the service answers ``/readyz`` with 200 (it can record)."""
        try:
            with self._http.stream("GET", "/readyz") as response:
                return response.status_code == 200  # the body is never read
        except httpx.TransportError:
            return False


class AsyncClient(OperationMethods):
    """Asynchronous twin of :class:`Client`, same parameters and methods (its waits between
    attempts are ``asyncio.sleep``)."""

    def __init__(
        self,
        base_url: str = DEFAULT_URL,
        *,
        timeout: httpx.Timeout | float = DEFAULT_TIMEOUT,
        transport: httpx.AsyncBaseTransport | None = None,
        headers: dict[str, str] | None = None,
        retries: int = DEFAULT_RETRIES,
        backoff: float = DEFAULT_BACKOFF,
        backoff_max: float = DEFAULT_BACKOFF_MAX,
        max_response_bytes: int = DEFAULT_MAX_RESPONSE_BYTES,
    ) -> None:
        self._retries = _Retries(retries, backoff, backoff_max)
        self._max_response_bytes = _check_max_bytes(max_response_bytes)
        self._http = httpx.AsyncClient(
            base_url=base_url, timeout=timeout, transport=transport, headers=headers
        )

    async def __aenter__(self) -> "AsyncClient":
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        await self._http.aclose()

    async def call(self, operation: str, request: BaseModel, request_id: str | None = None) -> Any:
        """Run any operation by name, retried as :class:`Client` says; returns its response
        model."""
        _check_type(operation, request)
        body = request.model_dump_json().encode()
        return parse_answer(operation, *await self._post(operation, body, request_id))

    async def send(
        self, operation: str, body: bytes, request_id: str | None = None
    ) -> httpx.Response:
        """POST a JSON body as it is (the server validates it) to ``operation``, retried as
        :meth:`call` is; returns the last answer whatever its status, its body read and
        decoded within ``max_response_bytes`` (else ``ResponseTooLarge``). :func:`parse_answer`
        turns it into the operation's response model or the error :meth:`call` would raise."""
        return (await self._post(operation, body, request_id))[0]

    async def _post(
        self, operation: str, body: bytes, request_id: str | None
    ) -> tuple[httpx.Response, int]:
        """The last answer and the number of attempts it took."""
        request = _request(operation, body, request_id, self._http)
        attempts = 0
        while True:
            attempts += 1
            outcome: httpx.Response | httpx.TransportError
            try:
                outcome = await self._exchange(request, attempts)
            except httpx.TransportError as exc:
                outcome = exc
            wait = self._retries.wait(attempts, outcome)
            if wait is None:
                break
            await async_sleep(wait)
        if isinstance(outcome, httpx.TransportError):
            raise _unreachable(operation, self._http.base_url, outcome, attempts) from outcome
        return outcome, attempts

    async def _exchange(self, request: httpx.Request, attempts: int) -> httpx.Response:
        """Send ``request`` (the ``attempts``-th time) and read its answer within the cap."""
        response = await self._http.send(request, stream=True)
        try:
            body = _Body(response, self._max_response_bytes, attempts)
            async for piece in response.aiter_bytes():
                body.add(piece)
        except httpx.DecodingError as exc:
            raise _undecodable(response, exc, attempts) from exc
        finally:
            await response.aclose()
        return body.whole()

    async def ready(self) -> bool:
        """True when the service answers ``/readyz`` with 200 (it can record)."""
        try:
            async with self._http.stream("GET", "/readyz") as response:
                return response.status_code == 200  # the body is never read
        except httpx.TransportError:
            return False
