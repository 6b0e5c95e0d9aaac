"""The gate concept: capture, tracking and polar gates, their regions, probabilities,
areas and design, the thresholds they use and the quadrature behind the probabilities.

Modules, one job each:

- :mod:`~plotgate.core.gates.thresholds`: the chi-square threshold and the gate coefficients;
- :mod:`~plotgate.core.gates.results`: :class:`GateResult`, :class:`GateStage`, shared statistics;
- :mod:`~plotgate.core.gates.parameters`: validation of the parameters gates share;
- :mod:`~plotgate.core.gates.capture`: ring, expanded and combined gates (Konovalov);
- :mod:`~plotgate.core.gates.tracking`: ellipse and rectangular gates;
- :mod:`~plotgate.core.gates.polar`: sector and first-association windows (Mu et al.);
- :mod:`~plotgate.core.gates.kinds`: :data:`Gate`, any of the seven kinds;
- :mod:`~plotgate.core.gates.regions`: gating problems and gates as plane regions;
- :mod:`~plotgate.core.gates.probability`: gating probabilities (Konovalov, eq. 1-6);
- :mod:`~plotgate.core.gates.analysis`: areas, false marks, capture probability, design;
- :mod:`~plotgate.core.gates.quadrature`: graded Gauss-Legendre panels.

One gate concept (decision)
---------------------------
Each gate kind is one frozen dataclass (:class:`RingGate`, :class:`ExpandedGate`,
:class:`CombinedGate`, :class:`EllipseGate`, :class:`RectangularGate`,
:class:`SectorGate`, :class:`FirstAssociationGate`) holding its parameters (speeds,
probability, coefficients), with

- ``test(...)``: the vectorized gate test on N pairs of marks, returning a
  :class:`GateResult` (what initiation and the service's ``gates.test`` call); for the
  ellipse, combined, sector and first-association gates a compiled kernel
  (:mod:`plotgate.core.gates.kernels`) that checks and tests each pair in one pass, with
  the numpy ``test_reference`` as its tested oracle and the path that names a bad input;
- ``region(geometry)``: the gate as a plane region of a gating problem, for its
  probability, area and design;
- ``contains(geometry, i, z2)``: the test on problem i of a gating problem, what the
  Monte Carlo check samples.

The former functional API (``ring_gate(z1, z2, tau, v_min, v_max)`` and its six
siblings) is replaced, not kept beside the dataclasses: each function would only
construct the dataclass and call its ``test``, a second spelling of one gate. A one-off
test reads ``RingGate(v_min, v_max).test(z1, z2, tau)``. What varies per call (marks,
covariances, sigmas, tau) is an argument of ``test``; what defines the gate is a field.
Gate parameters are validated when the gate is used (``test`` or ``region``), with the
errors naming them (``v_min``, ``P_G``, ...), as the functions did.

Symbols (SI units; angles in radians)
-------------------------------------
z1, z2 : first and second mark, (2,) or (N, 2), x east / y north in metres.
P1, P2 : their covariances, (2, 2) or (N, 2, 2), in m^2.
d : z2 - z1; B = P1 + P2, the covariance of d (Konovalov, eq. 1).
tau : time between the marks (s); v_min, v_max : speed bounds (m/s).
R_min, R_max : v_min tau and v_max tau, the radii of the ring gate (m).
z, z_pred, S : a mark, its prediction and the innovation covariance; nu = z - z_pred.
rho : squared Mahalanobis distance nu^T S^-1 nu; gamma : its threshold for P_G.
r, az : range (m) and azimuth (rad, clockwise from north) of a polar mark.
"""

from typing import TYPE_CHECKING

from plotgate.core.exports import lazy_exports

if TYPE_CHECKING:
    from plotgate.core.gates.analysis import (
        FalseMarks,
        GateDesign,
        capture_probability,
        combined_area_approximation,
        design_gate,
        false_marks,
        gate_area,
        resolution_cells,
    )
    from plotgate.core.gates.capture import CombinedGate, ExpandedGate, RingGate
    from plotgate.core.gates.kinds import Gate
    from plotgate.core.gates.polar import FirstAssociationGate, SectorGate
    from plotgate.core.gates.probability import (
        GateProbability,
        conditional_probability,
        monte_carlo_probability,
        unconditional_probability,
    )
    from plotgate.core.gates.regions import MarkGeometry, StarRegion, mark_geometry
    from plotgate.core.gates.results import GateResult, GateStage
    from plotgate.core.gates.thresholds import (
        expansion_coefficient,
        gate_threshold,
        rectangular_coefficient,
    )
    from plotgate.core.gates.tracking import EllipseGate, RectangularGate, innovation_covariance

__all__ = [
    "CombinedGate",
    "EllipseGate",
    "ExpandedGate",
    "FalseMarks",
    "FirstAssociationGate",
    "Gate",
    "GateDesign",
    "GateProbability",
    "GateResult",
    "GateStage",
    "MarkGeometry",
    "RectangularGate",
    "RingGate",
    "SectorGate",
    "StarRegion",
    "capture_probability",
    "combined_area_approximation",
    "conditional_probability",
    "design_gate",
    "expansion_coefficient",
    "false_marks",
    "gate_area",
    "gate_threshold",
    "innovation_covariance",
    "mark_geometry",
    "monte_carlo_probability",
    "rectangular_coefficient",
    "resolution_cells",
    "unconditional_probability",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "plotgate.core.gates.analysis": (
            "FalseMarks",
            "GateDesign",
            "capture_probability",
            "combined_area_approximation",
            "design_gate",
            "false_marks",
            "gate_area",
            "resolution_cells",
        ),
        "plotgate.core.gates.capture": (
            "CombinedGate",
            "ExpandedGate",
            "RingGate",
        ),
        "plotgate.core.gates.kinds": ("Gate",),
        "plotgate.core.gates.polar": (
            "FirstAssociationGate",
            "SectorGate",
        ),
        "plotgate.core.gates.probability": (
            "GateProbability",
            "conditional_probability",
            "monte_carlo_probability",
            "unconditional_probability",
        ),
        "plotgate.core.gates.regions": (
            "MarkGeometry",
            "StarRegion",
            "mark_geometry",
        ),
        "plotgate.core.gates.results": (
            "GateResult",
            "GateStage",
        ),
        "plotgate.core.gates.thresholds": (
            "expansion_coefficient",
            "gate_threshold",
            "rectangular_coefficient",
        ),
        "plotgate.core.gates.tracking": (
            "EllipseGate",
            "RectangularGate",
            "innovation_covariance",
        ),
    },
)
