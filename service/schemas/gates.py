"""Wire models of the gates, and of the gate-test operations (Konovalov; Mu et al.).

Each gate kind's parameters (names, bounds, defaults) are declared once, in one model per
kind; its two uses on the wire differ only by what the operation adds to it:

- a gate test (:data:`Gate`, the ``*Gate`` models) also carries ``tau`` for the kinds
  that need it (ring, expanded, combined, first association);
- a gating probability (:data:`GateRegion`, the ``*Region`` models, named after the plane
  regions the probabilities integrate over) takes tau from its request, and the
  tracking gates (ellipse, rectangular, sector) also take the predicted displacement
  ``offset`` = z_pred - z1 instead of a predicted plot.

So a capture gate's test model extends its region model by ``tau``, and a tracking
gate's region model extends its test model by ``offset``. Both become core's gate of the
kind in one place, :func:`plotgate.service.operations.gate_conversion.core_gate`.

A gate is chosen by ``kind``. For the capture gates (``ring``, ``expanded``,
``combined``) the first plot is the initiator z1 and the candidates are second marks
z2 taken ``tau`` seconds later. For the tracking gates (``ellipse``, ``rectangular``,
``sector``) the first plot is the predicted position with its predicted covariance
H P H^T, and S = P_first + P_candidate. ``first_association`` is the polar window for
the first association of Mu et al., before a velocity is known.
"""

from typing import Annotated, Literal

from pydantic import Field

from plotgate.service.schemas.common import MAX_PLOTS, Plot, Position, Schema

__all__ = [
    "CombinedGate",
    "CombinedRegion",
    "DesignGate",
    "ExpandedGate",
    "ExpandedRegion",
    "EllipseGate",
    "EllipseRegion",
    "FirstAssociationGate",
    "FirstAssociationRegion",
    "Gate",
    "GatePair",
    "GatePairsRequest",
    "GateParameters",
    "GateRegion",
    "GateResults",
    "GateTestRequest",
    "RectangularGate",
    "RectangularRegion",
    "RingGate",
    "RingRegion",
    "SectorGate",
    "SectorRegion",
    "Stage",
]

Stage = Literal["none", "ring", "inner_ellipse", "outer_ellipse"]
"""Combined-gate stage that accepted a mark (Konovalov): GateStage values 0..3 by name."""

Probability = Annotated[float, Field(gt=0, lt=1)]
Seconds = Annotated[float, Field(gt=0, le=1e6, description="Interval tau between the marks, s.")]
Speed = Annotated[float, Field(ge=0, le=1e6, description="Target speed bound, m/s.")]
Coefficient = Annotated[float, Field(ge=0.01, le=100, description="Window width in sigmas.")]


Offset = Annotated[
    Position,
    Field(description="Predicted displacement z_pred - z1 (x east, y north), m."),
]


class RingRegion(Schema):
    """Ring v_min tau <= |z2 - z1| <= v_max tau (Konovalov, Fig. 1)."""

    kind: Literal["ring"] = Field(description="Discriminator: ring gate.")
    v_min: Speed = Field(default=0.0, description="Smallest target speed, m/s.")
    v_max: Speed = Field(description="Largest target speed, m/s.")


class RingGate(RingRegion):
    """Ring v_min tau <= |z2 - z1| <= v_max tau (Konovalov, Fig. 1), tested after tau."""

    tau: Seconds


class ExpandedRegion(Schema):
    """Ellipse with semi-axes v_max tau + K_g sigma along and across the line of sight."""

    kind: Literal["expanded"] = Field(description="Discriminator: expanded ellipse gate.")
    v_max: Speed = Field(description="Largest target speed, m/s.")
    p: float = Field(
        default=0.9,
        ge=1e-6,
        lt=1,
        description="Probability p giving K_g = sqrt(-2 ln(1-p)) (Konovalov, his ref. [4]); "
        "below 1e-6 the gate would grow by less than a thousandth of a sigma.",
    )


class ExpandedGate(ExpandedRegion):
    """The expanded ellipse gate, tested after tau."""

    tau: Seconds


class CombinedRegion(Schema):
    """Two-stage gate of Konovalov (Fig. 4): the ring, else the P_G ellipse of B at its edge."""

    kind: Literal["combined"] = Field(description="Discriminator: combined two-stage gate.")
    v_min: Speed = Field(default=0.0, description="Smallest target speed, m/s.")
    v_max: Speed = Field(description="Largest target speed, m/s.")
    P_G: Probability = Field(
        default=0.9, description="Gating probability of the second stage's ellipse."
    )


class CombinedGate(CombinedRegion):
    """The two-stage combined gate, tested after tau."""

    tau: Seconds


class EllipseGate(Schema):
    """Chi-square prediction gate nu^T S^-1 nu <= gamma(P_G)."""

    kind: Literal["ellipse"] = Field(description="Discriminator: chi-square ellipse gate.")
    P_G: Probability = Field(default=0.99, description="Gating probability.")


class EllipseRegion(EllipseGate):
    """The chi-square prediction gate about z1 + offset, S = B."""

    offset: Offset = (0.0, 0.0)


class RectangularGate(Schema):
    """|dx| <= k sigma_x and |dy| <= k sigma_y (the secondary-processing textbook)."""

    kind: Literal["rectangular"] = Field(description="Discriminator: rectangular gate.")
    k: Coefficient = Field(default=3.0, description="Half-width in sigmas.")


class RectangularRegion(RectangularGate):
    """The rectangular gate about z1 + offset, sigmas from B."""

    offset: Offset = (0.0, 0.0)


class SectorGate(Schema):
    """Polar sector |dr| <= K_R s_r, |d az| <= K_az s_az (Mu et al., eq. 1-2)."""

    kind: Literal["sector"] = Field(description="Discriminator: polar sector gate.")
    K_R: Coefficient = Field(default=3.0, description="Range window in summed sigmas.")
    K_az: Coefficient = Field(default=3.0, description="Azimuth window in summed sigmas.")


class SectorRegion(SectorGate):
    """The polar sector about the prediction z1 + offset."""

    offset: Offset = (0.0, 0.0)


class FirstAssociationRegion(Schema):
    """Mu et al.'s first-association windows (eq. 3-4): v_max tau plus the errors."""

    kind: Literal["first_association"] = Field(
        description="Discriminator: first-association polar window."
    )
    v_max: Speed = Field(description="Largest target speed, m/s.")
    K_R: Coefficient = Field(default=3.0, description="Range error window in sigmas.")
    K_az: Coefficient = Field(default=3.0, description="Azimuth error window in sigmas.")


class FirstAssociationGate(FirstAssociationRegion):
    """The first-association windows, tested after tau."""

    tau: Seconds


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
"""A gate of the gate tests: its parameters and the interval tau between the marks."""

GateRegion = Annotated[
    RingRegion
    | CombinedRegion
    | ExpandedRegion
    | EllipseRegion
    | RectangularRegion
    | SectorRegion
    | FirstAssociationRegion,
    Field(discriminator="kind", description="The gate, chosen by kind; tau is the request's."),
]
"""A gate of the gating probabilities: its parameters and, for a tracking gate, its
prediction's offset from the first mark."""

DesignGate = Annotated[
    CombinedRegion | ExpandedRegion,
    Field(
        discriminator="kind",
        description="The gate to size: combined (its P_G is found) or expanded (its p is "
        "found); the given P_G or p is only a template and may be omitted.",
    ),
]
"""A gate ``gates.design`` sizes."""

GateParameters = (
    RingRegion
    | ExpandedRegion
    | CombinedRegion
    | EllipseGate
    | RectangularGate
    | SectorGate
    | FirstAssociationRegion
)
"""Any wire gate, of either use, as the model of its kind's parameters (the other use's
model extends it): what the service converts to core's gate."""


class GateTestRequest(Schema):
    """One first plot tested against many candidates."""

    gate: Gate = Field(
        description="The gate and its parameters; `kind` names it (ring, expanded, combined, "
        "ellipse, rectangular, sector, first_association)."
    )
    first: Plot = Field(
        description="The first plot (mark) z1, or the predicted position for the "
        "prediction gates (ellipse, rectangular, sector): the gate is centred on it."
    )
    candidates: list[Plot] = Field(
        min_length=1,
        max_length=MAX_PLOTS,
        description="The second plots z2 tested against the gate, each answered at its index.",
    )


class GatePair(Schema):
    """One independent (first, second) pair."""

    first: Plot = Field(description="The pair's first plot z1 (or predicted position).")
    second: Plot = Field(description="The pair's second plot z2, tested against the gate.")


class GatePairsRequest(Schema):
    """Many independent pairs, each with its own first plot."""

    gate: Gate = Field(
        description="The gate and its parameters, the same for every pair; `kind` names it."
    )
    pairs: list[GatePair] = Field(
        min_length=1,
        max_length=MAX_PLOTS,
        description="Independent (first, second) pairs, each answered at its index.",
    )


class GateResults(Schema):
    """Per-candidate results, index i answering candidate (or pair) i."""

    kind: str = Field(description="The gate kind tested.")
    statistic_name: str = Field(description="What `statistic` measures, with its unit.")
    threshold: float = Field(
        description="Upper bound on statistic; the ring gate also needs statistic >= v_min tau."
    )
    inside: list[bool] = Field(description="Whether candidate (or pair) i is in the gate.")
    statistic: list[float] = Field(
        description="The gate's statistic for candidate (or pair) i, in the unit "
        "`statistic_name` gives; inside when it is at most `threshold`."
    )
    stage: list[Stage] | None = Field(
        default=None, description="Combined gate only: the stage that accepted each mark."
    )
    count_inside: int = Field(description="How many candidates (or pairs) are inside.")
