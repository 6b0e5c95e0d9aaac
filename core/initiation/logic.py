"""Track initiation from plots in clutter, one scan after another.

The secondary-processing textbook (the logic of auto-capture: ring capture zone, k/m and
k/m - l criteria, narrow / medium / wide gates, alpha-beta smoothing, branch or
single-plot association), Mu et al. (the polar method for slow ground targets: sector
windows, range-only extrapolation, the tangential-speed azimuth window, the radial
acceleration check, 3/4 over a sliding window) and Konovalov (the ring, expanded and
combined capture gates).

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
5. A tentative track with k plots within its first m scans is confirmed, or under score
   confirmation one whose track score (:mod:`plotgate.core.initiation.score`, Blackman
   and Popoli, ch. 6) reaches Wald's threshold ln((1 - beta) / alpha) with at least k
   plots; in polar mode
   only if every triple of its ranges passes the acceleration check (a track that
   fails it is dropped). Newly confirmed tracks sharing two or more plots keep the one
   with the smaller mean statistic (the higher score under score confirmation);
   tentative tracks sharing two or more plots with a confirmed track are pruned.
6. Dropped: l misses in a row; a tentative track whose k is no longer reachable within
   m scans, or under score confirmation whose score is at or below Wald's
   ln(beta / (1 - alpha)); any track whose speed exceeds v_max by more than
   :data:`~plotgate.core.initiation.filter.SPEED_SIGMAS` of its velocity sigma (before
   it may confirm; a clutter track the filter has run away with, or a target faster
   than the settings describe).
7. Plots of the scan used by no track and captured by no initiator become initiators;
   initiators past their window expire, and captured ones at once. Under score
   confirmation every plot no confirmed track holds becomes an initiator, and an
   initiator lives out its window captured or not, until a confirmed track holds its
   plot: a plot a clutter initiator captured or a tentative track took may still be
   the first of its own target's track (a target seen in scans 2, 3 and 4 whose scan-2
   plot a clutter plot of scan 1 captured), and an initiator whose capture took a
   clutter plot may still capture its target's plot a scan later; tracks sharing plots
   are resolved by their scores at confirmation (step 5).

The filter is :mod:`plotgate.core.initiation.filter`, the candidate search
:mod:`plotgate.core.initiation.search` and the gates on its candidates
:mod:`plotgate.core.initiation.pairs`. Every scan counts as an opportunity for every track
(the scans are one surveillance picture); polar mode measures ranges and azimuths about
each plot's own sensor, so a track should be fed by one sensor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from plotgate.core.errors import ParameterError
from plotgate.core.initiation.assignment import one_to_one
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.filter import (
    SPEED_SIGMAS,
    alpha_beta_gain,
    kalman_gain,
    one_point,
    predict,
    speed_excess,
    two_point,
    update,
)
from plotgate.core.initiation.pairs import capture_pairs, nearest, track_pairs, window_coefficients
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.score import (
    capture_score,
    first_plot_score,
    log_clutter_density,
    miss_score,
    update_score,
    wald_thresholds,
)
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.sharing import keep_greedy, shares_two
from plotgate.core.initiation.state import (
    MAX_SESSION_SCANS,
    PLOT_STRIDE,
    InitiationState,
    Initiators,
    Tracks,
    empty_state,
)
from plotgate.core.sym2 import sym2

__all__ = ["DROP_REASONS", "ScanReport", "initiate"]

DROP_REASONS = ("misses", "window", "acceleration", "speed", "pruned", "score")
"""Why a track was dropped: l misses in a row; k unreachable within m; the polar
acceleration check; a speed beyond v_max (filter.speed_excess); sharing two or more plots
with a confirmed track; a tentative track's score at or below Wald's deletion threshold."""


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


# ------------------------------------------------------------------ track bookkeeping


def _shift_in(old: np.ndarray, new: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Append new[i] to row i of a history (dropping the oldest) where hit[i]."""
    shifted = np.concatenate([old[:, 1:], new[:, None]], axis=1)
    return np.where(hit[:, None], shifted, old)


def _acceleration_ok(tracks: Tracks, config: InitiationConfig) -> np.ndarray:
    """Mu et al.: |second divided difference of range| <= K_A a_max for every plot triple."""
    r, t = tracks.ranges, tracks.times
    r1, r2, r3 = r[:, :-2], r[:, 1:-1], r[:, 2:]
    t1, t2, t3 = t[:, :-2], t[:, 1:-1], t[:, 2:]
    with np.errstate(invalid="ignore", divide="ignore"):
        dd = 2.0 * ((r3 - r2) / (t3 - t2) - (r2 - r1) / (t2 - t1)) / (t3 - t1)
    bad = np.isfinite(dd) & (np.abs(dd) > config.K_A * config.a_max)
    ok: np.ndarray = ~bad.any(axis=1)
    return ok


def _new_tracks(
    ini: Initiators,
    rows: np.ndarray,
    cols: np.ndarray,
    scan: Scan,
    k: int,
    ids: np.ndarray,
    first_id: int,
    config: InitiationConfig,
) -> Tracks:
    """Tentative tracks from (initiator, plot) pairs of scan number k."""
    m, h = rows.size, config.history
    tau = scan.t - ini.t[rows]
    if config.confirmation == "score":  # the speed bound as a prior, updated with z2
        x1, P1 = one_point(ini.z[rows], ini.R[rows], config.v_max)
        xp, Pp = predict(x1, P1, tau, config.q)
        R2 = scan.R[cols]
        S = Pp[:, :2, :2] + R2
        nu = scan.z[cols] - xp[:, :2]
        x, P = update(xp, Pp, scan.z[cols], R2, kalman_gain(Pp, R2))
        gaps = k - ini.scan[rows] - 1
        density = log_clutter_density(config, scan.size)
        score = ini.score[rows] + capture_score(nu, S, gaps, config, density)
    else:
        x, P = two_point(ini.z[rows], ini.R[rows], scan.z[cols], scan.R[cols], tau)
        score = np.zeros(m)

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
        score=score,
    )


# ------------------------------------------------------------------ one scan


def _step(
    state: InitiationState, scan: Scan, config: InitiationConfig
) -> tuple[InitiationState, ScanReport]:
    k, n = state.scans, scan.size
    if n > PLOT_STRIDE:
        raise ParameterError("scans", f"a scan may hold at most {PLOT_STRIDE} plots, got {n}")
    ids = k * PLOT_STRIDE + np.arange(n, dtype=np.int64)
    index = PlotIndex(scan, window_coefficients(config) if config.mode == "polar" else None)
    tracks = state.tracks
    m = tracks.size

    # 1-3: predict and associate
    dt = scan.t - tracks.t
    xp, Pp = predict(tracks.x, tracks.P, dt, config.q)
    assoc = np.full(m, -1, dtype=np.int64)
    stat = np.zeros(m)
    used = np.zeros(n, dtype=bool)  # taken by a confirmed track
    rows, cols, s = track_pairs(tracks, xp, Pp, dt, scan, index, config)
    conf = tracks.confirmed[rows]
    a, b, c = one_to_one(rows[conf], cols[conf], s[conf])
    assoc[a], stat[a], used[b] = b, c, True
    free = ~conf & ~used[cols]
    a, b, c = nearest(rows[free], cols[free], s[free])
    assoc[a], stat[a] = b, c
    hit = assoc >= 0
    score = tracks.score
    if config.confirmation == "score":
        score = score + np.where(hit, 0.0, miss_score(config))
        if hit.any():
            j = assoc[hit]
            nu = scan.z[j] - xp[hit, :2]
            S = sym2(Pp[hit, :2, :2] + scan.R[j])
            density = log_clutter_density(config, n)
            score[hit] += update_score(nu[:, 0], nu[:, 1], S, config, density)
    x, P = xp, Pp
    if hit.any():
        j = assoc[hit]
        x, P = xp.copy(), Pp.copy()
        if config.filter == "kalman":
            K = kalman_gain(Pp[hit], scan.R[j])
        else:
            K = alpha_beta_gain(tracks.n[hit] + 1.0, dt[hit], config.alpha_min, config.beta_min)
        x[hit], P[hit] = update(xp[hit], Pp[hit], scan.z[j], scan.R[j], K)
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
        score=score,
    )
    by_track = np.full(n, -1, dtype=np.int64)
    by_track[assoc[hit & ~tracks.confirmed]] = tracks.id[hit & ~tracks.confirmed]
    by_track[assoc[hit & tracks.confirmed]] = tracks.id[hit & tracks.confirmed]

    # 4: capture
    ini = state.initiators
    rows, cols, dist = capture_pairs(ini, scan, index, config, ~used, k)
    if config.association == "nearest":
        rows, cols, dist = nearest(rows, cols, dist)
    born = _new_tracks(ini, rows, cols, scan, k, ids, state.next_track, config)
    captured = np.zeros(n, dtype=bool)
    captured[cols] = True
    unset = by_track[cols] < 0
    by_track[cols[unset]] = born.id[unset]
    tracks = tracks.join(born)

    # 5: confirmation, conflicts, pruning
    age = k - tracks.first_scan + 1
    confirm_at, delete_at = wald_thresholds(config)
    if config.confirmation == "score":
        ready = ~tracks.confirmed & (tracks.score >= confirm_at) & (tracks.n >= config.confirm_k)
    else:
        ready = ~tracks.confirmed & (tracks.n >= config.confirm_k) & (age <= config.confirm_m)
    dropped, reasons = [], []
    if config.mode == "polar":
        jerky = ready & ~_acceleration_ok(tracks, config)
        dropped.append(jerky)
        reasons.append("acceleration")
        ready &= ~jerky
    # faster than v_max allows, confirmed or not: neither confirms nor prunes, and no
    # state carries it (a state with one is refused as tampered)
    fast = speed_excess(tracks.x, tracks.P, config.v_max) > SPEED_SIGMAS
    dropped.append(fast)
    reasons.append("speed")
    ready &= ~fast
    order = np.flatnonzero(ready)
    if config.confirmation == "score":  # the likelier track first
        rank = -tracks.score[order]
    else:  # the smaller mean statistic first
        rank = tracks.cost[order] / (tracks.n[order] - 1)
    order = order[np.argsort(rank, kind="stable")]
    keep = keep_greedy(tracks.plots[order])
    confirmed = tracks.confirmed.copy()
    confirmed[order[keep]] = True
    newly = np.zeros(tracks.size, dtype=bool)
    newly[order[keep]] = True
    tentative = np.flatnonzero(~confirmed)
    pruned = np.zeros(tracks.size, dtype=bool)
    pruned[tentative] = shares_two(tracks.plots[tentative], tracks.plots[confirmed & ~fast])
    dropped.append(pruned)
    reasons.append("pruned")
    tracks = replace(
        tracks, confirmed=confirmed, confirmed_scan=np.where(newly, k, tracks.confirmed_scan)
    )

    # 6: drops
    if config.confirmation == "score":
        dropped.append(~confirmed & (tracks.score <= delete_at))
        reasons.append("score")
        window = np.zeros(tracks.size, dtype=bool)
    else:
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
    if config.confirmation == "score":  # every hypothesis stays open: the score decides
        held = tracks.plots[confirmed]  # but a confirmed track's plots are its own
        alive &= ~np.isin(ini.plot, held)
        fresh = ~np.isin(ids, held)
    else:  # the textbook's: captured initiators and used plots are consumed
        alive[rows] = False
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
        score=np.full(
            fresh.sum(),
            first_plot_score(config, log_clutter_density(config, n))
            if config.confirmation == "score"
            else 0.0,
        ),
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
    .. [1] The secondary-processing textbook: auto-capture of trajectories, k/m and
       k/m - l criteria, narrow / medium / wide gates, alpha-beta coefficients (Fig. 3.5).
    .. [2] Mu et al., track initiation in polar coordinates, eq. (1)-(5), 3/4 sliding
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
