"""What a gate test returns, and the statistics several gates compare.

Every gate tests N pairs at once. Marks, covariances, sigmas, ranges and azimuths
are per pair: each is either unbatched (shared by all pairs, e.g. one first mark
against N candidates) or has a leading axis of the common length N. Gate
parameters (tau, speeds, probabilities, coefficients) are scalars, so each gate
has one scalar threshold. Results are always (N,) arrays (N = 1 when nothing is
batched). Inputs are never modified.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from plotgate.core.validation import to_pairs

__all__ = ["GateResult", "GateStage", "difference", "gate_result", "window_statistic"]


class GateStage(enum.IntEnum):
    """Stage of the combined gate that accepted a mark (Konovalov, Fig. 4)."""

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
        bound R_min (see :class:`plotgate.core.gates.capture.RingGate`).
    stage : (N,) ndarray of int8 or None
        :class:`GateStage` values, from
        :class:`plotgate.core.gates.capture.CombinedGate` only; None otherwise.
    """

    inside: np.ndarray
    statistic: np.ndarray
    threshold: float
    stage: np.ndarray | None = None


def gate_result(
    n: int,
    inside: np.ndarray,
    statistic: np.ndarray,
    threshold: float,
    stage: np.ndarray | None = None,
) -> GateResult:
    """A :class:`GateResult` of N pairs, each array broadcast to (n,)."""
    return GateResult(
        to_pairs(inside, n),
        to_pairs(statistic, n),
        float(threshold),
        None if stage is None else to_pairs(stage, n),
    )


def difference(
    a: np.ndarray, b: np.ndarray, n: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Components of b - a for (..., 2) positions, as (n,) arrays when n is given."""
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    if n is None:
        return dx, dy
    return to_pairs(dx, n), to_pairs(dy, n)


def window_statistic(
    dr: np.ndarray | float,
    daz: np.ndarray | float,
    W_R: np.ndarray | float,
    W_az: np.ndarray | float,
) -> np.ndarray:
    """max(|dr| / W_R, |daz| / W_az): the larger offset as a fraction of its window.

    The statistic of the rectangular gate (offsets x, y and windows k sigma) and of the
    polar windows (range and azimuth offsets and windows).
    """
    statistic: np.ndarray = np.maximum(np.abs(dr) / W_R, np.abs(daz) / W_az)
    return statistic
