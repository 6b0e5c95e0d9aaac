"""The gate operations: tests, gating probabilities, analysis and design (Konovalov;
Mu et al.)

Each declaration is the whole of one operation (:class:`~plotgate.service.schemas.Endpoint`):
its name, path and models, its handler and field map (named, imported on first use), its
work sizes and default caps, its description and example, its scene drawer and the
client's method. :mod:`plotgate.service.table` gathers every capability's declarations.
"""

from typing import Any

from plotgate.service.schemas.endpoints import Endpoint, Reference
from plotgate.service.schemas.gates import GatePairsRequest, GateResults, GateTestRequest
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

__all__ = [
    "AXIS_RATIO_CAP",
    "CURVE_AXIS_RATIO_CAP",
    "CURVE_COST_CAP",
    "DESIGN_AXIS_RATIO_CAP",
    "OPERATIONS",
]

_GATES = "plotgate.service.operations.gates"
_PROBABILITY = "plotgate.service.operations.probability"
_SCENES = "plotgate.service.scenes.gates"

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

_CAPTURE = (
    "The capture gates follow Konovalov: the ring R_min <= |d| <= R_max with "
    "R = v tau, the expanded ellipse of semi-axes R_max + K_g sigma, and the combined "
    "two-stage gate (inside the ring, or within the chi-square ellipse of B = P1 + P2 "
    "about the ring's nearest point)."
)


_MARK = {"r": 50_000.0, "az_deg": 0.0, "sigma_r": 200.0, "sigma_az_deg": 0.5}
_RING = {"kind": "ring", "v_min": 100.0, "v_max": 500.0}
_PRIOR = {"kind": "area", "v_min": 100.0, "v_max": 500.0}
_RESOLUTION = {"range": 500.0, "azimuth_deg": 1.5}


def _polar(r: float, az_deg: float) -> dict[str, Any]:
    return {"frame": "polar", "r": r, "az_deg": az_deg, "sigma_r": 200.0, "sigma_az_deg": 0.5}


def _cartesian(x: float, y: float) -> dict[str, Any]:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[40_000.0, 0.0], [0.0, 40_000.0]]}


TEST = Endpoint(
    "gates.test",
    "/v1/gates/test",
    "Test one first plot against many candidate plots",
    GateTestRequest,
    GateResults,
    work={"candidates": lambda r: len(r.candidates)},
    handler=Reference(_GATES, "test"),
    fields=Reference(_GATES, "TEST_FIELDS"),
    drawer=Reference(_SCENES, "test"),
    batch_drawer=Reference("plotgate.service.scenes.batched", "TESTS"),
    client_method="test_gate",
    description=(
        "Tests one first plot z1 against many candidate plots z2: for each candidate, "
        "whether it falls in the gate and the gate's statistic. " + _CAPTURE + " The "
        "prediction gates are the chi-square ellipse nu^T S^-1 nu <= gamma(P_G), the "
        "rectangular gate |dx| <= k sigma_x, |dy| <= k sigma_y (the secondary-processing "
        "textbook) and Mu et al.'s polar sector and first-association windows (eq. 1-4). "
        "Plots are Cartesian (x, y in m with a 2 x 2 covariance in m^2) or polar (range in "
        "m, azimuth in degrees, with their sigmas, about a sensor); `tau` is the interval "
        "between the marks, s. The combined gate also says which stage accepted each mark."
    ),
    example_body={
        "gate": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
        "first": _polar(50_000.0, 0.0),
        "candidates": [
            _polar(51_000.0, 0.5),
            _cartesian(0.0, 52_600.0),
            _cartesian(0.0, 60_000.0),
        ],
    },
)

PAIRS = Endpoint(
    "gates.pairs",
    "/v1/gates/pairs",
    "Test many independent (first, second) plot pairs",
    GatePairsRequest,
    GateResults,
    work={"pairs": lambda r: len(r.pairs)},
    handler=Reference(_GATES, "pairs"),
    fields=Reference(_GATES, "PAIRS_FIELDS"),
    drawer=Reference(_SCENES, "pairs"),
    client_method="test_gate_pairs",
    description=(
        "Tests many independent (first, second) plot pairs against one gate, each pair "
        "with its own first plot: the batch form of `gates.test`, for pairs collected "
        "from many tracks. " + _CAPTURE + " Units and plot forms as in `gates.test`; "
        "index i of every answer array answers pair i."
    ),
    example_body={
        "gate": {"kind": "ring", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
        "pairs": [
            {"first": _polar(50_000.0, 0.0), "second": _polar(51_000.0, 0.5)},
            {"first": _cartesian(0.0, 20_000.0), "second": _cartesian(300.0, 20_400.0)},
        ],
    },
)

PROBABILITY = Endpoint(
    "gates.probability",
    "/v1/gates/probability",
    "Probability that the second mark falls in a gate, for a known velocity or over a speed prior",
    GateProbabilityRequest,
    GateProbabilityResult,
    slow=True,
    work={"mark.axis_ratio": unconditional_axis_ratio},
    caps={"mark.axis_ratio": AXIS_RATIO_CAP},
    handler=Reference(_PROBABILITY, "probability"),
    fields=Reference(_PROBABILITY, "PROBABILITY_FIELDS"),
    drawer=Reference(_SCENES, "probability"),
    client_method="gate_probability",
    description=(
        "The probability that the second mark falls in a capture gate. With `velocity` "
        "(m/s) it is Konovalov's conditional probability, eq. 2: the integral of the "
        "density of d ~ N(v tau, B) over the gate. With `prior` it is the unconditional "
        "probability of eq. 3-6: heading uniform over [0, 2 pi) and speed either weighted "
        "as the paper's eq. 4 (`area`: true position uniform over the ring) or uniform on "
        "[v_min, v_max] (`speed`). Computed by deterministic quadrature along rays (a "
        "closed form in erf) and over direction, not by sampling; the answer carries its "
        "estimated absolute error (target below 1e-6). The mark is at range `r` (m) and "
        "azimuth `az_deg` from the radar, with sigmas in m and degrees; `tau` in s."
    ),
    example_body={"gate": _RING, "mark": _MARK, "tau": 5.0, "prior": _PRIOR},
)

PROBABILITY_CURVE = Endpoint(
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
    handler=Reference(_PROBABILITY, "curve"),
    fields=Reference(_PROBABILITY, "CURVE_FIELDS"),
    drawer=Reference(_SCENES, "curve"),
    client_method="gate_probability_curve",
    description=(
        "Konovalov's gating probability (eq. 2 conditional on a velocity, or eq. 3-6 over "
        "a speed prior) at many values at once: against target speed (m/s, conditional, "
        "at `course_deg` clockwise from north) or against the first mark's range (m, "
        "conditional at `speed` or unconditional over `prior`), each point with its "
        "quadrature error. The curves of the paper's Fig. 2 (ring gate) and Fig. 5 "
        "(combined gate, P_G = 0.9); `plotgate plot fig2` draws them from this operation."
    ),
    example_body={
        "gate": _RING,
        "mark": _MARK,
        "tau": 5.0,
        "against": "speed",
        "values": [100.0, 300.0, 500.0],
        "course_deg": 0.0,
    },
)

ANALYSIS = Endpoint(
    "gates.analysis",
    "/v1/gates/analysis",
    "Gate area, resolution cells, false marks and capture probability",
    GateAnalysisRequest,
    GateAnalysisResult,
    slow=True,
    work={"mark.axis_ratio": unconditional_axis_ratio},
    caps={"mark.axis_ratio": AXIS_RATIO_CAP},
    handler=Reference(_PROBABILITY, "analysis"),
    fields=Reference(_PROBABILITY, "ANALYSIS_FIELDS"),
    drawer=Reference(_SCENES, "analysis"),
    client_method="gate_analysis",
    description=(
        "What a capture gate costs and captures, after Konovalov: its area S (m^2, exact "
        "quadrature; for the combined gate also the paper's approximation S_ring + "
        "S_ellipse / 2), the resolution cells it covers S' = S / (dR R dAz) with R the "
        "first mark's range, the Poisson false marks in it (mean F S', P(at least one) = "
        "1 - exp(-F S')) for a false-alarm probability F per cell, and, with a speed "
        "prior, the unconditional gating probability (eq. 3-6) and the capture "
        "probability P = P_gate P_D1 P_D2. The paper's worked numbers: about 49 cells "
        "for the expanded gate against 31 for the combined one at 50 km."
    ),
    example_body={
        "gate": {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
        "mark": _MARK,
        "tau": 5.0,
        "resolution": _RESOLUTION,
        "false_alarm": 1e-4,
        "m_max": 3,
        "prior": _PRIOR,
        "P_D1": 0.9,
        "P_D2": 0.9,
    },
)

DESIGN = Endpoint(
    "gates.design",
    "/v1/gates/design",
    "Size a combined or expanded gate for a wanted capture probability",
    GateDesignRequest,
    GateDesignResult,
    slow=True,
    work={"mark.axis_ratio": unconditional_axis_ratio},
    # a root search over the gate's parameter: four to ten unconditional probabilities
    caps={"mark.axis_ratio": DESIGN_AXIS_RATIO_CAP},
    handler=Reference(_PROBABILITY, "design"),
    fields=Reference(_PROBABILITY, "DESIGN_FIELDS"),
    drawer=Reference(_SCENES, "design"),
    client_method="gate_design",
    description=(
        "Sizes a capture gate for a wanted capture probability P_gate P_D1 P_D2 over a "
        "speed prior (Konovalov, eq. 3-6): the combined gate's P_G (and its gamma = "
        "chi2.ppf(P_G, 2)) or the expanded gate's p (and K_g = sqrt(-2 ln(1 - p))), found "
        "by Brent's method on the unconditional gating probability, with the gate's area "
        "(m^2), resolution cells and false marks at that size."
    ),
    example_body={
        "gate": {"kind": "expanded", "v_max": 300.0},
        "mark": _MARK,
        "tau": 5.0,
        "capture": 0.9,
        "prior": {"kind": "area", "v_min": 0.0, "v_max": 300.0},
        "P_D1": 0.99,
        "P_D2": 1.0,
        "resolution": _RESOLUTION,
    },
)

OPERATIONS = (
    TEST,
    PAIRS,
    PROBABILITY,
    PROBABILITY_CURVE,
    ANALYSIS,
    DESIGN,
)
