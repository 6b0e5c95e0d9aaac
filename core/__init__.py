"""plotgate core: stateless gating mathematics for radar track initiation.

Pure functions over numpy arrays (numpy and scipy only; no I/O, no state): frame
conversions, gate thresholds and the gates of the papers (:mod:`plotgate.core.gates`),
vectorized over a leading batch axis of N plots or pairs. Bad input raises a
:class:`PlotgateError` subclass naming the argument.

Symbols (SI units; angles in radians)
-------------------------------------
z, z1, z2 : mark positions, (2,) or (N, 2), x east / y north (m).
P, P1, P2 : mark covariances, (2, 2) or (N, 2, 2) (m^2).
d : z2 - z1; B = P1 + P2, its covariance.
tau : time between marks (s); v_min, v_max : speed bounds (m/s).
R_min, R_max : v_min tau, v_max tau, the ring radii (m).
nu, S, rho : innovation, its covariance, and rho = nu^T S^-1 nu.
P_G, gamma : gating probability and the chi-square threshold on rho.
p, K_g : probability and expansion coefficient of the expanded gate.
r, az : range (m) and azimuth, clockwise from north: x = r sin az, y = r cos az.
K_R, K_az : window coefficients of the polar sector gates.
"""

from typing import TYPE_CHECKING

from plotgate.core.errors import (
    CovarianceError,
    GeometryError,
    NonFiniteError,
    ParameterError,
    PlotgateError,
)
from plotgate.core.exports import lazy_exports

if TYPE_CHECKING:
    from plotgate.core.covariance import MAX_CONDITION, check_covariance
    from plotgate.core.frames import (
        cartesian_covariance_to_polar,
        cartesian_to_polar,
        polar_covariance_to_cartesian,
        polar_to_cartesian,
        wrap_angle,
    )
    from plotgate.core.gates import (
        CombinedGate,
        EllipseGate,
        ExpandedGate,
        FalseMarks,
        FirstAssociationGate,
        Gate,
        GateDesign,
        GateProbability,
        GateResult,
        GateStage,
        MarkGeometry,
        RectangularGate,
        RingGate,
        SectorGate,
        StarRegion,
        capture_probability,
        combined_area_approximation,
        conditional_probability,
        design_gate,
        expansion_coefficient,
        false_marks,
        gate_area,
        gate_threshold,
        innovation_covariance,
        mark_geometry,
        monte_carlo_probability,
        rectangular_coefficient,
        resolution_cells,
        unconditional_probability,
    )

__all__ = [
    "MAX_CONDITION",
    "CombinedGate",
    "EllipseGate",
    "ExpandedGate",
    "FalseMarks",
    "FirstAssociationGate",
    "Gate",
    "GateDesign",
    "GateProbability",
    "MarkGeometry",
    "RectangularGate",
    "RingGate",
    "SectorGate",
    "StarRegion",
    "capture_probability",
    "check_covariance",
    "combined_area_approximation",
    "conditional_probability",
    "design_gate",
    "false_marks",
    "gate_area",
    "mark_geometry",
    "monte_carlo_probability",
    "resolution_cells",
    "unconditional_probability",
    "CovarianceError",
    "GateResult",
    "GateStage",
    "GeometryError",
    "NonFiniteError",
    "ParameterError",
    "PlotgateError",
    "cartesian_covariance_to_polar",
    "cartesian_to_polar",
    "expansion_coefficient",
    "gate_threshold",
    "innovation_covariance",
    "polar_covariance_to_cartesian",
    "polar_to_cartesian",
    "rectangular_coefficient",
    "wrap_angle",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "plotgate.core.covariance": (
            "MAX_CONDITION",
            "check_covariance",
        ),
        "plotgate.core.frames": (
            "cartesian_covariance_to_polar",
            "cartesian_to_polar",
            "polar_covariance_to_cartesian",
            "polar_to_cartesian",
            "wrap_angle",
        ),
        "plotgate.core.gates": (
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
        ),
    },
)
