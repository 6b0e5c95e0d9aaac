"""Gate areas, resolution cells, false marks, capture probability and gate design (Konovalov).

Konovalov compares gates by the false marks they admit: a gate of area S covers
S' = S / (dR R dAz) resolution cells (R the first mark's range, dR and dAz the
radar's range and azimuth resolution); false marks uniform over the picture fall in
it as a Poisson count with mean F S' (F the false-alarm probability per cell), so
P(m false marks) = exp(-F S') (F S')^m / m! and P(at least one) = 1 - exp(-F S').
A target's track is captured with probability P_gate P_D1 P_D2.

:func:`design_gate` is not in the paper: it sizes the combined gate (its P_G) or the
expanded gate (its p) to reach a wanted unconditional capture probability, so gate
types can be compared at equal capture probability by their false marks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize, stats

from plotgate.core.errors import ParameterError
from plotgate.core.gates.capture import CombinedGate, ExpandedGate
from plotgate.core.gates.kinds import Gate
from plotgate.core.gates.parameters import ring_radii
from plotgate.core.gates.probability import (
    Prior,
    unconditional_probability,
    unconditional_quadrature,
)
from plotgate.core.gates.quadrature import adaptive_panels, breakpoints, panel_rule
from plotgate.core.gates.regions import MarkGeometry
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.validation import (
    as_array,
    as_probability,
    as_scalar,
    require_nonnegative,
    require_positive,
    require_scalar,
)

_SEARCH_RULE = (6, 1.0)

__all__ = [
    "FalseMarks",
    "GateDesign",
    "capture_probability",
    "combined_area_approximation",
    "design_gate",
    "false_marks",
    "gate_area",
    "resolution_cells",
]


def gate_area(gate: Gate, geometry: MarkGeometry) -> np.ndarray:
    """Area of the gate, m^2, for each of N problems.

    The half integral of hi^2 - lo^2 over the gate's directions (its
    :class:`~plotgate.core.gates.regions.StarRegion`), on Gauss-Legendre panels split at the
    boundary's kinks and bisected until two rules agree to 1e-12 of the area; exact to
    rounding for every gate kind (the ring, ellipse, expanded, rectangular and sector
    areas have closed forms the tests compare with).

    Examples
    --------
    >>> from plotgate.core.gates import RingGate, mark_geometry
    >>> g = mark_geometry(50e3, 0.0, 200.0, np.radians(0.5), tau=5.0)
    >>> bool(np.isclose(gate_area(RingGate(100.0, 500.0), g)[0], np.pi * (2500**2 - 500**2)))
    True
    """
    region = gate.region(geometry)
    edges = breakpoints(
        region.start,
        region.start + region.span,
        np.empty((geometry.n, 0)),
        np.empty((geometry.n, 0)),
        region.kinks,
        periodic=True,
        uniform=16,
    )

    def half_difference(rows: np.ndarray | slice, theta: np.ndarray) -> np.ndarray:
        lo, hi = region.radii(theta, rows)
        half: np.ndarray = 0.5 * (hi * hi - lo * lo)
        return half

    theta, weight = panel_rule(edges, 8)
    rough = np.einsum("nt,nt->n", weight, half_difference(slice(None), theta))
    area, _ = adaptive_panels(half_difference, edges, 1e-12 * np.maximum(rough, 1e-300))
    return area


def combined_area_approximation(gate: CombinedGate, geometry: MarkGeometry) -> np.ndarray:
    """The paper's S_Sigma ~ S_ring + S_ellipse / 2, S_ellipse = pi sqrt(|gamma B|), m^2."""
    R_min, R_max = ring_radii(geometry.tau, gate.v_min, gate.v_max)
    require_scalar("P_G", gate.P_G)
    gamma = float(gate_threshold(gate.P_G))
    ring: np.ndarray = np.pi * (R_max * R_max - R_min * R_min) + np.zeros(geometry.n)
    area: np.ndarray = ring + 0.5 * np.pi * gamma * np.sqrt(geometry.B.det)
    return area


def resolution_cells(area: ArrayLike, r: ArrayLike, dR: float, dAz: float) -> np.ndarray:
    """S' = S / (dR r dAz): the gate area in resolution cells (Konovalov).

    Parameters
    ----------
    area : float or (N,) array_like
        Gate area, m^2.
    r : float or (N,) array_like
        Range of the first mark, m, > 0.
    dR, dAz : float
        Range (m) and azimuth (rad) resolution, > 0.
    """
    area = as_array("area", area)
    r = as_array("r", r)
    require_nonnegative("area", area)
    require_positive("r", r)
    for name, value in (("dR", dR), ("dAz", dAz)):
        require_positive(name, as_scalar(name, value))
    cells: np.ndarray = area / (dR * r * dAz)
    return cells


@dataclass(frozen=True)
class FalseMarks:
    """Poisson false marks in a gate: mean F S', P(exactly m) for m = 0..len-1, P(>= 1)."""

    mean: np.ndarray
    probabilities: np.ndarray
    at_least_one: np.ndarray


def false_marks(cells: ArrayLike, F: float, m_max: int = 5) -> FalseMarks:
    """False-mark statistics for gates of ``cells`` resolution cells (Konovalov).

    mu_F(m) = exp(-F S') (F S')^m / m! for m = 0..m_max and
    P(at least one) = 1 - exp(-F S').

    Examples
    --------
    The paper's expanded gate, 49 cells at F = 1e-4:

    >>> round(float(false_marks(49.0, 1e-4).at_least_one), 4)
    0.0049
    """
    cells = as_array("cells", cells)
    require_nonnegative("cells", cells)
    require_scalar("F", F)
    F = float(as_probability("F", F))
    if isinstance(m_max, bool) or not isinstance(m_max, int) or not 0 <= m_max <= 1000:
        raise ParameterError("m_max", f"must be an integer in [0, 1000], got {m_max!r}")
    mean = F * cells
    pmf = stats.poisson.pmf(np.arange(m_max + 1), mean[..., None])
    return FalseMarks(mean, pmf, -np.expm1(-mean))


def capture_probability(P_gate: ArrayLike, P_D1: ArrayLike, P_D2: ArrayLike) -> np.ndarray:
    """P = P_gate P_D1 P_D2: both marks detected and the second gated (Konovalov)."""
    probs = [
        as_array(name, value)
        for name, value in (("P_gate", P_gate), ("P_D1", P_D1), ("P_D2", P_D2))
    ]
    for name, p in zip(("P_gate", "P_D1", "P_D2"), probs, strict=True):
        if not ((p >= 0) & (p <= 1)).all():
            raise ParameterError(name, f"must lie in [0, 1], got {p.tolist()}")
    product: np.ndarray = probs[0] * probs[1] * probs[2]
    return product


@dataclass(frozen=True)
class GateDesign:
    """A gate sized for a wanted capture probability.

    Attributes
    ----------
    gate : CombinedGate or ExpandedGate
        The gate with the P_G (combined) or p (expanded) found.
    parameter : float
        That P_G or p.
    probability, error : float
        Its unconditional gating probability and quadrature error estimate.
    capture : float
        probability P_D1 P_D2.
    area : float
        Gate area, m^2.
    """

    gate: CombinedGate | ExpandedGate
    parameter: float
    probability: float
    error: float
    capture: float
    area: float


def design_gate(
    gate: CombinedGate | ExpandedGate,
    geometry: MarkGeometry,
    capture: float,
    v_min: float,
    v_max: float,
    prior: Prior = "area",
    P_D1: float = 1.0,
    P_D2: float = 1.0,
    tol: float = 1e-6,
) -> GateDesign:
    """Find the combined gate's P_G, or the expanded gate's p, that reaches ``capture``.

    Solves P_gate(x) P_D1 P_D2 = capture for x = P_G or p by Brent's method
    (:func:`scipy.optimize.brentq`, to ``tol`` in x) on the unconditional
    probability, which grows with x. The ``gate``'s own P_G or p is only the template
    (its speeds are kept). ``geometry`` must hold a single problem.

    Raises
    ------
    ParameterError
        If ``capture`` is not in (0, 1), is above P_D1 P_D2 (unreachable), or is
        already reached as P_G (p) goes to 0 -- the ring (circle) alone suffices.

    References
    ----------
    .. [1] Konovalov sizes the combined gate by P_G and the expanded gate by p; this
       inverts its probability (eq. 3-6) for a wanted capture probability.
    """
    if geometry.n != 1:
        raise ParameterError("geometry", f"must hold one problem, got {geometry.n}")
    require_scalar("capture", capture)
    capture = float(as_probability("capture", capture))
    detection = float(capture_probability(1.0, P_D1, P_D2))
    if capture >= detection:
        raise ParameterError("capture", f"{capture} is not reachable: P_D1 P_D2 = {detection}")
    field = "P_G" if isinstance(gate, CombinedGate) else "p"

    R_min, R_max = ring_radii(geometry.tau, v_min, v_max)

    def sized(x: float) -> CombinedGate | ExpandedGate:
        return replace(gate, P_G=x) if isinstance(gate, CombinedGate) else replace(gate, p=x)

    def gated(x: float) -> float:
        # the search runs on a cheaper rule (error ~1e-7); the answer is re-evaluated fully
        return float(
            unconditional_quadrature(
                sized(x), geometry, R_min, R_max, prior, _SEARCH_RULE, table=True
            )[0]
        )

    wanted = capture / detection
    lo, hi = 1e-9, 1.0 - 1e-12
    first_stage = gated(lo)
    if first_stage >= wanted:
        raise ParameterError(
            "capture",
            f"{capture} is reached with {field} -> 0: the "
            f"gate's first stage alone gives {first_stage * detection:.6f}",
        )
    if gated(hi) <= wanted:
        raise ParameterError("capture", f"{capture} needs {field} above {hi}")
    x = float(optimize.brentq(lambda t: gated(t) - wanted, lo, hi, xtol=tol))
    designed = sized(x)
    result = unconditional_probability(designed, geometry, v_min, v_max, prior)
    p = float(result.probability[0])
    return GateDesign(
        designed,
        x,
        p,
        float(result.error[0]),
        p * detection,
        float(gate_area(designed, geometry)[0]),
    )
