"""The wire contract of every operation: name, path, request and response models.

Clients read this table to call the service without importing it; the registry
(:mod:`service.registry`) binds each endpoint to its handler.
"""

from dataclasses import dataclass

from pydantic import BaseModel

from service.schemas.gates import GatePairsRequest, GateResults, GateTestRequest
from service.schemas.identification import (
    IdentifyPairRequest,
    IdentifyPairResult,
    IdentifyPictureRequest,
    IdentifyPictureResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
)
from service.schemas.initiation import (
    EvaluateRequest,
    EvaluateResult,
    InitiateRequest,
    InitiateResult,
    SimulateRequest,
    SimulateResult,
)
from service.schemas.probability import (
    GateAnalysisRequest,
    GateAnalysisResult,
    GateDesignRequest,
    GateDesignResult,
    GateProbabilityCurve,
    GateProbabilityCurveRequest,
    GateProbabilityRequest,
    GateProbabilityResult,
)
from service.schemas.solves import (
    CrlbRequest,
    CrlbResult,
    NoiseRequest,
    NoiseResult,
    PositionSolveRequest,
    PositionSolveResult,
    TrajectorySolveRequest,
    TrajectorySolveResult,
)
from service.schemas.study import StudyRequest, StudyResult

__all__ = ["ENDPOINTS", "Endpoint"]


@dataclass(frozen=True)
class Endpoint:
    """One operation as seen from the wire.

    ``slow`` marks an operation that may compute for seconds (unconditional
    probabilities, curves, gate design) or for more than ~50 ms at its size limits
    (the multistatic solves and bounds): the server runs it off the event loop and
    clients give it a longer timeout.
    """

    name: str
    path: str
    summary: str
    request: type[BaseModel]
    response: type[BaseModel]
    slow: bool = False

    @property
    def tag(self) -> str:
        return self.name.split(".")[0]


ENDPOINTS: dict[str, Endpoint] = {
    e.name: e
    for e in (
        Endpoint(
            "gates.test", "/v1/gates/test", "Test one first plot against many candidate plots",
            GateTestRequest, GateResults,
        ),
        Endpoint(
            "gates.pairs", "/v1/gates/pairs", "Test many independent (first, second) plot pairs",
            GatePairsRequest, GateResults,
        ),
        Endpoint(
            "gates.probability", "/v1/gates/probability",
            "Probability that the second mark falls in a gate, for a known velocity or over "
            "a speed prior",
            GateProbabilityRequest, GateProbabilityResult, slow=True,
        ),
        Endpoint(
            "gates.probability_curve", "/v1/gates/probability/curve",
            "Gating probability against target speed or the first mark's range",
            GateProbabilityCurveRequest, GateProbabilityCurve, slow=True,
        ),
        Endpoint(
            "gates.analysis", "/v1/gates/analysis",
            "Gate area, resolution cells, false marks and capture probability",
            GateAnalysisRequest, GateAnalysisResult, slow=True,
        ),
        Endpoint(
            "gates.design", "/v1/gates/design",
            "Size a combined or expanded gate for a wanted capture probability",
            GateDesignRequest, GateDesignResult, slow=True,
        ),
        Endpoint(
            "solves.position", "/v1/solves/position",
            "Maximum-likelihood positions of a batch of multistatic range-sum problems, "
            "optionally with a closed-form solution",
            PositionSolveRequest, PositionSolveResult, slow=True,
        ),
        Endpoint(
            "solves.trajectory", "/v1/solves/trajectory",
            "Constant-velocity track from range sums at several sample times",
            TrajectorySolveRequest, TrajectorySolveResult, slow=True,
        ),
        Endpoint(
            "solves.crlb", "/v1/solves/crlb",
            "Cramer-Rao bound of multistatic positioning, single shot or along a track",
            CrlbRequest, CrlbResult, slow=True,
        ),
        Endpoint(
            "solves.noise", "/v1/solves/noise",
            "Range-sum noise from quadratic fits, and sliding-window smoothing of "
            "coordinates",
            NoiseRequest, NoiseResult, slow=True,
        ),
        Endpoint(
            "solves.study", "/v1/solves/study",
            "Monte Carlo accuracy study of the multistatic solvers along a track (seed 001 "
            "Fig. 3 curves 1-6)",
            StudyRequest, StudyResult, slow=True,
        ),
        Endpoint(
            "initiation.initiate", "/v1/initiation/initiate",
            "Start and confirm tracks from scans of plots in clutter, continuing a state",
            InitiateRequest, InitiateResult, slow=True,
        ),
        Endpoint(
            "initiation.simulate", "/v1/initiation/simulate",
            "Seeded scans of targets in Poisson clutter, every plot labelled",
            SimulateRequest, SimulateResult, slow=True,
        ),
        Endpoint(
            "initiation.evaluate", "/v1/initiation/evaluate",
            "Monte Carlo of track initiation: targets initiated, false tracks",
            EvaluateRequest, EvaluateResult, slow=True,
        ),
        Endpoint(
            "identification.pair", "/v1/identification/pair",
            "Is a passive (ESM) track the same object as an active radar track? Fisher's "
            "Z-test on bearings",
            IdentifyPairRequest, IdentifyPairResult, slow=True,
        ),
        Endpoint(
            "identification.picture", "/v1/identification/picture",
            "Z matrix and one-to-one identification of many passive and active tracks",
            IdentifyPictureRequest, IdentifyPictureResult, slow=True,
        ),
        Endpoint(
            "identification.simulate", "/v1/identification/simulate",
            "Seed 004's experiment by Monte Carlo: realized type I or type II error",
            IdentifySimulateRequest, IdentifySimulateResult, slow=True,
        ),
    )
}
