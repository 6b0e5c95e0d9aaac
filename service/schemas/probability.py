"""Wire models of the gating-probability operations (Konovalov, eq. 1-6).

A problem is a first mark at range r and azimuth az from the radar, both marks' range
and azimuth errors, the interval ``tau`` between the marks, and a gate built about the
first mark: a :data:`plotgate.service.schemas.gates.GateRegion`, without ``tau`` (the
request carries it) and, for a tracking gate, with the predicted displacement ``offset``.

Operations: ``gates.probability`` (one probability, conditional on a velocity, eq. 2, or
unconditional over a speed prior, eq. 3-6), ``gates.probability_curve`` (a probability
against speed or range), ``gates.analysis`` (area, resolution cells, false marks and
capture probability of a gate) and ``gates.design`` (the combined gate's P_G or the
expanded gate's p that reaches a wanted capture probability).

Rules that concern several fields (exactly one of ``velocity`` and ``prior``; what a curve
needs for each ``against``; the value-count limits) are model validators that answer 422
naming the offending field.
"""

import math
from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from plotgate.service.schemas.common import MAX_DISTANCE, MIN_RANGE, Loc, Schema, invalid
from plotgate.service.schemas.gates import DesignGate, GateRegion, Probability, Seconds, Speed

__all__ = [
    "MAX_CURVE_POINTS",
    "MAX_SPEED",
    "MAX_UNCONDITIONAL_POINTS",
    "GATE_COST",
    "AreaApproximation",
    "FalseMarks",
    "GateAnalysisRequest",
    "GateAnalysisResult",
    "GateDesignRequest",
    "GateDesignResult",
    "GateProbabilityCurve",
    "GateProbabilityCurveRequest",
    "GateProbabilityRequest",
    "GateProbabilityResult",
    "Mark",
    "Resolution",
    "SpeedPrior",
    "Velocity",
    "unconditional_axis_ratio",
    "unconditional_cost",
]

MAX_CURVE_POINTS = 1000
"""Most values of a conditional curve (each costs a one-dimensional quadrature)."""
MAX_UNCONDITIONAL_POINTS = 100
"""Most values of an unconditional curve (each costs about a second of quadrature)."""
MAX_SPEED = 1e6
"""Largest speed, m/s, as the gate schemas allow."""

Angle = Annotated[float, Field(ge=-360, le=360)]
DetectionProbability = Annotated[float, Field(gt=0, le=1)]
CurveValue = Annotated[float, Field(ge=0, le=MAX_DISTANCE)]


class Mark(Schema):
    """The first mark, seen from a radar at the origin, and both marks' errors."""

    r: float = Field(ge=MIN_RANGE, le=MAX_DISTANCE, description="Range of the first mark, m.")
    az_deg: Angle = Field(default=0.0, description="Its azimuth, degrees clockwise from north.")
    sigma_r: float = Field(ge=1e-3, le=MAX_DISTANCE, description="Range error sigma, m.")
    sigma_az_deg: float = Field(ge=1e-6, le=180, description="Azimuth error sigma, degrees.")
    sigma_r2: float | None = Field(
        default=None,
        ge=1e-3,
        le=MAX_DISTANCE,
        description="The second mark's range sigma, m; null: equal to the first's.",
    )
    sigma_az2_deg: float | None = Field(
        default=None,
        ge=1e-6,
        le=180,
        description="The second mark's azimuth sigma, degrees; null: equal to the first's.",
    )

    def axis_ratio(self, r: float | None = None) -> float:
        """sqrt(lambda_max / lambda_min) of B = P1 + P2, the covariance of z2 - z1.

        Both marks are seen at range ``r`` (default the mark's own), so B has
        sigma_r^2 + sigma_r2^2 along the line of sight and r^2 (sigma_az^2 + sigma_az2^2)
        across it (the polar-to-Cartesian Jacobian): those are its eigenvalues.
        """
        r = self.r if r is None else r
        along = self.sigma_r**2 + (self.sigma_r if self.sigma_r2 is None else self.sigma_r2) ** 2
        az2 = self.sigma_az_deg if self.sigma_az2_deg is None else self.sigma_az2_deg
        across = (r * math.radians(self.sigma_az_deg)) ** 2 + (r * math.radians(az2)) ** 2
        return math.sqrt(max(along, across) / min(along, across))


class Velocity(Schema):
    """A known target velocity: v = speed (sin course, cos course), x east, y north."""

    speed: Speed = Field(description="Target speed, m/s.")
    course_deg: Angle = Field(default=0.0, description="Course, degrees clockwise from north.")


class SpeedPrior(Schema):
    """Uniform heading and a speed on [v_min, v_max] (Konovalov, eq. 3-6)."""

    kind: Literal["area", "speed"] = Field(
        default="area",
        description="area: the true displacement uniform over the ring (the paper's eq. 4, "
        "speed density proportional to v); speed: the speed uniform.",
    )
    v_min: Speed = Field(default=0.0, description="Smallest target speed, m/s.")
    v_max: Speed = Field(description="Largest target speed, m/s.")


class Resolution(Schema):
    """The radar's resolution: a cell is range x (R azimuth) at the first mark's range R."""

    range: float = Field(
        ge=1e-3,
        le=MAX_DISTANCE,
        description="Range resolution dR, m, at least 1 mm (as sigma_r): finer, a gate's "
        "S / (dR R dAz) resolution cells could overflow double precision.",
    )
    azimuth_deg: float = Field(
        ge=1e-6,
        le=360,
        description="Azimuth resolution dAz, degrees, at least 1e-6 (as sigma_az_deg).",
    )


class GateProbabilityRequest(Schema):
    """One gating probability: conditional on ``velocity`` or unconditional over ``prior``."""

    gate: GateRegion
    mark: Mark = Field(
        description="The first mark (range and azimuth from the radar) and both marks' "
        "errors, which set B = P1 + P2."
    )
    tau: Seconds
    velocity: Velocity | None = Field(
        default=None, description="Known velocity: the conditional probability (eq. 2)."
    )
    prior: SpeedPrior | None = Field(
        default=None, description="Speed prior: the unconditional probability (eq. 3-6)."
    )

    @model_validator(mode="after")
    def _one_of(self) -> "GateProbabilityRequest":
        if (self.velocity is None) == (self.prior is None):
            reason = "give exactly one of velocity and prior"
            raise invalid(
                type(self).__name__,
                [(("velocity",), reason, self.velocity), (("prior",), reason, self.prior)],
            )
        return self


class GateProbabilityResult(Schema):
    """The probability that the second mark falls in the gate."""

    conditional: bool = Field(description="True for a known velocity, false over a prior.")
    probability: float = Field(description="Gating probability.")
    error: float = Field(description="Estimated absolute quadrature error.")


class GateProbabilityCurveRequest(Schema):
    """A gating probability against target speed, or against the first mark's range.

    against = speed: ``values`` are speeds (m/s) at ``course_deg``, conditional;
    ``speed`` and ``prior`` must be absent. against = range: ``values`` are ranges of the
    first mark (m, replacing ``mark.r``); conditional with ``speed`` (at ``course_deg``),
    unconditional with ``prior``: exactly one. At most :data:`MAX_CURVE_POINTS` values,
    :data:`MAX_UNCONDITIONAL_POINTS` for an unconditional curve.
    """

    gate: GateRegion
    mark: Mark = Field(
        description="The first mark (range and azimuth from the radar) and both marks' "
        "errors, which set B = P1 + P2."
    )
    tau: Seconds
    against: Literal["speed", "range"] = Field(description="What the values are.")
    values: list[CurveValue] = Field(
        min_length=1,
        max_length=MAX_CURVE_POINTS,
        description="Speeds (m/s) or ranges of the first mark (m).",
    )
    course_deg: Angle = Field(default=0.0, description="Course, degrees clockwise from north.")
    speed: Speed | None = Field(
        default=None, description="Target speed of a conditional range curve, m/s."
    )
    prior: SpeedPrior | None = Field(
        default=None, description="Speed prior of an unconditional range curve."
    )

    @property
    def conditional(self) -> bool:
        return self.prior is None

    @model_validator(mode="after")
    def _rules(self) -> "GateProbabilityCurveRequest":
        errors: list[tuple[Loc, str, Any]] = []
        if self.against == "speed":
            for name in ("speed", "prior"):
                if getattr(self, name) is not None:
                    errors.append(
                        (
                            (name,),
                            "must be absent when against is speed: the values are the speeds",
                            getattr(self, name),
                        )
                    )
            errors += [
                (("values", i), f"a speed must not exceed {MAX_SPEED:g} m/s", v)
                for i, v in enumerate(self.values)
                if v > MAX_SPEED
            ]
        else:
            if (self.speed is None) == (self.prior is None):
                reason = "give exactly one of speed and prior when against is range"
                errors += [(("speed",), reason, self.speed), (("prior",), reason, self.prior)]
            errors += [
                (("values", i), f"a range must be at least {MIN_RANGE:g} m", v)
                for i, v in enumerate(self.values)
                if v < MIN_RANGE
            ]
            if self.prior is not None and len(self.values) > MAX_UNCONDITIONAL_POINTS:
                errors.append(
                    (
                        ("values",),
                        f"an unconditional curve takes at most "
                        f"{MAX_UNCONDITIONAL_POINTS} values, got {len(self.values)}",
                        len(self.values),
                    )
                )
        if errors:
            raise invalid(type(self).__name__, errors)
        return self


class GateProbabilityCurve(Schema):
    """Gating probabilities, index i answering values[i]."""

    against: Literal["speed", "range"] = Field(description="What the values are.")
    values: list[float] = Field(description="The speeds (m/s) or ranges (m), as given.")
    conditional: bool = Field(description="True for a known velocity, false over a prior.")
    probability: list[float] = Field(description="Gating probability at each value.")
    error: list[float] = Field(description="Estimated absolute quadrature error of each.")


class FalseMarks(Schema):
    """Poisson false marks in a gate of S' cells: mean F S' (Konovalov)."""

    mean: float = Field(description="Expected number F S' of false marks in the gate.")
    probabilities: list[float] = Field(
        description="P(exactly m false marks) for m = 0..m_max: exp(-F S') (F S')^m / m!."
    )
    at_least_one: float = Field(description="P(at least one) = 1 - exp(-F S').")


class AreaApproximation(Schema):
    """The paper's combined-gate area S_ring + S_ellipse / 2 and what follows from it."""

    area: float = Field(description="Approximate gate area, m^2.")
    cells: float = Field(description="Resolution cells S' it covers.")
    false_marks: FalseMarks = Field(
        description="Poisson false marks in the gate: mean F S' and P(exactly m), m = 0..m_max."
    )


class GateAnalysisRequest(Schema):
    """Area, resolution cells, false marks and (with a prior) capture probability of a gate."""

    gate: GateRegion
    mark: Mark = Field(
        description="The first mark (range and azimuth from the radar) and both marks' "
        "errors, which set B = P1 + P2."
    )
    tau: Seconds
    resolution: Resolution = Field(
        description="The radar's range and azimuth resolution, which size a resolution cell."
    )
    false_alarm: Probability = Field(
        default=1e-4, description="False-alarm probability F per resolution cell."
    )
    m_max: int = Field(
        default=5, ge=0, le=1000, description="Largest false-mark count given a probability."
    )
    prior: SpeedPrior | None = Field(
        default=None,
        description="Speed prior: also compute the unconditional gating and "
        "capture probabilities.",
    )
    P_D1: DetectionProbability = Field(
        default=1.0, description="Detection probability of the first mark."
    )
    P_D2: DetectionProbability = Field(
        default=1.0, description="Detection probability of the second mark."
    )


class GateAnalysisResult(Schema):
    """What a gate costs in false marks and, with a prior, what it captures."""

    area: float = Field(description="Gate area S, m^2 (exact quadrature).")
    cells: float = Field(description="Resolution cells S' = S / (dR R dAz).")
    false_marks: FalseMarks = Field(
        description="Poisson false marks in the gate: mean F S' and P(exactly m), m = 0..m_max."
    )
    approximation: AreaApproximation | None = Field(
        default=None, description="Combined gate only: the paper's approximate area."
    )
    gate_probability: float | None = Field(
        default=None, description="Unconditional gating probability (with a prior)."
    )
    error: float | None = Field(
        default=None, description="Its estimated absolute quadrature error."
    )
    capture: float | None = Field(
        default=None, description="Capture probability P_gate P_D1 P_D2 (with a prior)."
    )


class GateDesignRequest(Schema):
    """Size a combined or expanded gate for a wanted unconditional capture probability."""

    gate: DesignGate
    mark: Mark = Field(
        description="The first mark (range and azimuth from the radar) and both marks' "
        "errors, which set B = P1 + P2."
    )
    tau: Seconds
    capture: Probability = Field(description="Wanted capture probability P_gate P_D1 P_D2.")
    prior: SpeedPrior = Field(
        description="Speed prior of the unconditional gating probability (Konovalov, eq. 3-6)."
    )
    P_D1: DetectionProbability = Field(
        default=1.0, description="Detection probability of the first mark."
    )
    P_D2: DetectionProbability = Field(
        default=1.0, description="Detection probability of the second mark."
    )
    resolution: Resolution = Field(
        description="The radar's range and azimuth resolution, which size a resolution cell."
    )
    false_alarm: Probability = Field(
        default=1e-4, description="False-alarm probability F per resolution cell."
    )


class GateDesignResult(Schema):
    """The gate parameter found, and the gate it gives."""

    parameter: Literal["P_G", "p"] = Field(
        description="P_G for the combined gate, p for the expanded gate."
    )
    value: float = Field(description="The parameter's value.")
    threshold: float = Field(
        description="gamma = chi2.ppf(P_G, 2) (combined) or K_g = sqrt(-2 ln(1-p)) "
        "(expanded, in sigmas)."
    )
    probability: float = Field(description="Unconditional gating probability of the gate.")
    error: float = Field(description="Its estimated absolute quadrature error.")
    capture: float = Field(description="Capture probability P_gate P_D1 P_D2.")
    area: float = Field(description="Gate area, m^2.")
    cells: float = Field(description="Resolution cells S' it covers.")
    false_marks: FalseMarks = Field(description="False marks in the gate (m_max = 5).")


GATE_COST = {"first_association": 3}
"""What one unconditional probability costs with each gate kind, relative to the ring's
(1 for every kind not named): the polar first-association window, whose origin is the
radar, took 3 times the ring's worst time over the prior's widths, and up to 25 times at
the paper's example (``bench/bench_worst_requests.py``)."""


def unconditional_cost(request: GateProbabilityCurveRequest) -> int:
    """The work size ``values x gate cost`` of a curve: its unconditional probabilities, each
    weighted by its gate kind's :data:`GATE_COST`; 0 for a conditional curve (a thousand
    conditional points cost a third of a second)."""
    if request.prior is None:
        return 0
    return len(request.values) * GATE_COST.get(request.gate.kind, 1)


def unconditional_axis_ratio(
    request: GateProbabilityRequest
    | GateProbabilityCurveRequest
    | GateAnalysisRequest
    | GateDesignRequest,
) -> int:
    """The work size ``mark.axis_ratio``: the largest axis ratio of B (rounded up) over the
    request's unconditional probabilities, 1 when it asks for none.

    The unconditional quadrature grades its panels towards the thin features of an
    eccentric B, so its cost grows steeply with the ratio (about 0.1 s at 2, seconds at
    20, minutes at 10^3 and beyond; ``bench/HISTORY.md``); conditional probabilities and
    areas cost milliseconds at any ratio.
    """
    if request.prior is None:
        return 1
    ranges = (
        request.values
        if isinstance(request, GateProbabilityCurveRequest) and request.against == "range"
        else [request.mark.r]
    )
    return math.ceil(max(request.mark.axis_ratio(r) for r in ranges))
