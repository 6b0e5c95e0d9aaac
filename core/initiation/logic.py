"""Track initiation from plots in clutter, one scan after another (DESIGN section 5).

Seeds 003 (the logic of auto-capture: ring capture zone, k/m and k/m - l criteria,
narrow / medium / wide gates, alpha-beta smoothing, branch or single-plot association),
002 (the polar method for slow ground targets: sector windows, range-only
extrapolation, the tangential-speed azimuth window, the radial acceleration check, 3/4
over a sliding window) and 000 (the ring, expanded and combined capture gates).

Each scan, in this order:

1. Every track is predicted to the scan time (constant velocity; Kalman with white
   acceleration q, or the alpha-beta smoother whose covariance follows its fixed gains).
2. Confirmed tracks take plots one to one (a minimum-cost assignment on the gate
   statistic, solved on the candidate pairs only). Their plots are not reused by
   anything else.
3. Tentative tracks take the nearest plot in their gate (several may share one). The
   gate is the chi-square ellipse rho = nu^T S^-1 nu <= gamma (Cartesian) or the polar
   windows (range about the linear extrapolation of the last two ranges, azimuth about
   the last azimuth within asin(v_max dt / r) + K_az sigma); gamma (or K^2) grows by
   gate_widening[misses] after misses in a row.
4. Initiators from earlier scans within the 2/N (or 2/T) window capture plots in their
   capture gate (ring, expanded, combined, or polar first-association windows); each
   plot starts a tentative track (branch), or only the nearest one does, with the
   two-point state x = [z2, (z2 - z1) / tau] and its exact covariance.
5. A tentative track with k plots within its first m scans is confirmed (in polar mode
   only if every triple of its ranges passes the acceleration check; a track that
   fails it is dropped). Newly confirmed tracks sharing two or more plots keep the one
   with the smaller mean statistic; tentative tracks sharing two or more plots with a
   confirmed track are pruned.
6. Dropped: l misses in a row, or (tentative) k no longer reachable within m scans.
7. Plots of the scan used by no track and captured by no initiator become initiators;
   initiators past their window expire.

Candidates come from a ``scipy.spatial.cKDTree`` of the scan's plots ((x, y); in polar
mode (r, S az), where a window is a Chebyshev ball), searched with a radius that bounds
each gate, so the work grows with the plots near each track and initiator, not with all
plots. Every scan counts as an opportunity for every track
(the scans are one surveillance picture); polar mode measures ranges and azimuths about
each plot's own sensor, so a track should be fed by one sensor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats
from scipy.spatial import cKDTree

from plotgate.core.errors import ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.gates.capture import CombinedGate, ExpandedGate, RingGate
from plotgate.core.gates.polar import FirstAssociationGate
from plotgate.core.gates.thresholds import expansion_coefficient
from plotgate.core.initiation.assignment import one_to_one
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.sharing import keep_greedy, shares_two
from plotgate.core.initiation.state import (
    MAX_SESSION_SCANS,
    PLOT_STRIDE,
    InitiationState,
    Initiators,
    Tracks,
    empty_state,
)

__all__ = ["DROP_REASONS", "MAX_CANDIDATES", "ScanReport", "initiate"]

DROP_REASONS = ("misses", "window", "acceleration", "pruned")
"""Why a track was dropped: l misses in a row; k unreachable within m; the polar
acceleration check; sharing two or more plots with a confirmed track."""
MAX_CANDIDATES = 2**24
"""Most candidate (track or initiator, plot) pairs one search may return (about 400 MB):
plots so dense that every gate holds hundreds (a thousand targets at one spot) would
otherwise grow tentative tracks, and their pairs, without bound. Over it the scan is
refused (ParameterError on ``scans``)."""


@dataclass(frozen=True)
class ScanReport:
    """What one scan did.

    Attributes
    ----------
    scan : int
        The scan's number in the session.
    t : float
        Its time, s.
    plots : int
        Plots in the scan.
    associated : (n,) ndarray of int
        Per plot of the scan: the id of the track it updated or started (the confirmed
        one when several), -1 when none.
    initiators : int
        Plots that became initiators.
    started, confirmed : ndarray of int
        Ids of the tracks started and confirmed by this scan.
    dropped : ndarray of int
        Ids of the tracks dropped by this scan.
    reasons : ndarray of str
        Why each was dropped (:data:`DROP_REASONS`).
    """

    scan: int
    t: float
    plots: int
    associated: np.ndarray
    initiators: int
    started: np.ndarray
    confirmed: np.ndarray
    dropped: np.ndarray
    reasons: np.ndarray


# ------------------------------------------------------------------ filter


def _predict(
    x: np.ndarray, P: np.ndarray, dt: np.ndarray, q: float
) -> tuple[np.ndarray, np.ndarray]:
    """Constant-velocity prediction over dt (m,) with white acceleration q (m^2/s^3)."""
    d = dt[:, None]
    xp = np.concatenate([x[:, :2] + d * x[:, 2:], x[:, 2:]], axis=1)
    F = np.tile(np.eye(4), (dt.size, 1, 1))
    F[:, 0, 2] = F[:, 1, 3] = dt
    Q = np.zeros_like(F)
    dt2, dt3 = dt * dt / 2.0, dt**3 / 3.0
    for i in (0, 1):
        Q[:, i, i], Q[:, i, i + 2], Q[:, i + 2, i], Q[:, i + 2, i + 2] = dt3, dt2, dt2, dt
    return xp, F @ P @ np.swapaxes(F, 1, 2) + q * Q


def _inv2(S: np.ndarray) -> np.ndarray:
    """Inverse of (..., 2, 2) symmetric positive definite matrices."""
    a, b, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    det = a * d - b * b
    return np.stack([np.stack([d, -b], -1), np.stack([-b, a], -1)], -2) / det[..., None, None]


def _update(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    n: np.ndarray,
    dt: np.ndarray,
    config: InitiationConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Kalman update, or alpha-beta with gains of the n-th plot (Joseph covariance)."""
    nu = z - x[:, :2]
    if config.filter == "kalman":
        S = P[:, :2, :2] + R
        K = P[:, :, :2] @ _inv2(S)  # (m, 4, 2)
    else:
        alpha = np.maximum(2.0 * (2.0 * n - 1.0) / (n * (n + 1.0)), config.alpha_min)
        beta = np.maximum(6.0 / (n * (n + 1.0)), config.beta_min)
        rate = np.divide(beta, dt, out=np.zeros_like(dt), where=dt > 0)
        K = np.zeros((x.shape[0], 4, 2))
        K[:, 0, 0] = K[:, 1, 1] = alpha
        K[:, 2, 0] = K[:, 3, 1] = rate
    x = x + np.einsum("mij,mj->mi", K, nu)
    IKH = np.tile(np.eye(4), (x.shape[0], 1, 1))
    IKH[:, :, :2] -= K
    P = IKH @ P @ np.swapaxes(IKH, 1, 2) + K @ R @ np.swapaxes(K, 1, 2)
    return x, 0.5 * (P + np.swapaxes(P, 1, 2))


def _two_point(
    z1: np.ndarray, R1: np.ndarray, z2: np.ndarray, R2: np.ndarray, tau: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """State [z2, (z2 - z1)/tau] and its exact covariance from two plots."""
    t = tau[:, None, None]
    P = np.zeros((tau.size, 4, 4))
    P[:, :2, :2] = R2
    P[:, :2, 2:] = P[:, 2:, :2] = R2 / t
    P[:, 2:, 2:] = (R1 + R2) / (t * t)
    return np.concatenate([z2, (z2 - z1) / tau[:, None]], axis=1), P


# ------------------------------------------------------------------ candidates


def _near(
    tree: cKDTree, centres: np.ndarray, radius: np.ndarray, p: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, point) pairs with the tree's point within radius[row] of centres[row] (p-norm).

    Queries go in bins of radii within a factor 1.5, each bin one
    ``sparse_distance_matrix`` between a tree of its centres and the points (pairs come
    back as arrays, not Python lists), then the exact per-query radius. A bin that could
    hold more than :data:`MAX_CANDIDATES` pairs is counted first (``count_neighbors``
    allocates no pairs) and refused over it.
    """
    if centres.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    smallest = max(float(radius.min()), 1e-9)
    bins = np.floor(np.log(np.maximum(radius, smallest) / smallest) / np.log(1.5)).astype(int)
    rows, cols = [], []
    for b in np.unique(bins):  # a few bins of similar radius
        idx = np.flatnonzero(bins == b)
        queries = cKDTree(centres[idx])
        reach = float(radius[idx].max())
        if idx.size * tree.n > MAX_CANDIDATES:
            count = int(queries.count_neighbors(tree, reach, p=p))
            if count > MAX_CANDIDATES:
                raise ParameterError(
                    "scans",
                    f"{count} candidate (track, plot) pairs in "
                    f"one search, more than {MAX_CANDIDATES}: the plots "
                    f"are too dense for the gates",
                )
        found = queries.sparse_distance_matrix(tree, reach, p=p, output_type="ndarray")
        i = idx[found["i"]]
        keep = found["v"] <= radius[i]
        rows.append(i[keep])
        cols.append(found["j"][keep].astype(np.int64))
    return np.concatenate(rows).astype(np.int64), np.concatenate(cols)


class _Index:
    """Candidate search over one scan's plots (the gates then test the candidates exactly).

    Cartesian gates: a cKDTree of (x, y) queried with a radius bounding each gate. Polar
    windows |dr| <= W_R, |d az| <= W_az are rectangles in (r, az): a cKDTree of
    (r, S az) queried with the Chebyshev radius max(W_R, S W_az), S the typical ratio of
    the two half-widths, so a window at 100 km does not drag in a disc of its arc
    length. Every plot also appears 2 pi away, for windows across +-pi.
    """

    def __init__(self, scan: Scan, config: InitiationConfig) -> None:
        self.tree = self.scale = self.owner = None
        if scan.size == 0:
            return
        if config.mode == "cartesian":
            self.tree = cKDTree(scan.z)
            return
        K_R, K_az = _window_coefficients(config)
        self.scale = K_R * np.median(scan.sigma_r) / (K_az * np.median(scan.sigma_az))
        other = scan.az - 2.0 * np.pi * np.sign(scan.az)
        pts = np.column_stack(
            [np.concatenate([scan.r, scan.r]), self.scale * np.concatenate([scan.az, other])]
        )
        self.tree = cKDTree(pts)
        self.owner = np.tile(np.arange(scan.size), 2)

    def ball(self, centres: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot within radius of centres[row] (Cartesian)."""
        if self.tree is None:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        return _near(self.tree, centres, radius, 2.0)

    def window(
        self, r: np.ndarray, az: np.ndarray, W_R: np.ndarray, W_az: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot possibly in the window about (r, az)[row]."""
        if self.tree is None:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        rows, cols = _near(
            self.tree,
            np.column_stack([r, self.scale * az]),
            np.maximum(W_R, self.scale * W_az) * (1 + 1e-9),
            np.inf,
        )
        cols = self.owner[cols]
        key = np.unique(rows * self.owner.size + cols)  # a wide window may meet both copies
        return key // self.owner.size, key % self.owner.size


def _window_coefficients(config: InitiationConfig) -> tuple[float, float]:
    k = float(np.sqrt(stats.chi2.ppf(config.gate_P_G, 2)))
    return (
        config.K_R if config.K_R is not None else k,
        config.K_az if config.K_az is not None else k,
    )


def _widening(misses: np.ndarray, config: InitiationConfig) -> np.ndarray:
    w = np.asarray(config.gate_widening)
    return w[np.minimum(misses, w.size - 1)]


def _track_pairs(
    tracks: Tracks,
    xp: np.ndarray,
    Pp: np.ndarray,
    dt: np.ndarray,
    scan: Scan,
    index: _Index,
    config: InitiationConfig,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(track, plot, statistic) of the plots inside each track's gate."""
    w = _widening(tracks.misses, config)
    if config.mode == "cartesian":
        gamma = stats.chi2.ppf(config.gate_P_G, 2) * w
        r_max = np.trace(scan.R, axis1=1, axis2=2).max() if scan.size else 0.0
        radius = np.sqrt(gamma * (np.trace(Pp[:, :2, :2], axis1=1, axis2=2) + r_max))
        rows, cols = index.ball(xp[:, :2], radius)
        nu = scan.z[cols] - xp[rows, :2]
        Si = _inv2(Pp[rows, :2, :2] + scan.R[cols])
        s = np.einsum("ni,nij,nj->n", nu, Si, nu)
        keep = s <= gamma[rows]
        return rows[keep], cols[keep], s[keep]
    K_R, K_az = _window_coefficients(config)
    r_last, r_prev = tracks.ranges[:, -1], tracks.ranges[:, -2]
    span = tracks.times[:, -1] - tracks.times[:, -2]
    a = np.divide(dt, span, out=np.zeros_like(dt), where=span > 0)
    r_pred = r_last + a * (r_last - r_prev)
    var_pred = (1 + a) ** 2 * tracks.sigma_r[:, -1] ** 2 + a**2 * tracks.sigma_r[:, -2] ** 2
    tangential = np.arcsin(np.minimum(1.0, config.v_max * dt / r_last))
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
    keep = (d_r <= W_R) & (d_az <= W_az)
    s = (d_r / W_R) ** 2 + (d_az / W_az) ** 2
    return rows[keep], cols[keep], s[keep]


def _capture_pairs(
    ini: Initiators,
    scan: Scan,
    index: _Index,
    config: InitiationConfig,
    allowed: np.ndarray,
    k: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(initiator, plot, distance) of the plots inside each initiator's capture gate.

    Only initiators within the 2/N (or 2/T) window of scan number k take part.
    """
    tau = scan.t - ini.t
    if config.capture_time is None:
        window = k - ini.scan <= config.capture_scans - 1
    else:
        window = tau <= config.capture_time
    R_max = config.v_max * np.maximum(tau, 0.0)
    later = np.flatnonzero((tau > 0) & window)  # a plot from a later time, in time
    if config.mode == "polar":
        K_R, K_az = _window_coefficients(config)
        W_R = R_max + K_R * np.sqrt(ini.sigma_r**2 + scan.sigma_r.max(initial=0.0) ** 2)
        W_az = np.arcsin(np.minimum(1.0, R_max / ini.r)) + K_az * np.sqrt(
            ini.sigma_az**2 + scan.sigma_az.max(initial=0.0) ** 2
        )
        rows, cols = index.window(ini.r[later], ini.az[later], W_R[later], W_az[later])
    elif config.capture_gate == "ring":
        radius = R_max
    elif config.capture_gate == "expanded":
        K_g = float(expansion_coefficient(config.capture_p))
        radius = R_max + K_g * np.maximum(ini.sigma_r, ini.r * ini.sigma_az)
    else:
        gamma = stats.chi2.ppf(config.capture_P_G, 2)
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
    return rows, cols, np.linalg.norm(scan.z[cols] - ini.z[rows], axis=1)


def _nearest(
    rows: np.ndarray, cols: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pair of smallest statistic for each row (ties: the lower plot index)."""
    order = np.lexsort((cols, s, rows))
    first = order[np.r_[True, rows[order][1:] != rows[order][:-1]]] if rows.size else order
    return rows[first], cols[first], s[first]


# ------------------------------------------------------------------ track bookkeeping


def _shift_in(old: np.ndarray, new: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Append new[i] to row i of a history (dropping the oldest) where hit[i]."""
    shifted = np.concatenate([old[:, 1:], new[:, None]], axis=1)
    return np.where(hit[:, None], shifted, old)


def _acceleration_ok(tracks: Tracks, config: InitiationConfig) -> np.ndarray:
    """Seed 002: |second divided difference of range| <= K_A a_max for every plot triple."""
    r, t = tracks.ranges, tracks.times
    r1, r2, r3 = r[:, :-2], r[:, 1:-1], r[:, 2:]
    t1, t2, t3 = t[:, :-2], t[:, 1:-1], t[:, 2:]
    with np.errstate(invalid="ignore", divide="ignore"):
        dd = 2.0 * ((r3 - r2) / (t3 - t2) - (r2 - r1) / (t2 - t1)) / (t3 - t1)
    bad = np.isfinite(dd) & (np.abs(dd) > config.K_A * config.a_max)
    return ~bad.any(axis=1)


def _new_tracks(
    ini: Initiators,
    rows: np.ndarray,
    cols: np.ndarray,
    scan: Scan,
    ids: np.ndarray,
    first_id: int,
    config: InitiationConfig,
) -> Tracks:
    """Tentative tracks from (initiator, plot) pairs."""
    m, h = rows.size, config.history
    tau = scan.t - ini.t[rows]
    x, P = _two_point(ini.z[rows], ini.R[rows], scan.z[cols], scan.R[cols], tau)

    def history(first: np.ndarray, second: np.ndarray, fill: float) -> np.ndarray:
        out = np.full((m, h), fill, dtype=np.asarray(first).dtype)
        out[:, -2], out[:, -1] = first, second
        return out

    return Tracks(
        id=first_id + np.arange(m, dtype=np.int64),
        confirmed=np.zeros(m, dtype=bool),
        x=x,
        P=P,
        t=np.full(m, scan.t),
        n=np.full(m, 2, dtype=np.int64),
        first_scan=ini.scan[rows],
        confirmed_scan=np.full(m, -1, dtype=np.int64),
        misses=np.zeros(m, dtype=np.int64),
        cost=np.zeros(m),
        plots=history(ini.plot[rows], ids[cols], -1),
        ranges=history(ini.r[rows], scan.r[cols], np.nan),
        times=history(ini.t[rows], np.full(m, scan.t), np.nan),
        sigma_r=history(ini.sigma_r[rows], scan.sigma_r[cols], np.nan),
        az=scan.az[cols],
        sigma_az=scan.sigma_az[cols],
        sensor=scan.sensor[cols],
    )


# ------------------------------------------------------------------ one scan


def _step(
    state: InitiationState, scan: Scan, config: InitiationConfig
) -> tuple[InitiationState, ScanReport]:
    k, n = state.scans, scan.size
    if n > PLOT_STRIDE:
        raise ParameterError("scans", f"a scan may hold at most {PLOT_STRIDE} plots, got {n}")
    ids = k * PLOT_STRIDE + np.arange(n, dtype=np.int64)
    index = _Index(scan, config)
    tracks = state.tracks
    m = tracks.size

    # 1-3: predict and associate
    dt = scan.t - tracks.t
    xp, Pp = _predict(tracks.x, tracks.P, dt, config.q)
    assoc = np.full(m, -1, dtype=np.int64)
    stat = np.zeros(m)
    used = np.zeros(n, dtype=bool)  # taken by a confirmed track
    rows, cols, s = _track_pairs(tracks, xp, Pp, dt, scan, index, config)
    conf = tracks.confirmed[rows]
    a, b, c = one_to_one(rows[conf], cols[conf], s[conf])
    assoc[a], stat[a], used[b] = b, c, True
    free = ~conf & ~used[cols]
    a, b, c = _nearest(rows[free], cols[free], s[free])
    assoc[a], stat[a] = b, c
    hit = assoc >= 0
    x, P = xp, Pp
    if hit.any():
        j = assoc[hit]
        x, P = xp.copy(), Pp.copy()
        x[hit], P[hit] = _update(
            xp[hit], Pp[hit], scan.z[j], scan.R[j], tracks.n[hit] + 1.0, dt[hit], config
        )
    j = np.maximum(assoc, 0)
    tracks = Tracks(
        id=tracks.id,
        confirmed=tracks.confirmed,
        x=x,
        P=P,
        t=np.full(m, scan.t),
        n=tracks.n + hit,
        first_scan=tracks.first_scan,
        confirmed_scan=tracks.confirmed_scan,
        misses=np.where(hit, 0, tracks.misses + 1),
        cost=tracks.cost + stat,
        plots=_shift_in(tracks.plots, ids[j] if n else assoc, hit),
        ranges=_shift_in(tracks.ranges, scan.r[j] if n else dt, hit),
        times=_shift_in(tracks.times, np.full(m, scan.t), hit),
        sigma_r=_shift_in(tracks.sigma_r, scan.sigma_r[j] if n else dt, hit),
        az=np.where(hit, scan.az[j] if n else 0.0, tracks.az),
        sigma_az=np.where(hit, scan.sigma_az[j] if n else 0.0, tracks.sigma_az),
        sensor=np.where(hit[:, None], scan.sensor[j] if n else 0.0, tracks.sensor),
    )
    by_track = np.full(n, -1, dtype=np.int64)
    by_track[assoc[hit & ~tracks.confirmed]] = tracks.id[hit & ~tracks.confirmed]
    by_track[assoc[hit & tracks.confirmed]] = tracks.id[hit & tracks.confirmed]

    # 4: capture
    ini = state.initiators
    rows, cols, dist = _capture_pairs(ini, scan, index, config, ~used, k)
    if config.association == "nearest":
        rows, cols, dist = _nearest(rows, cols, dist)
    born = _new_tracks(ini, rows, cols, scan, ids, state.next_track, config)
    captured = np.zeros(n, dtype=bool)
    captured[cols] = True
    unset = by_track[cols] < 0
    by_track[cols[unset]] = born.id[unset]
    tracks = tracks.join(born)

    # 5: confirmation, conflicts, pruning
    age = k - tracks.first_scan + 1
    ready = ~tracks.confirmed & (tracks.n >= config.confirm_k) & (age <= config.confirm_m)
    dropped, reasons = [], []
    if config.mode == "polar":
        jerky = ready & ~_acceleration_ok(tracks, config)
        dropped.append(jerky)
        reasons.append("acceleration")
        ready &= ~jerky
    order = np.flatnonzero(ready)
    order = order[np.argsort(tracks.cost[order] / (tracks.n[order] - 1), kind="stable")]
    keep = keep_greedy(tracks.plots[order])
    confirmed = tracks.confirmed.copy()
    confirmed[order[keep]] = True
    newly = np.zeros(tracks.size, dtype=bool)
    newly[order[keep]] = True
    tentative = np.flatnonzero(~confirmed)
    pruned = np.zeros(tracks.size, dtype=bool)
    pruned[tentative] = shares_two(tracks.plots[tentative], tracks.plots[confirmed])
    dropped.append(pruned)
    reasons.append("pruned")
    tracks = replace(
        tracks, confirmed=confirmed, confirmed_scan=np.where(newly, k, tracks.confirmed_scan)
    )

    # 6: drops
    window = ~confirmed & (tracks.n + (config.confirm_m - age) < config.confirm_k)
    misses = tracks.misses >= config.drop_misses
    gone = np.zeros(tracks.size, dtype=bool)
    why = np.empty(tracks.size, dtype=object)
    for mask, reason in zip(
        [misses, window, *dropped], ["misses", "window", *reasons], strict=True
    ):
        fresh = mask & ~gone
        why[fresh] = reason
        gone |= fresh

    # 7: initiators
    if config.capture_time is None:
        alive = (k - ini.scan) < config.capture_scans - 1
    else:
        alive = scan.t - ini.t < config.capture_time
    alive[rows] = False  # captured initiators are consumed
    fresh = ~used & ~captured & (by_track < 0)
    new_ini = Initiators(
        plot=ids[fresh],
        scan=np.full(fresh.sum(), k, dtype=np.int64),
        t=np.full(fresh.sum(), scan.t),
        z=scan.z[fresh],
        R=scan.R[fresh],
        sensor=scan.sensor[fresh],
        r=scan.r[fresh],
        az=scan.az[fresh],
        sigma_r=scan.sigma_r[fresh],
        sigma_az=scan.sigma_az[fresh],
    )
    initiators = Initiators(
        *(
            np.concatenate([getattr(ini, f)[alive], getattr(new_ini, f)])
            for f in Initiators.__dataclass_fields__
        )
    )
    report = ScanReport(
        scan=k,
        t=scan.t,
        plots=n,
        associated=by_track,
        initiators=int(fresh.sum()),
        started=born.id,
        confirmed=tracks.id[newly],
        dropped=tracks.id[gone],
        reasons=why[gone].astype(str),
    )
    return InitiationState(
        version=state.version,
        config_digest=state.config_digest,
        scans=k + 1,
        t=scan.t,
        next_track=state.next_track + born.size,
        initiators=initiators,
        tracks=tracks.take(~gone),
    ), report


def initiate(
    state: InitiationState | None,
    scans: Sequence[Scan],
    config: InitiationConfig,
    max_tracks: int | None = None,
) -> tuple[InitiationState, list[ScanReport]]:
    """Run track initiation over scans in time order, from a state (None: a new session).

    Parameters
    ----------
    state : InitiationState or None
        The state returned by the previous call (made under the same ``config``), or
        None to start.
    scans : sequence of Scan
        The next scans, times non-decreasing and not before the state's last scan.
    config : InitiationConfig
    max_tracks : int, optional
        Most live tracks after any scan: a bound on the work of every later scan (each
        predicts, gates and checks every live track). None: no bound.

    Returns
    -------
    state : InitiationState
        Pass it to the next call. Sending scans one call at a time answers exactly as
        sending them all at once.
    reports : list of ScanReport
        One per scan.

    Raises
    ------
    ParameterError
        ``"state"`` for a state made under other settings; ``"scans"`` (with the scan's
        index) for a time earlier than the one before it, for a scan after which more
        than ``max_tracks`` tracks live or a track's state is not finite (two plots too
        close in time for a velocity), or for scans that would take the session past
        :data:`~plotgate.core.initiation.state.MAX_SESSION_SCANS`.

    References
    ----------
    .. [1] Seed 003: auto-capture of trajectories, k/m and k/m - l criteria, narrow /
       medium / wide gates, alpha-beta coefficients (Fig. 3.5).
    .. [2] Seed 002: track initiation in polar coordinates, eqs. (1)-(5), 3/4 sliding
       window.

    Examples
    --------
    A target at 10 m/s east, four scans a second apart, no clutter:

    >>> from plotgate.core.initiation.scan import cartesian_scan
    >>> R = np.eye(2)[None] * 4.0
    >>> scans = [cartesian_scan(t, [[1000.0 + 10.0 * t, 2000.0]], R) for t in range(4)]
    >>> state, reports = initiate(None, scans, InitiationConfig(v_max=20.0))
    >>> [r.confirmed.tolist() for r in reports], state.tracks.n.tolist()
    ([[], [], [0], []], [4])
    """
    state = empty_state(config) if state is None else state
    if state.config_digest != config.digest():
        raise ParameterError("state", "was made under other settings than these")
    if state.scans + len(scans) > MAX_SESSION_SCANS:
        raise ParameterError(
            "scans",
            f"would take the session past {MAX_SESSION_SCANS} "
            f"scans (it has {state.scans}); start a new session",
        )
    reports = []
    last = state.t
    for i, scan in enumerate(scans):
        if last is not None and scan.t < last:
            raise ParameterError(
                "scans",
                f"time {scan.t} s is before the previous scan's "
                f"{last} s; scans must come in time order",
                i,
            )
        try:
            with np.errstate(all="ignore"):  # checked below, on the step's result
                state, report = _step(state, scan, config)
        except ParameterError as exc:  # a scan's own problem: say which scan
            if exc.field != "scans" or exc.index is not None:
                raise
            raise ParameterError("scans", exc.reason, i) from exc
        if not (np.isfinite(state.tracks.x).all() and np.isfinite(state.tracks.P).all()):
            bad = int(
                np.flatnonzero(
                    ~np.isfinite(state.tracks.P).all(axis=(1, 2))
                    | ~np.isfinite(state.tracks.x).all(axis=1)
                )[0]
            )
            raise ParameterError(
                "scans",
                f"leaves track {state.tracks.id[bad]} with a state "
                "or covariance beyond double precision (scans or plot "
                "times too close together for a velocity?)",
                i,
            )
        if max_tracks is not None and state.tracks.size > max_tracks:
            raise ParameterError(
                "scans",
                f"leaves {state.tracks.size} live tracks (scan "
                f"{state.scans - 1} of the session); at most {max_tracks}: "
                "narrower capture gates, nearest association or fewer "
                "plots",
                i,
            )
        reports.append(report)
        last = scan.t
    return state, reports
