"""Wire models of the gate-test operations (Konovalov).

A gate is chosen by ``kind``. For the capture gates (``ring``, ``expanded``,
``combined``) the first plot is the initiator z1 and the candidates are second marks
z2 taken ``tau`` seconds later. For the tracking gates (``ellipse``, ``rectangular``,
``sector``) the first plot is the predicted position with its predicted covariance
H P H^T, and S = P_first + P_candidate. ``first_association`` is the polar window for
the first association of Mu et al., before a velocity is known.
"""

from typing import Annotated, Literal

from pydantic import Field

from plotgate.service.schemas.common import MAX_PLOTS, Plot, Schema

__all__ = [
    "CombinedGate",
    "ExpandedGate",
    "EllipseGate",
    "FirstAssociationGate",
    "Gate",
    "GatePair",
    "GatePairsRequest",
    "GateResults",
    "GateTestRequest",
    "RectangularGate",
    "RingGate",
    "SectorGate",
    "Stage",
]

Stage = Literal["none", "ring", "inner_ellipse", "outer_ellipse"]
"""Combined-gate stage that accepted a mark (Konovalov): GateStage values 0..3 by name."""

Probability = Annotated[float, Field(gt=0, lt=1)]
Seconds = Annotated[float, Field(gt=0, le=1e6, description="Interval tau between the marks, s.")]
Speed = Annotated[float, Field(ge=0, le=1e6, description="Target speed bound, m/s.")]
Coefficient = Annotated[float, Field(ge=0.01, le=100, description="Window width in sigmas.")]


class RingGate(Schema):
    """Ring v_min tau <= |z2 - z1| <= v_max tau (Konovalov, Fig. 1)."""

    kind: Literal["ring"]
    tau: Seconds
    v_min: Speed = 0.0
    v_max: Speed


class ExpandedGate(Schema):
    """Ellipse with semi-axes v_max tau + K_g sigma along and across the line of sight."""

    kind: Literal["expanded"]
    tau: Seconds
    v_max: Speed
    p: float = Field(
        default=0.9,
        ge=1e-6,
        lt=1,
        description="Probability p giving K_g = sqrt(-2 ln(1-p)); below 1e-6 the gate "
        "would grow by less than a thousandth of a sigma.",
    )


class CombinedGate(Schema):
    """Two-stage gate of Konovalov: the ring, else a chi-square ellipse at the ring's edge."""

    kind: Literal["combined"]
    tau: Seconds
    v_min: Speed = 0.0
    v_max: Speed
    P_G: Probability = Field(default=0.9, description="Ellipse gating probability.")


class EllipseGate(Schema):
    """Chi-square prediction gate nu^T S^-1 nu <= gamma(P_G)."""

    kind: Literal["ellipse"]
    P_G: Probability = Field(default=0.99, description="Gating probability.")


class RectangularGate(Schema):
    """|dx| <= k sigma_x and |dy| <= k sigma_y, sigmas from S (secondary-processing textbook)."""

    kind: Literal["rectangular"]
    k: Coefficient = 3.0


class SectorGate(Schema):
    """Polar sector |dr| <= K_R s_r, |d az| <= K_az s_az about the first plot's sensor."""

    kind: Literal["sector"]
    K_R: Coefficient = 3.0
    K_az: Coefficient = 3.0


class FirstAssociationGate(Schema):
    """Mu et al.'s first-association window: v_max tau plus the errors, in range and azimuth."""

    kind: Literal["first_association"]
    tau: Seconds
    v_max: Speed
    K_R: Coefficient = 3.0
    K_az: Coefficient = 3.0


Gate = Annotated[
    RingGate
    | ExpandedGate
    | CombinedGate
    | EllipseGate
    | RectangularGate
    | SectorGate
    | FirstAssociationGate,
    Field(discriminator="kind"),
]


class GateTestRequest(Schema):
    """One first plot tested against many candidates."""

    gate: Gate
    first: Plot
    candidates: list[Plot] = Field(min_length=1, max_length=MAX_PLOTS)


class GatePair(Schema):
    """One independent (first, second) pair."""

    first: Plot
    second: Plot


class GatePairsRequest(Schema):
    """Many independent pairs, each with its own first plot."""

    gate: Gate
    pairs: list[GatePair] = Field(min_length=1, max_length=MAX_PLOTS)


class GateResults(Schema):
    """Per-candidate results, index i answering candidate (or pair) i."""

    kind: str = Field(description="The gate kind tested.")
    statistic_name: str = Field(description="What `statistic` measures, with its unit.")
    threshold: float = Field(
        description="Upper bound on statistic; the ring gate also needs statistic >= v_min tau."
    )
    inside: list[bool]
    statistic: list[float]
    stage: list[Stage] | None = Field(
        default=None, description="Combined gate only: the stage that accepted each mark."
    )
    count_inside: int
