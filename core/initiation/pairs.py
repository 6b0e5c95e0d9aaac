"""The plots inside each track's gate: (track, plot) pairs with their statistic.

Candidates come from the scan's :class:`~plotgate.core.initiation.search.PlotIndex`; the
gates then test them exactly, vectorized over the candidate pairs. A track's gate is the
chi-square ellipse rho = nu^T S^-1 nu <= gamma (Cartesian, :func:`ellipse_pairs`) or the
polar windows about the range extrapolation and the last azimuth (Mu et al., eq. 1-2,
with the azimuth window of the tangential speed bound, eq. 4: :func:`window_pairs`);
gamma (or K^2) grows by gate_widening[misses] after misses in a row (the
secondary-processing textbook's narrow, medium and wide gates). The initiators' capture
gates are :mod:`plotgate.core.initiation.capture`'s.

Under score confirmation, a Cartesian track's gate also lets in every plot inside
Blackman's maximum-likelihood gate (:func:`likelihood_pairs`, with
:func:`plotgate.core.initiation.score.ml_gate`), where the plot scores above a miss: the
score, not a fixed gating probability, decides which plots a track may take.

Every function here takes a scan of at least one plot: initiation handles an empty scan
before it looks for pairs.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from plotgate.core.frames import wrap_finite
from plotgate.core.gates.polar import bearing_turn
from plotgate.core.gates.results import window_statistic
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.gates.tracking import EllipseGate
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.score import log_clutter_density, ml_gate
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Tracks
from plotgate.core.sym2 import Sym2, sym2

__all__ = [
    "Pairs",
    "Prediction",
    "ellipse_pairs",
    "likelihood_gate_bound",
    "likelihood_pairs",
    "nearest",
    "widening",
    "window_coefficients",
    "window_pairs",
]


class Pairs(NamedTuple):
    """Candidate pairs that passed a gate: row (track or initiator), plot (index in the
    scan) and the gate's statistic, (E,) each."""

    row: np.ndarray
    plot: np.ndarray
    statistic: np.ndarray

    def take(self, keep: np.ndarray) -> Pairs:
        """The pairs at ``keep`` (a boolean mask or indices)."""
        return Pairs(self.row[keep], self.plot[keep], self.statistic[keep])


class Prediction(NamedTuple):
    """Every track predicted to the scan time: dt (m,) s since its last update, x (m, 4)
    and P (m, 4, 4) the predicted state and covariance."""

    dt: np.ndarray
    x: np.ndarray
    P: np.ndarray


def window_coefficients(config: InitiationConfig) -> tuple[float, float]:
    """Polar window coefficients (K_R, K_az): the config's, or sqrt(gamma) of gate_P_G."""
    k = float(np.sqrt(gate_threshold(config.gate_P_G, 2)))
    return (
        config.K_R if config.K_R is not None else k,
        config.K_az if config.K_az is not None else k,
    )


def widening(misses: np.ndarray, config: InitiationConfig) -> np.ndarray:
    """Factor of each track's gate threshold after its misses in a row."""
    w = np.asarray(config.gate_widening)
    factor: np.ndarray = w[np.minimum(misses, w.size - 1)]
    return factor


def _ellipse_members(
    prediction: Prediction,
    scan: Scan,
    index: PlotIndex,
    reach: np.ndarray,
    threshold: Callable[[np.ndarray, Sym2], np.ndarray],
) -> Pairs:
    """(track, plot, rho) of the plots with rho = nu^T S^-1 nu <= threshold(track, S),
    S = P_xy + R, searched in the discs a threshold of ``reach`` (m,) per track bounds.

    :meth:`~plotgate.core.gates.tracking.EllipseGate.statistic` is called without the
    gate's input checks: those refuse an S whose condition number passes 10^12, and a
    session's state may hold covariances (up to 1e100) that initiation gates and answers.
    """
    xy, P_xy = prediction.x[:, :2], prediction.P[:, :2, :2]
    r_max = np.trace(scan.R, axis1=1, axis2=2).max()
    radius = np.sqrt(reach * (np.trace(P_xy, axis1=1, axis2=2) + r_max))
    track, plot = index.ball(xy, radius)
    nu = scan.z[plot] - xy[track]
    S = sym2(P_xy[track] + scan.R[plot])
    rho = EllipseGate.statistic(nu[:, 0], nu[:, 1], S)
    return Pairs(track, plot, rho).take(rho <= threshold(track, S))


def ellipse_pairs(
    tracks: Tracks, prediction: Prediction, scan: Scan, index: PlotIndex, config: InitiationConfig
) -> Pairs:
    """(track, plot, rho) of the plots inside each track's chi-square gate (Cartesian):
    the ellipse of :class:`~plotgate.core.gates.tracking.EllipseGate` against the gate's
    threshold times the track's widening."""
    gamma = EllipseGate(config.gate_P_G).threshold * widening(tracks.misses, config)
    return _ellipse_members(prediction, scan, index, gamma, lambda track, S: gamma[track])


def likelihood_pairs(
    tracks: Tracks, prediction: Prediction, scan: Scan, index: PlotIndex, config: InitiationConfig
) -> Pairs:
    """(track, plot, rho) of the plots inside each track's chi-square gate or Blackman's
    maximum-likelihood gate, whichever is wider (Cartesian, score confirmation).

    Per pair, rho is held to the larger of :func:`ellipse_pairs`' threshold and the
    maximum-likelihood gate of the pair's S; :func:`likelihood_gate_bound` bounds the
    search.
    """
    gamma = EllipseGate(config.gate_P_G).threshold * widening(tracks.misses, config)
    density = log_clutter_density(config, scan.size)
    reach = np.fmax(gamma, likelihood_gate_bound(prediction.P[:, :2, :2], scan, config))

    def threshold(track: np.ndarray, S: Sym2) -> np.ndarray:
        wider: np.ndarray = np.fmax(gamma[track], ml_gate(S.det, config, density))
        return wider

    return _ellipse_members(prediction, scan, index, reach, threshold)


def likelihood_gate_bound(P_xy: np.ndarray, scan: Scan, config: InitiationConfig) -> np.ndarray:
    """Per row of P_xy (k, 2, 2): the widest maximum-likelihood gate any plot of the scan
    can have, S = P_xy + R.

    The gate shrinks as |S| grows, and for 2x2 positive semi-definite matrices
    |P + R| >= |P| + |R| (Minkowski's determinant inequality), so |P| plus the smallest
    |R| of the scan bounds every pair's |S| from below and the gate from above. Empty
    scan: no plot, no gate (-inf).
    """
    if scan.size == 0:
        return np.full(P_xy.shape[0], -np.inf)
    det_R = np.linalg.det(scan.R).min()
    density = log_clutter_density(config, scan.size)
    return ml_gate(np.linalg.det(P_xy) + det_R, config, density)


def window_pairs(
    tracks: Tracks, prediction: Prediction, scan: Scan, index: PlotIndex, config: InitiationConfig
) -> Pairs:
    """(track, plot, rank) of the plots inside each track's polar windows (Mu et al.).

    The windows about the range extrapolated from the last two ranges (its variance
    carried through the extrapolation) and the last azimuth, the azimuth window grown by
    the gates' largest bearing change (:func:`~plotgate.core.gates.polar.bearing_turn`,
    Mu et al., eq. 4), and decided by the polar gates' statistic
    (:func:`~plotgate.core.gates.results.window_statistic`, at most 1). Their centre and
    widths are the extrapolation's, which no wire gate kind has: the sector gate's
    azimuth window is K_az sigma alone (Mu et al., eq. 2). Plots inside one gate are
    ranked by (d_r / W_R)^2 + (d_az / W_az)^2.
    """
    w = widening(tracks.misses, config)
    dt = prediction.dt
    K_R, K_az = window_coefficients(config)
    r_last, r_prev = tracks.ranges[:, -1], tracks.ranges[:, -2]
    span = tracks.times[:, -1] - tracks.times[:, -2]
    a = np.divide(dt, span, out=np.zeros_like(dt), where=span > 0)
    r_pred = r_last + a * (r_last - r_prev)
    var_pred = (1 + a) ** 2 * tracks.sigma_r[:, -1] ** 2 + a**2 * tracks.sigma_r[:, -2] ** 2
    tangential = bearing_turn(config.v_max * dt, r_last)
    k_r, k_az = K_R * np.sqrt(w), K_az * np.sqrt(w)
    big_r, big_az = scan.sigma_r.max(), scan.sigma_az.max()
    track, plot = index.window(
        r_pred,
        tracks.az,
        k_r * np.sqrt(big_r**2 + var_pred),
        tangential + k_az * np.sqrt(big_az**2 + tracks.sigma_az**2),
    )
    W_R = k_r[track] * np.sqrt(scan.sigma_r[plot] ** 2 + var_pred[track])
    W_az = tangential[track] + k_az[track] * np.sqrt(
        scan.sigma_az[plot] ** 2 + tracks.sigma_az[track] ** 2
    )
    d_r = np.abs(scan.r[plot] - r_pred[track])
    d_az = np.abs(wrap_finite(scan.az[plot] - tracks.az[track]))
    inside = window_statistic(d_r, d_az, W_R, W_az) <= 1.0
    rank = (d_r / W_R) ** 2 + (d_az / W_az) ** 2
    return Pairs(track, plot, rank).take(inside)


def nearest(pairs: Pairs) -> Pairs:
    """The pair of smallest statistic for each row (ties: the lower plot index)."""
    row = pairs.row
    order = np.lexsort((pairs.plot, pairs.statistic, row))
    first = order[np.r_[True, row[order][1:] != row[order][:-1]]] if row.size else order
    return pairs.take(first)
