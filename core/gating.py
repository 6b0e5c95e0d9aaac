"""Shared gate machinery: the result type and the helpers of the gate modules.

The gates live in :mod:`plotgate.core.capture_gates` (seed 000),
:mod:`plotgate.core.tracking_gates`
(seed 000 ref. [6], seed 003) and :mod:`plotgate.core.polar_gates` (seed 002, seed 003).

Symbols
-------
z1, z2 : first and second mark, (2,) or (N, 2), x east / y north in metres.
P1, P2 : their covariances, (2, 2) or (N, 2, 2), in m^2.
d : z2 - z1; B = P1 + P2, the covariance of d (seed 000, eq. 1).
tau : time between the marks (s); v_min, v_max : speed bounds (m/s).
R_min, R_max : v_min tau and v_max tau, the radii of the ring gate (m).
z, z_pred, S : a mark, its prediction and the innovation covariance; nu = z - z_pred.
rho : squared Mahalanobis distance nu^T S^-1 nu; gamma : its threshold for P_G.
r, az : range (m) and azimuth (rad, clockwise from north) of a polar mark.

Every gate tests N pairs at once. Marks, covariances, sigmas, ranges and azimuths
are per pair: each is either unbatched (shared by all pairs, e.g. one first mark
against N candidates) or has a leading axis of the common length N. Gate
parameters (tau, speeds, probabilities, coefficients) are scalars, so each gate
has one scalar threshold. Results are always (N,) arrays (N = 1 when nothing is
batched). Inputs are never modified.
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError
from plotgate.core.thresholds import expansion_coefficient, gate_threshold
from plotgate.core.validation import (
    as_array,
    as_probability,
    as_scalar,
    require_nonnegative,
    require_positive,
    require_scalar,
    to_pairs,
)

__all__ = ["GateResult", "GateStage"]


class GateStage(enum.IntEnum):
    """Stage of the combined gate that accepted a mark (seed 000, Fig. 4)."""

    NONE = 0  # rejected
    RING = 1  # inside the ring R_min <= |d| <= R_max
    INNER_ELLIPSE = 2  # inside the ellipse centred on the inner circle
    OUTER_ELLIPSE = 3  # inside the ellipse centred on the outer circle


@dataclass(frozen=True)
class GateResult:
    """Outcome of a gate test on N pairs.

    Attributes
    ----------
    inside : (N,) ndarray of bool
        The second mark falls in the gate.
    statistic : (N,) ndarray of float
        The tested quantity; its meaning and unit are documented per gate.
    threshold : float
        Acceptance bound on the statistic. For every gate but the ring gate
        ``inside == (statistic <= threshold)``; the ring gate also has the lower
        bound R_min (see :func:`plotgate.core.capture_gates.ring_gate`).
    stage : (N,) ndarray of int8 or None
        :class:`GateStage` values, from :func:`plotgate.core.capture_gates.combined_gate`
        only; None otherwise.
    """

    inside: np.ndarray
    statistic: np.ndarray
    threshold: float
    stage: np.ndarray | None = None


def _difference(
    a: np.ndarray, b: np.ndarray, n: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Components of b - a for (..., 2) positions, as (n,) arrays when n is given."""
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    if n is None:
        return dx, dy
    return to_pairs(dx, n), to_pairs(dy, n)


def _ring_radii(tau: float, v_min: float, v_max: float) -> tuple[float, float]:
    """Validate tau, v_min, v_max and return R_min = v_min tau, R_max = v_max tau."""
    tau = as_scalar("tau", tau)
    v_min = as_scalar("v_min", v_min)
    v_max = as_scalar("v_max", v_max)
    require_positive("tau", tau)
    require_nonnegative("v_min", v_min)
    require_nonnegative("v_max", v_max)
    if v_min > v_max:
        raise ParameterError("v_min", f"v_min ({v_min}) exceeds v_max ({v_max})")
    return v_min * tau, v_max * tau


def _gate_threshold(P_G: float) -> float:
    """gamma = gate_threshold(P_G, 2) for a scalar P_G, validated, then looked up."""
    require_scalar("P_G", P_G)
    return _chi2_threshold_2d(float(as_probability("P_G", P_G)))


def _expansion_coefficient(p: float) -> float:
    """K_g = expansion_coefficient(p) for a scalar p, validated, then looked up."""
    require_scalar("p", p)
    return _expansion_coefficient_of(float(as_probability("p", p)))


# scipy's chi2.ppf costs 0.1-0.4 ms a call, more than a gate on 10 pairs does; a
# gate's probability is one scalar per call and few distinct values occur in practice.
@functools.lru_cache(maxsize=256)
def _chi2_threshold_2d(P_G: float) -> float:
    """gate_threshold(P_G, 2) for a validated float P_G in (0, 1), memoized."""
    return float(gate_threshold(P_G, 2))


@functools.lru_cache(maxsize=256)
def _expansion_coefficient_of(p: float) -> float:
    """expansion_coefficient(p) for a validated float p in (0, 1), memoized."""
    return float(expansion_coefficient(p))


def _positive_coefficient(name: str, value: float) -> float:
    k = as_scalar(name, value)
    require_positive(name, k)
    return k


def _sigma(name: str, value: ArrayLike) -> np.ndarray:
    """Validate a standard deviation: finite and > 0, scalar or (N,)."""
    sigma = as_array(name, value)
    require_positive(name, sigma)
    return sigma


def _window_statistic(
    dr: np.ndarray | float,
    daz: np.ndarray | float,
    W_R: np.ndarray | float,
    W_az: np.ndarray | float,
) -> np.ndarray:
    """max(|dr| / W_R, |daz| / W_az): the larger offset as a fraction of its window."""
    return np.maximum(np.abs(dr) / W_R, np.abs(daz) / W_az)


def _result(
    n: int,
    inside: np.ndarray,
    statistic: np.ndarray,
    threshold: float,
    stage: np.ndarray | None = None,
) -> GateResult:
    return GateResult(
        to_pairs(inside, n),
        to_pairs(statistic, n),
        float(threshold),
        None if stage is None else to_pairs(stage, n),
    )
