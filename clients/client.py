"""Typed HTTP clients of plotgate, sync and async, built on httpx and the shared schemas.

Each operation of :data:`plotgate.service.schemas.ENDPOINTS` is reachable through ``call(name,
request)``; the common ones also have a typed method (``test_gate``, ``gate_probability``
...). The gating-probability and multistatic-solve methods (``solve_position``,
``solve_trajectory``, ``crlb``, ``estimate_noise``, ``accuracy_study``) and the
initiation methods (``initiate``, ``simulate_scans``, ``evaluate_initiation``) and the
identification methods (``identify_pair``, ``identify_picture``, ``simulate_identification``)
take their request model or the same as a dict (validated here, so a bad dict raises pydantic's
``ValidationError`` before any call).
Errors are the exceptions of :mod:`plotgate.clients.errors`. The README shows a full example.
"""

from collections.abc import Mapping, Sequence
from typing import Any

import httpx
from pydantic import BaseModel

from plotgate.clients.errors import TransportError, raise_for_problem
from plotgate.service.schemas import (
    ENDPOINTS,
    CrlbRequest,
    CrlbResult,
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

__all__ = ["DEFAULT_TIMEOUT", "DEFAULT_URL", "SLOW_TIMEOUT", "AsyncClient", "Client"]

DEFAULT_URL = "http://127.0.0.1:8000"
DEFAULT_TIMEOUT = httpx.Timeout(30.0, connect=5.0)
"""No call can hang forever: 30 s for an answer, 5 s to connect."""
SLOW_TIMEOUT = httpx.Timeout(600.0, connect=5.0)
"""For operations whose endpoint is marked ``slow`` (quadratures, gate design)."""


def _model(operation: str, request: BaseModel | Mapping[str, Any]) -> BaseModel:
    """The request model of ``operation``: ``request`` itself, or validated from a dict."""
    if isinstance(request, Mapping):
        return ENDPOINTS[operation].request.model_validate(request)
    return request


def _prepare(
    operation: str, request: BaseModel, request_id: str | None
) -> tuple[str, bytes, dict[str, str], Any]:
    """Path, JSON body, headers and timeout of a call; refuses a request of the wrong type.

    Slow operations get :data:`SLOW_TIMEOUT`; the others the client's own timeout.
    """
    endpoint = ENDPOINTS[operation]
    if not isinstance(request, endpoint.request):
        raise TypeError(
            f"{operation} takes {endpoint.request.__name__}, not {type(request).__name__}"
        )
    headers = {"content-type": "application/json"}
    if request_id:
        headers["x-request-id"] = request_id
    timeout = SLOW_TIMEOUT if endpoint.slow else httpx.USE_CLIENT_DEFAULT
    return endpoint.path, request.model_dump_json().encode(), headers, timeout


def _parse(operation: str, response: httpx.Response) -> Any:
    raise_for_problem(response)
    return ENDPOINTS[operation].response.model_validate_json(response.content)


class Client:
    """Blocking client. Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    base_url : where the service listens.
    timeout : an ``httpx.Timeout`` or seconds; defaults to :data:`DEFAULT_TIMEOUT`.
    transport : an httpx transport, e.g. ``httpx.ASGITransport(app)`` to call an app in-process.
    headers : extra headers for every call (an API key, say).
    """

    def __init__(
        self,
        base_url: str = DEFAULT_URL,
        *,
        timeout: httpx.Timeout | float = DEFAULT_TIMEOUT,
        transport: httpx.BaseTransport | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
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
        """Run any operation by name; returns its response model."""
        path, content, headers, timeout = _prepare(operation, request, request_id)
        try:
            response = self._http.post(path, content=content, headers=headers, timeout=timeout)
        except httpx.TransportError as exc:
            raise TransportError(f"{operation} at {self._http.base_url}: {exc}") from exc
        return _parse(operation, response)

    def test_gate(self, gate: Gate, first: Plot, candidates: Sequence[Plot]) -> GateResults:
        """Test ``first`` against every candidate (operation ``gates.test``)."""
        request = GateTestRequest(gate=gate, first=first, candidates=list(candidates))
        return self.call("gates.test", request)

    def test_gate_pairs(self, gate: Gate, pairs: Sequence[GatePair]) -> GateResults:
        """Test independent (first, second) pairs (operation ``gates.pairs``)."""
        return self.call("gates.pairs", GatePairsRequest(gate=gate, pairs=list(pairs)))

    def gate_probability(
        self, request: GateProbabilityRequest | Mapping[str, Any]
    ) -> GateProbabilityResult:
        """Conditional or unconditional gating probability (operation ``gates.probability``)."""
        return self.call("gates.probability", _model("gates.probability", request))

    def gate_probability_curve(
        self, request: GateProbabilityCurveRequest | Mapping[str, Any]
    ) -> GateProbabilityCurve:
        """Gating probability against speed or range (``gates.probability_curve``)."""
        return self.call("gates.probability_curve", _model("gates.probability_curve", request))

    def gate_analysis(
        self, request: GateAnalysisRequest | Mapping[str, Any]
    ) -> GateAnalysisResult:
        """Area, cells, false marks and capture probability (operation ``gates.analysis``)."""
        return self.call("gates.analysis", _model("gates.analysis", request))

    def gate_design(self, request: GateDesignRequest | Mapping[str, Any]) -> GateDesignResult:
        """P_G or p reaching a wanted capture probability (operation ``gates.design``)."""
        return self.call("gates.design", _model("gates.design", request))

    def solve_position(
        self, request: PositionSolveRequest | Mapping[str, Any]
    ) -> PositionSolveResult:
        """Maximum-likelihood positions of a batch of range-sum problems (``solves.position``)."""
        return self.call("solves.position", _model("solves.position", request))

    def solve_trajectory(
        self, request: TrajectorySolveRequest | Mapping[str, Any]
    ) -> TrajectorySolveResult:
        """Constant-velocity track from range sums over samples (``solves.trajectory``)."""
        return self.call("solves.trajectory", _model("solves.trajectory", request))

    def crlb(self, request: CrlbRequest | Mapping[str, Any]) -> CrlbResult:
        """Cramer-Rao bound, single shot or along a track (operation ``solves.crlb``)."""
        return self.call("solves.crlb", _model("solves.crlb", request))

    def estimate_noise(self, request: NoiseRequest | Mapping[str, Any]) -> NoiseResult:
        """Range-sum noise and smoothed coordinates (operation ``solves.noise``)."""
        return self.call("solves.noise", _model("solves.noise", request))

    def accuracy_study(self, request: StudyRequest | Mapping[str, Any]) -> StudyResult:
        """Monte Carlo accuracy of the solvers along a track (operation ``solves.study``)."""
        return self.call("solves.study", _model("solves.study", request))

    def initiate(self, request: InitiateRequest | Mapping[str, Any]) -> InitiateResult:
        """Scans through track initiation, continuing a state (``initiation.initiate``)."""
        return self.call("initiation.initiate", _model("initiation.initiate", request))

    def simulate_scans(self, request: SimulateRequest | Mapping[str, Any]) -> SimulateResult:
        """Seeded scans of targets in clutter (operation ``initiation.simulate``)."""
        return self.call("initiation.simulate", _model("initiation.simulate", request))

    def evaluate_initiation(self, request: EvaluateRequest | Mapping[str, Any]) -> EvaluateResult:
        """Monte Carlo of track initiation (operation ``initiation.evaluate``)."""
        return self.call("initiation.evaluate", _model("initiation.evaluate", request))

    def identify_pair(
        self, request: IdentifyPairRequest | Mapping[str, Any]
    ) -> IdentifyPairResult:
        """Z-test of one passive against one active track (``identification.pair``)."""
        return self.call("identification.pair", _model("identification.pair", request))

    def identify_picture(
        self, request: IdentifyPictureRequest | Mapping[str, Any]
    ) -> IdentifyPictureResult:
        """Z matrix and identification of many tracks (``identification.picture``)."""
        return self.call("identification.picture", _model("identification.picture", request))

    def simulate_identification(
        self, request: IdentifySimulateRequest | Mapping[str, Any]
    ) -> IdentifySimulateResult:
        """Kvasnov's experiment by Monte Carlo (``identification.simulate``)."""
        return self.call("identification.simulate", _model("identification.simulate", request))

    def ready(self) -> bool:
        """True when the service answers ``/readyz`` with 200 (it can record)."""
        try:
            return self._http.get("/readyz").status_code == 200
        except httpx.TransportError:
            return False


class AsyncClient:
    """Asynchronous twin of :class:`Client`, same parameters and methods."""

    def __init__(
        self,
        base_url: str = DEFAULT_URL,
        *,
        timeout: httpx.Timeout | float = DEFAULT_TIMEOUT,
        transport: httpx.AsyncBaseTransport | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
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
        """Run any operation by name; returns its response model."""
        path, content, headers, timeout = _prepare(operation, request, request_id)
        try:
            response = await self._http.post(
                path, content=content, headers=headers, timeout=timeout
            )
        except httpx.TransportError as exc:
            raise TransportError(f"{operation} at {self._http.base_url}: {exc}") from exc
        return _parse(operation, response)

    async def test_gate(self, gate: Gate, first: Plot, candidates: Sequence[Plot]) -> GateResults:
        """Test ``first`` against every candidate (operation ``gates.test``)."""
        request = GateTestRequest(gate=gate, first=first, candidates=list(candidates))
        return await self.call("gates.test", request)

    async def test_gate_pairs(self, gate: Gate, pairs: Sequence[GatePair]) -> GateResults:
        """Test independent (first, second) pairs (operation ``gates.pairs``)."""
        return await self.call("gates.pairs", GatePairsRequest(gate=gate, pairs=list(pairs)))

    async def gate_probability(
        self, request: GateProbabilityRequest | Mapping[str, Any]
    ) -> GateProbabilityResult:
        """Conditional or unconditional gating probability (operation ``gates.probability``)."""
        return await self.call("gates.probability", _model("gates.probability", request))

    async def gate_probability_curve(
        self, request: GateProbabilityCurveRequest | Mapping[str, Any]
    ) -> GateProbabilityCurve:
        """Gating probability against speed or range (``gates.probability_curve``)."""
        return await self.call(
            "gates.probability_curve", _model("gates.probability_curve", request)
        )

    async def gate_analysis(
        self, request: GateAnalysisRequest | Mapping[str, Any]
    ) -> GateAnalysisResult:
        """Area, cells, false marks and capture probability (operation ``gates.analysis``)."""
        return await self.call("gates.analysis", _model("gates.analysis", request))

    async def gate_design(
        self, request: GateDesignRequest | Mapping[str, Any]
    ) -> GateDesignResult:
        """P_G or p reaching a wanted capture probability (operation ``gates.design``)."""
        return await self.call("gates.design", _model("gates.design", request))

    async def solve_position(
        self, request: PositionSolveRequest | Mapping[str, Any]
    ) -> PositionSolveResult:
        """Maximum-likelihood positions of a batch of range-sum problems (``solves.position``)."""
        return await self.call("solves.position", _model("solves.position", request))

    async def solve_trajectory(
        self, request: TrajectorySolveRequest | Mapping[str, Any]
    ) -> TrajectorySolveResult:
        """Constant-velocity track from range sums over samples (``solves.trajectory``)."""
        return await self.call("solves.trajectory", _model("solves.trajectory", request))

    async def crlb(self, request: CrlbRequest | Mapping[str, Any]) -> CrlbResult:
        """Cramer-Rao bound, single shot or along a track (operation ``solves.crlb``)."""
        return await self.call("solves.crlb", _model("solves.crlb", request))

    async def estimate_noise(self, request: NoiseRequest | Mapping[str, Any]) -> NoiseResult:
        """Range-sum noise and smoothed coordinates (operation ``solves.noise``)."""
        return await self.call("solves.noise", _model("solves.noise", request))

    async def accuracy_study(self, request: StudyRequest | Mapping[str, Any]) -> StudyResult:
        """Monte Carlo accuracy of the solvers along a track (operation ``solves.study``)."""
        return await self.call("solves.study", _model("solves.study", request))

    async def initiate(self, request: InitiateRequest | Mapping[str, Any]) -> InitiateResult:
        """Scans through track initiation, continuing a state (``initiation.initiate``)."""
        return await self.call("initiation.initiate", _model("initiation.initiate", request))

    async def simulate_scans(self, request: SimulateRequest | Mapping[str, Any]) -> SimulateResult:
        """Seeded scans of targets in clutter (operation ``initiation.simulate``)."""
        return await self.call("initiation.simulate", _model("initiation.simulate", request))

    async def evaluate_initiation(
        self, request: EvaluateRequest | Mapping[str, Any]
    ) -> EvaluateResult:
        """Monte Carlo of track initiation (operation ``initiation.evaluate``)."""
        return await self.call("initiation.evaluate", _model("initiation.evaluate", request))

    async def identify_pair(
        self, request: IdentifyPairRequest | Mapping[str, Any]
    ) -> IdentifyPairResult:
        """Z-test of one passive against one active track (``identification.pair``)."""
        return await self.call("identification.pair", _model("identification.pair", request))

    async def identify_picture(
        self, request: IdentifyPictureRequest | Mapping[str, Any]
    ) -> IdentifyPictureResult:
        """Z matrix and identification of many tracks (``identification.picture``)."""
        return await self.call("identification.picture", _model("identification.picture", request))

    async def simulate_identification(
        self, request: IdentifySimulateRequest | Mapping[str, Any]
    ) -> IdentifySimulateResult:
        """Kvasnov's experiment by Monte Carlo (``identification.simulate``)."""
        return await self.call(
            "identification.simulate", _model("identification.simulate", request)
        )

    async def ready(self) -> bool:
        """True when the service answers ``/readyz`` with 200 (it can record)."""
        try:
            return (await self._http.get("/readyz")).status_code == 200
        except httpx.TransportError:
            return False
