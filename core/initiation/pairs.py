"""The plots inside each gate: (track, plot) and (initiator, plot) pairs with their statistic.

Candidates come from the scan's :class:`~plotgate.core.initiation.search.PlotIndex`; the
gates then test them exactly, vectorized over the candidate pairs. A track's gate is the
chi-square ellipse rho = nu^T S^-1 nu <= gamma (Cartesian) or the polar windows about
the range extrapolation and the last azimuth (Mu et al., eq. 1-2, with the azimuth
window of the tangential speed bound, eq. 4); gamma (or K^2) grows by
gate_widening[misses] after misses in a row (the secondary-processing textbook's narrow,
medium and wide gates). An initiator's gate is its capture gate (Konovalov's ring,
expanded or combined gate; Mu et al.'s first-association windows, eq. 3-4).

Under score confirmation, Cartesian gates also let in every plot inside Blackman's
maximum-likelihood gate (:func:`plotgate.core.initiation.score.ml_gate`), where the plot
scores above a miss: the score, not a fixed gating probability, decides which plots a
track may take.
"""

from __future__ import annotations

import numpy as np

from plotgate.core.frames import wrap_finite
from plotgate.core.gates.capture import CombinedGate, ExpandedGate, RingGate
from plotgate.core.gates.polar import FirstAssociationGate, bearing_turn
from plotgate.core.gates.results import window_statistic
from plotgate.core.gates.thresholds import expansion_coefficient, gate_threshold
from plotgate.core.gates.tracking import EllipseGate
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.filter import one_point, predict
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.score import log_clutter_density, ml_gate
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Initiators, Tracks
from plotgate.core.sym2 import sym2

__all__ = [
    "capture_pairs",
    "likelihood_gate_bound",
    "likely_captures",
    "nearest",
    "track_pairs",
    "widening",
    "window_coefficients",
]


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


def track_pairs(
    tracks: Tracks,
    xp: np.ndarray,
    Pp: np.ndarray,
    dt: np.ndarray,
    scan: Scan,
    index: PlotIndex,
    config: InitiationConfig,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(track, plot, statistic) of the plots inside each track's gate.

    Cartesian: the chi-square ellipse of :class:`~plotgate.core.gates.tracking.EllipseGate`,
    rho = nu^T S^-1 nu with S = P_xy + R, against the gate's threshold times the track's
    widening. Its :meth:`~plotgate.core.gates.tracking.EllipseGate.statistic` is called
    without the gate's input checks: those refuse an S whose condition number passes
    10^12, and a session's state may hold covariances (up to 1e100) that initiation gates
    and answers.

    Polar: the windows of Mu et al. about the range extrapolated from the last two
    ranges (its variance carried through the extrapolation) and the last azimuth, the
    azimuth window grown by the gates' largest bearing change
    (:func:`~plotgate.core.gates.polar.bearing_turn`, Mu et al., eq. 4), and decided by
    the polar gates' statistic (:func:`~plotgate.core.gates.results.window_statistic`,
    at most 1). Their centre and widths are the extrapolation's, which no wire gate
    kind has: the sector gate's azimuth window is K_az sigma alone (Mu et al., eq. 2).
    Plots inside one gate are ranked by (d_r / W_R)^2 + (d_az / W_az)^2.

    Cartesian under score confirmation: gamma is, per pair, the larger of that threshold
    and the maximum-likelihood gate of the pair's S (:func:`likelihood_gate_bound`
    bounds the search).
    """
    w = widening(tracks.misses, config)
    if config.mode == "cartesian":
        gate = EllipseGate(config.gate_P_G)
        gamma = gate.threshold * w
        P_xy = Pp[:, :2, :2]
        widest = gamma
        if config.confirmation == "score":
            widest = np.fmax(gamma, likelihood_gate_bound(P_xy, scan, config))
        r_max = np.trace(scan.R, axis1=1, axis2=2).max() if scan.size else 0.0
        radius = np.sqrt(widest * (np.trace(P_xy, axis1=1, axis2=2) + r_max))
        rows, cols = index.ball(xp[:, :2], radius)
        nu = scan.z[cols] - xp[rows, :2]
        S = sym2(P_xy[rows] + scan.R[cols])
        s = gate.statistic(nu[:, 0], nu[:, 1], S)
        threshold = gamma[rows]
        if config.confirmation == "score":
            density = log_clutter_density(config, scan.size)
            threshold = np.fmax(threshold, ml_gate(S.det, config, density))
        keep = s <= threshold
        return rows[keep], cols[keep], s[keep]
    K_R, K_az = window_coefficients(config)
    r_last, r_prev = tracks.ranges[:, -1], tracks.ranges[:, -2]
    span = tracks.times[:, -1] - tracks.times[:, -2]
    a = np.divide(dt, span, out=np.zeros_like(dt), where=span > 0)
    r_pred = r_last + a * (r_last - r_prev)
    var_pred = (1 + a) ** 2 * tracks.sigma_r[:, -1] ** 2 + a**2 * tracks.sigma_r[:, -2] ** 2
    tangential = bearing_turn(config.v_max * dt, r_last)
    k_r, k_az = K_R * np.sqrt(w), K_az * np.sqrt(w)
    big_r = scan.sigma_r.max() if scan.size else 0.0
    big_az = scan.sigma_az.max() if scan.size else 0.0
    rows, cols = index.window(
        r_pred,
        tracks.az,
        k_r * np.sqrt(big_r**2 + var_pred),
        tangential + k_az * np.sqrt(big_az**2 + tracks.sigma_az**2),
    )
    W_R = k_r[rows] * np.sqrt(scan.sigma_r[cols] ** 2 + var_pred[rows])
    W_az = tangential[rows] + k_az[rows] * np.sqrt(
        scan.sigma_az[cols] ** 2 + tracks.sigma_az[rows] ** 2
    )
    d_r = np.abs(scan.r[cols] - r_pred[rows])
    d_az = np.abs(wrap_finite(scan.az[cols] - tracks.az[rows]))
    keep = window_statistic(d_r, d_az, W_R, W_az) <= 1.0
    s = (d_r / W_R) ** 2 + (d_az / W_az) ** 2
    return rows[keep], cols[keep], s[keep]


def capture_pairs(
    ini: Initiators,
    scan: Scan,
    index: PlotIndex,
    config: InitiationConfig,
    allowed: np.ndarray,
    k: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(initiator, plot, distance) of the plots inside each initiator's capture gate.

    Only initiators within the 2/N (or 2/T) window of scan number k take part. The
    search radii only bound each gate (the polar windows at the scan's largest sigmas);
    the gates decide: :class:`~plotgate.core.gates.polar.FirstAssociationGate` (polar),
    or :class:`~plotgate.core.gates.capture.RingGate`,
    :class:`~plotgate.core.gates.capture.ExpandedGate` or
    :class:`~plotgate.core.gates.capture.CombinedGate`, each tested once per initiator
    time on all its candidate pairs.
    """
    tau = scan.t - ini.t
    if config.capture_time is None:
        window = k - ini.scan <= config.capture_scans - 1
    else:
        window = tau <= config.capture_time
    R_max = config.v_max * np.maximum(tau, 0.0)
    later = np.flatnonzero((tau > 0) & window)  # a plot from a later time, in time
    if config.mode == "polar":
        K_R, K_az = window_coefficients(config)
        W_R = R_max + K_R * np.sqrt(ini.sigma_r**2 + scan.sigma_r.max(initial=0.0) ** 2)
        W_az = bearing_turn(R_max, ini.r) + K_az * np.sqrt(
            ini.sigma_az**2 + scan.sigma_az.max(initial=0.0) ** 2
        )
        rows, cols = index.window(ini.r[later], ini.az[later], W_R[later], W_az[later])
    elif config.capture_gate == "ring":
        radius = R_max
    elif config.capture_gate == "expanded":
        K_g = float(expansion_coefficient(config.capture_p))
        radius = R_max + K_g * np.maximum(ini.sigma_r, ini.r * ini.sigma_az)
    else:
        gamma = gate_threshold(config.capture_P_G, 2)
        big = np.trace(scan.R, axis1=1, axis2=2).max(initial=0.0)
        radius = R_max + np.sqrt(gamma * (np.trace(ini.R, axis1=1, axis2=2) + big))
    if config.mode == "cartesian":
        rows, cols = index.ball(ini.z[later], radius[later] * (1 + 1e-9) + 1e-9)
    rows = later[rows]
    keep = allowed[cols]
    rows, cols = rows[keep], cols[keep]
    inside = np.zeros(rows.size, dtype=bool)
    for t in np.unique(tau[rows]):  # the gates take one tau; a few initiator times
        g = np.flatnonzero(tau[rows] == t)
        i, c = rows[g], cols[g]
        if config.mode == "polar":
            res = FirstAssociationGate(config.v_max, K_R, K_az).test(
                ini.r[i],
                ini.az[i],
                scan.r[c],
                scan.az[c],
                t,
                ini.sigma_r[i],
                ini.sigma_az[i],
                scan.sigma_r[c],
                scan.sigma_az[c],
            )
        elif config.capture_gate == "ring":
            res = RingGate(config.v_min, config.v_max).test(ini.z[i], scan.z[c], t)
        elif config.capture_gate == "expanded":
            res = ExpandedGate(config.v_max, config.capture_p).test(
                ini.z[i], scan.z[c], t, ini.sigma_r[i], ini.sigma_az[i], sensor=ini.sensor[i]
            )
        else:
            res = CombinedGate(config.v_min, config.v_max, config.capture_P_G).test(
                ini.z[i], ini.R[i], scan.z[c], scan.R[c], t
            )
        inside[g] = res.inside
    rows, cols = rows[inside], cols[inside]
    if config.confirmation == "score" and config.mode == "cartesian":
        more_rows, more_cols = likely_captures(ini, scan, index, config, allowed, later)
        key = np.unique(np.concatenate([rows, more_rows]) * scan.size + np.r_[cols, more_cols])
        rows, cols = key // scan.size, key % scan.size
    return rows, cols, np.linalg.norm(scan.z[cols] - ini.z[rows], axis=1)


def likely_captures(
    ini: Initiators,
    scan: Scan,
    index: PlotIndex,
    config: InitiationConfig,
    allowed: np.ndarray,
    later: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(initiator, plot) pairs, initiators among ``later``, inside the maximum-likelihood
    gate of the capture score.

    The pair's S is the capture score's (:func:`plotgate.core.initiation.score.capture_score`):
    the initiator's one-point state with its velocity prior
    (:func:`~plotgate.core.initiation.filter.one_point`), predicted to the scan, plus the
    plot's R. A target's pair lies inside with the probability of the gate, which grows
    as clutter thins: the configured capture gate alone (the combined gate's ellipse at
    capture_P_G 0.99) loses about 1% of them per capture.
    """
    x1, P1 = one_point(ini.z[later], ini.R[later], config.v_max)
    xp, Pp = predict(x1, P1, scan.t - ini.t[later], config.q)
    P_xy = Pp[:, :2, :2]
    bound = likelihood_gate_bound(P_xy, scan, config)
    r_max = np.trace(scan.R, axis1=1, axis2=2).max(initial=0.0)
    radius = np.sqrt(np.fmax(bound, 0.0) * (np.trace(P_xy, axis1=1, axis2=2) + r_max))
    rows, cols = index.ball(xp[:, :2], radius)
    keep = allowed[cols]
    rows, cols = rows[keep], cols[keep]
    nu = scan.z[cols] - xp[rows, :2]
    S = sym2(P_xy[rows] + scan.R[cols])
    density = log_clutter_density(config, scan.size)
    inside = EllipseGate.statistic(nu[:, 0], nu[:, 1], S) <= ml_gate(S.det, config, density)
    return later[rows[inside]], cols[inside]


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


def nearest(
    rows: np.ndarray, cols: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pair of smallest statistic for each row (ties: the lower plot index)."""
    order = np.lexsort((cols, s, rows))
    first = order[np.r_[True, rows[order][1:] != rows[order][:-1]]] if rows.size else order
    return rows[first], cols[first], s[first]
