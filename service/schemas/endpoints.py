"""The wire contract of every operation: name, path, request and response models.

Clients read this table to call the service without importing it; the registry
(:mod:`plotgate.service.registry`) binds each endpoint to its handler.
"""

import copy
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel

from plotgate.service.schemas.crlb import CrlbRequest, CrlbResult
from plotgate.service.schemas.descriptions import DESCRIPTIONS
from plotgate.service.schemas.examples import EXAMPLES
from plotgate.service.schemas.gates import GatePairsRequest, GateResults, GateTestRequest
from plotgate.service.schemas.identification import (
    MAX_SIMULATED_SAMPLES,
    IdentifyPairRequest,
    IdentifyPairResult,
    IdentifyPictureRequest,
    IdentifyPictureResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
)
from plotgate.service.schemas.initiation import (
    EvaluateRequest,
    EvaluateResult,
    InitiateRequest,
    InitiateResult,
    SimulateRequest,
    SimulateResult,
)
from plotgate.service.schemas.noise import NoiseRequest, NoiseResult
from plotgate.service.schemas.position import PositionSolveRequest, PositionSolveResult
from plotgate.service.schemas.probability import (
    GateAnalysisRequest,
    GateAnalysisResult,
    GateDesignRequest,
    GateDesignResult,
    GateProbabilityCurve,
    GateProbabilityCurveRequest,
    GateProbabilityRequest,
    GateProbabilityResult,
    unconditional_axis_ratio,
    unconditional_cost,
)
from plotgate.service.schemas.study import StudyRequest, StudyResult
from plotgate.service.schemas.trajectory import TrajectorySolveRequest, TrajectorySolveResult

__all__ = [
    "CLUSTER_BUDGET_S",
    "ENDPOINTS",
    "MEMORY_BUDGET_MIB",
    "TIME_BUDGET_S",
    "Endpoint",
    "work_caps",
]

MEMORY_BUDGET_MIB = 1024
"""The peak RSS, MiB, a server process stays under while it answers the largest request
its default caps accept (:attr:`Endpoint.caps`; ``bench/bench_worst_requests.py``
measures each operation's worst request in a fresh process)."""
TIME_BUDGET_S = 10.0
"""The wall time, s, on one core, that the largest request the default caps accept stays
under (``bench/bench_worst_requests.py`` searches each operation's slowest one)."""
CLUSTER_BUDGET_S = 300.0
"""The time, s, one request may keep each worker thread of a Dask cluster busy: the
default ``PLOTGATE_DASK_TIMEOUT_S``. A chunked operation's cluster cap is its one-core cap
times ``CLUSTER_BUDGET_S / TIME_BUDGET_S`` per worker thread (:meth:`Endpoint.cluster_cap`),
so a request the cluster takes can finish before the service's timeout."""


@dataclass(frozen=True)
class Endpoint:
    """One operation as seen from the wire.

    ``work`` names the sizes of a request an operator may cap per operation (plots per
    scan, problems per batch, Monte Carlo runs, curve points, mean clutter plots per
    simulated scan, the axis ratio of the marks' error ellipse that sets the cost of an
    unconditional gating probability...). ``slow`` marks an
    operation that may compute for seconds (unconditional
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
    work: dict[str, Callable[[Any], int]] = field(default_factory=dict)
    """The sizes a server may limit below the schema's own bounds (``PLOTGATE_LIMITS``):
    name (the request field it counts; ``a x b`` for a product of two) -> its value for a
    validated request."""
    caps: dict[str, int] = field(default_factory=dict)
    """Default caps on some of the ``work`` sizes: those whose memory or time grows faster
    than the body (a matrix of passive x active tracks, runs x samples, a smoothing window
    fitted at every sample), each set so that the largest request they accept keeps the
    process under :data:`MEMORY_BUDGET_MIB` (measured by ``bench/bench_worst_requests.py``).
    An operator's ``PLOTGATE_LIMITS`` lowers or raises any of them (:func:`work_caps`)."""
    cluster_caps: dict[str, int] = field(default_factory=dict)
    """For an operation whose work runs in chunks on a Dask cluster when the service has
    one: the hard ceiling of each default cap that a cluster widens
    (:meth:`cluster_cap`). A ceiling bounds what the cluster cannot spread: the results
    gathered in the service's memory and the chunks' count."""

    def __post_init__(self) -> None:
        unknown = set(self.caps) - set(self.work)
        if unknown:
            raise ValueError(f"{self.name}: default caps on sizes it lacks: {sorted(unknown)}")
        if set(self.cluster_caps) - set(self.caps):
            raise ValueError(f"{self.name}: cluster ceilings on sizes without a default cap")

    def cluster_cap(self, size: str, workers: int) -> int:
        """The cap on ``size`` with a Dask cluster of ``workers`` worker threads: the one-core
        default times ``CLUSTER_BUDGET_S / TIME_BUDGET_S`` per thread, never under the
        default nor over the ceiling (:attr:`cluster_caps`)."""
        default = self.caps[size]
        widened = default * workers * round(CLUSTER_BUDGET_S / TIME_BUDGET_S)
        return min(self.cluster_caps[size], max(default, widened))

    @property
    def tag(self) -> str:
        return self.name.split(".")[0]

    @property
    def description(self) -> str:
        """What the operation computes, its paper and equation, its units (markdown,
        :data:`plotgate.service.schemas.descriptions.DESCRIPTIONS`)."""
        return DESCRIPTIONS[self.name]

    @property
    def example(self) -> dict[str, Any]:
        """A small valid request body (:data:`plotgate.service.schemas.examples.EXAMPLES`), a
        copy."""
        return copy.deepcopy(EXAMPLES[self.name])


AXIS_RATIO_CAP = 26
"""Default cap of ``mark.axis_ratio`` for one unconditional probability (gates.probability,
gates.analysis). Its cost grows with the ratio, the gate kind and the prior; the slowest is
the first-association window over a wide speed prior (10 km about the mark), whose
heading density at an eccentric B is still integrated on graded panels. CPU time of one
request on this tree (``bench/bench_worst_requests.py``; the CPU time is what a quiet
core's wall time would be): at ratio 22, 5.1-5.2 s for that window, 1.4-1.7 s for the
ring, combined and expanded gates, 0.2-0.4 s for the paper's ring prior. 26 takes the
issue's eccentric gate (80 km, 20 m, 1 deg) with room under 10 s."""
DESIGN_AXIS_RATIO_CAP = 26
"""Default cap of ``gates.design``'s ``mark.axis_ratio``: a design evaluates four to ten
unconditional probabilities of the combined or expanded gate, which share one density
table; 0.3-0.4 s of CPU for a whole design at ratio 22."""
CURVE_AXIS_RATIO_CAP = 9
"""Default cap of an unconditional curve's ``mark.axis_ratio``: its points are many
probabilities, so the ratio is held where one point costs a fraction of a second."""
CURVE_COST_CAP = 16
"""Default cap of a curve's ``values x gate cost`` (:data:`~plotgate.service.schemas.
probability.GATE_COST`): each unconditional point costs what one probability does, at
most the ratio :data:`CURVE_AXIS_RATIO_CAP` (``bench/bench_worst_requests.py`` times the
slowest curve it accepts; ``plotgate plot compare``'s 15 points fit)."""
EVALUATION_WORK_CAP = 1_200_000
"""Default cap of ``initiation.evaluate``'s ``runs x scans x plots``, plot-equivalents
(:meth:`~plotgate.service.schemas.EvaluateRequest.work`): about 6.5 s on one core."""
CLUSTER_EVALUATION_WORK = 200_000_000
"""Its ceiling on a cluster of any size: about 18 core-minutes of work. What the service
gathers is one score a run and rule, at most 10^4 runs x 51 rules (the schema's bounds),
a few hundred bytes each; the plots stay on the workers (``bench/README.md`` measures the
service's peak RSS during a 10^4-run evaluation on a cluster)."""


def _study_range_sums(request: StudyRequest) -> int:
    """The range sums a study simulates and solves one by one. Memory: about 470 bytes each
    (2.4 million took 1.37 GB of RSS; the cap, 1.2 million, 809 MiB). Time: 1166 runs x 200
    samples x 3 receivers (700,000) took 2.9 s of CPU (``bench/bench_worst_requests.py``),
    so the cap is about 5 s."""
    return request.runs * len(request.sample_times) * len(request.receivers)


def _study_solve_work(request: StudyRequest) -> int:
    """The solves' work with many receivers: each solve of P pairs weighs its P x P
    covariance, so time and memory grow as P^2. 54 runs x 200 samples x 64 receivers (691,200
    range sums, under their cap) took 239 s and 2380 MiB of RSS on a shared machine, 54
    bytes a unit; 2 runs x 200 x 64 took 0.5 s of CPU. The default cap, 3,600,000 (the range
    sums' cap at 3 receivers), is about 1 s and 200 MiB."""
    return _study_range_sums(request) * len(request.receivers)


def _study_prefix_work(request: StudyRequest) -> int:
    """With ``tracks``, the work of every prefix's trajectory solve (runs x samples^2 x
    receivers^2; 0 without tracks). 55 runs x 200^2 x 3^2 (2e7) took 1.3 s of CPU, and so did
    2 runs x 1000^2 x 3^2 (``bench/bench_worst_requests.py``): the default cap, 6e7, is about
    4 s."""
    if not request.tracks:
        return 0
    return request.runs * len(request.sample_times) ** 2 * len(request.receivers) ** 2


ENDPOINTS: dict[str, Endpoint] = {
    e.name: e
    for e in (
        Endpoint(
            "gates.test",
            "/v1/gates/test",
            "Test one first plot against many candidate plots",
            GateTestRequest,
            GateResults,
            work={"candidates": lambda r: len(r.candidates)},
        ),
        Endpoint(
            "gates.pairs",
            "/v1/gates/pairs",
            "Test many independent (first, second) plot pairs",
            GatePairsRequest,
            GateResults,
            work={"pairs": lambda r: len(r.pairs)},
        ),
        Endpoint(
            "gates.probability",
            "/v1/gates/probability",
            "Probability that the second mark falls in a gate, for a known velocity or over "
            "a speed prior",
            GateProbabilityRequest,
            GateProbabilityResult,
            slow=True,
            work={"mark.axis_ratio": unconditional_axis_ratio},
            caps={"mark.axis_ratio": AXIS_RATIO_CAP},
        ),
        Endpoint(
            "gates.probability_curve",
            "/v1/gates/probability/curve",
            "Gating probability against target speed or the first mark's range",
            GateProbabilityCurveRequest,
            GateProbabilityCurve,
            slow=True,
            work={
                "values": lambda r: len(r.values),
                "mark.axis_ratio": unconditional_axis_ratio,
                "values x gate cost": unconditional_cost,
            },
            # each unconditional point costs what one gates.probability does
            caps={"mark.axis_ratio": CURVE_AXIS_RATIO_CAP, "values x gate cost": CURVE_COST_CAP},
        ),
        Endpoint(
            "gates.analysis",
            "/v1/gates/analysis",
            "Gate area, resolution cells, false marks and capture probability",
            GateAnalysisRequest,
            GateAnalysisResult,
            slow=True,
            work={"mark.axis_ratio": unconditional_axis_ratio},
            caps={"mark.axis_ratio": AXIS_RATIO_CAP},
        ),
        Endpoint(
            "gates.design",
            "/v1/gates/design",
            "Size a combined or expanded gate for a wanted capture probability",
            GateDesignRequest,
            GateDesignResult,
            slow=True,
            work={"mark.axis_ratio": unconditional_axis_ratio},
            # a root search over the gate's parameter: four to ten unconditional probabilities
            caps={"mark.axis_ratio": DESIGN_AXIS_RATIO_CAP},
        ),
        Endpoint(
            "solves.position",
            "/v1/solves/position",
            "Maximum-likelihood positions of a batch of multistatic range-sum problems, "
            "optionally with a closed-form solution",
            PositionSolveRequest,
            PositionSolveResult,
            slow=True,
            work={"problems": lambda r: len(r.problems)},
        ),
        Endpoint(
            "solves.trajectory",
            "/v1/solves/trajectory",
            "Constant-velocity track from range sums at several sample times",
            TrajectorySolveRequest,
            TrajectorySolveResult,
            slow=True,
            work={"sample_times": lambda r: len(r.sample_times)},
        ),
        Endpoint(
            "solves.crlb",
            "/v1/solves/crlb",
            "Cramer-Rao bound of multistatic positioning, single shot or along a track",
            CrlbRequest,
            CrlbResult,
            slow=True,
            work={
                "targets": lambda r: len(r.targets or ()),
                "sample_times": lambda r: len(r.sample_times or ()),
            },
        ),
        Endpoint(
            "solves.noise",
            "/v1/solves/noise",
            "Range-sum noise from quadratic fits, and sliding-window smoothing of coordinates",
            NoiseRequest,
            NoiseResult,
            slow=True,
            work={
                "sample_times": lambda r: len(r.sample_times),
                "sample_times x window": lambda r: len(r.sample_times) * (r.window or 0),
            },
            # one pseudo-inverse per sample over its window: time, not memory (core fits in
            # blocks); 1000 samples x a window of 1000 at degree 10 took 23 s on 2 loaded cores
            caps={"sample_times x window": 1_000_000},
        ),
        Endpoint(
            "solves.study",
            "/v1/solves/study",
            "Monte Carlo accuracy study of the multistatic solvers along a track (Fadeev "
            "et al., Fig. 3, curves 1-6)",
            StudyRequest,
            StudyResult,
            slow=True,
            work={
                "runs": lambda r: r.runs,
                "sample_times": lambda r: len(r.sample_times),
                "runs x sample_times x receivers": _study_range_sums,
                "runs x sample_times x receivers^2": _study_solve_work,
                "runs x sample_times^2 x receivers^2": _study_prefix_work,
            },
            caps={
                "runs x sample_times^2 x receivers^2": 60_000_000,
                "runs x sample_times x receivers^2": 3_600_000,
                "runs x sample_times x receivers": 1_200_000,
            },
        ),
        Endpoint(
            "initiation.initiate",
            "/v1/initiation/initiate",
            "Start and confirm tracks from scans of plots in clutter, continuing a state",
            InitiateRequest,
            InitiateResult,
            slow=True,
            work={
                "scans": lambda r: len(r.scans),
                "scans.plots": lambda r: max((len(s.plots) for s in r.scans), default=0),
                "state": lambda r: 0 if r.state is None else r.state.size(),
            },
        ),
        Endpoint(
            "initiation.simulate",
            "/v1/initiation/simulate",
            "Seeded scans of targets in Poisson clutter, every plot labelled",
            SimulateRequest,
            SimulateResult,
            slow=True,
            work={"scenario.scans": lambda r: r.scenario.scans},
        ),
        Endpoint(
            "initiation.evaluate",
            "/v1/initiation/evaluate",
            "Monte Carlo of track initiation: targets initiated, false tracks",
            EvaluateRequest,
            EvaluateResult,
            slow=True,
            work={
                "runs": lambda r: r.runs,
                "scenario.scans": lambda r: r.scenario.scans,
                "scenario.clutter": lambda r: math.ceil(r.scenario.clutter),
                "sweep.values": lambda r: 0 if r.sweep is None else len(r.sweep.values),
                "runs x scans x plots": EvaluateRequest.work,
            },
            # plot-equivalents of about 5.4 us on one core (EvaluateRequest.work): 6.5 s;
            # a cluster takes 30 times as many per worker thread, up to the schema's ceiling
            caps={"runs x scans x plots": EVALUATION_WORK_CAP},
            cluster_caps={"runs x scans x plots": CLUSTER_EVALUATION_WORK},
        ),
        Endpoint(
            "identification.pair",
            "/v1/identification/pair",
            "Is a passive (ESM) track the same object as an active radar track? Fisher's "
            "Z-test on bearings",
            IdentifyPairRequest,
            IdentifyPairResult,
            slow=True,
            work={
                "passive_bearings_deg": lambda r: len(r.passive_bearings_deg),
                "active_bearings_deg": lambda r: len(r.active_bearings_deg),
            },
        ),
        Endpoint(
            "identification.picture",
            "/v1/identification/picture",
            "Z matrix and one-to-one identification of many passive and active tracks",
            IdentifyPictureRequest,
            IdentifyPictureResult,
            slow=True,
            work={
                "passive_deg": lambda r: len(r.passive_deg),
                "active_deg": lambda r: len(r.active_deg),
                "passive_deg x active_deg": lambda r: len(r.passive_deg) * len(r.active_deg),
            },
            # Z, p-values and passes: about 195 bytes a cell in the answer (4,000,000 cells
            # took 1023 MiB of RSS); 2,500,000 take about 720 MiB
            caps={"passive_deg x active_deg": 2_500_000},
        ),
        Endpoint(
            "identification.simulate",
            "/v1/identification/simulate",
            "Kvasnov's experiment by Monte Carlo: realized type I or type II error",
            IdentifySimulateRequest,
            IdentifySimulateResult,
            slow=True,
            work={"runs": lambda r: r.runs, "runs x (n + m)": lambda r: r.runs * (r.n + r.m)},
            # drawn in chunks of 10^6 bearings, so time, not memory, bounds it: 25,000,000
            # bearings take under 1 s of CPU on one core; a cluster gathers one count a
            # chunk, so it may take up to the schema's bound (500 chunks)
            caps={"runs x (n + m)": 25_000_000},
            cluster_caps={"runs x (n + m)": MAX_SIMULATED_SAMPLES},
        ),
    )
}


def work_caps(operator: Mapping[str, Mapping[str, int]]) -> dict[str, dict[str, int]]:
    """The caps a server applies: every operation's defaults (:attr:`Endpoint.caps`) with
    the operator's (``PLOTGATE_LIMITS``) laid over them, size by size.

    An operator's cap wins whether it is lower or higher than the default: raising one
    trades the memory budget for larger requests, knowingly. Entries naming no operation
    are kept as they are, for :func:`plotgate.service.registry.check_limits` to refuse.
    """
    caps = {name: dict(e.caps) for name, e in ENDPOINTS.items() if e.caps}
    for name, sizes in operator.items():
        caps[name] = {**caps.get(name, {}), **sizes}
    return caps
