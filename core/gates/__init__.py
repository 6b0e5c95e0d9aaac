"""The gate concept: capture, tracking and polar gates, their regions, probabilities,
areas and design, the thresholds they use and the quadrature behind the probabilities.

Modules, one job each:

- :mod:`~plotgate.core.gates.thresholds`: the chi-square threshold and the gate coefficients;
- :mod:`~plotgate.core.gates.results`: :class:`GateResult`, :class:`GateStage`, shared statistics;
- :mod:`~plotgate.core.gates.parameters`: validation of the parameters gates share;
- :mod:`~plotgate.core.gates.capture`: ring, expanded and combined gates (Konovalov);
- :mod:`~plotgate.core.gates.tracking`: ellipse and rectangular gates;
- :mod:`~plotgate.core.gates.polar`: sector and first-association windows (Mu et al.);
- :mod:`~plotgate.core.gates.regions`: gating problems and gates as plane regions;
- :mod:`~plotgate.core.gates.probability`: gating probabilities (Konovalov, eq. 1-6);
- :mod:`~plotgate.core.gates.analysis`: areas, false marks, capture probability, design;
- :mod:`~plotgate.core.gates.quadrature`: graded Gauss-Legendre panels.

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
from plotgate.core.gates.capture import combined_gate, expanded_gate, ring_gate
from plotgate.core.gates.polar import first_association_gate, sector_gate
from plotgate.core.gates.probability import (
    GateProbability,
    conditional_probability,
    monte_carlo_probability,
    unconditional_probability,
)
from plotgate.core.gates.regions import (
    CombinedGate,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    Gate,
    MarkGeometry,
    RectangularGate,
    RingGate,
    SectorGate,
    StarRegion,
    mark_geometry,
)
from plotgate.core.gates.results import GateResult, GateStage
from plotgate.core.gates.thresholds import (
    expansion_coefficient,
    gate_threshold,
    rectangular_coefficient,
)
from plotgate.core.gates.tracking import ellipse_gate, innovation_covariance, rectangular_gate

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
    "combined_gate",
    "conditional_probability",
    "design_gate",
    "ellipse_gate",
    "expanded_gate",
    "expansion_coefficient",
    "false_marks",
    "first_association_gate",
    "gate_area",
    "gate_threshold",
    "innovation_covariance",
    "mark_geometry",
    "monte_carlo_probability",
    "rectangular_coefficient",
    "rectangular_gate",
    "resolution_cells",
    "ring_gate",
    "sector_gate",
    "unconditional_probability",
]
