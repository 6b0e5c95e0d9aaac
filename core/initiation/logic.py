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
   gate_widening[misses] after misses in a row. Under existence confirmation
   (:mod:`plotgate.core.initiation.existence`, IPDA) the nearest plot still enters a
   tentative track's history, but its state and probability of existence come from
   every plot in its gate that no confirmed track took (the PDA mixture, and the Markov
   chain then Mušicki et al.'s update).
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

Each stage is one function below (:func:`_predicted`, :func:`_associate` and
:func:`_updated` for 1-3, :func:`_capture` and :func:`_born` for 4, :func:`_confirm` for
5, :func:`_dropped` for 6, :func:`_initiators` for 7); the choices of the settings are
made once, by :func:`~plotgate.core.initiation.rules.select_rules`, before the first
scan. An empty scan associates and captures nothing: every track misses, no initiator
is captured. A track dropped for several reasons reports the first of
:data:`DROP_REASONS`.

The filter is :mod:`plotgate.core.initiation.filter`, the candidate search
:mod:`plotgate.core.initiation.search`, the track gates on its candidates
:mod:`plotgate.core.initiation.pairs`, the capture gates
:mod:`plotgate.core.initiation.capture` and the confirmation rules
:mod:`plotgate.core.initiation.confirmation`. Every scan counts as an opportunity for every track
(the scans are one surveillance picture); polar mode measures ranges and azimuths about
each plot's own sensor, so a track should be fed by one sensor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from plotgate.core.errors import ParameterError
from plotgate.core.initiation.assignment import one_to_one
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.existence import Gated
from plotgate.core.initiation.filter import SPEED_SIGMAS, predict, speed_excess, update
from plotgate.core.initiation.held import held_plots
from plotgate.core.initiation.pairs import Pairs, Prediction, nearest
from plotgate.core.initiation.rules import Rules, select_rules
from plotgate.core.initiation.scan import Scan
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

__all__ = ["DROP_REASONS", "ScanReport", "initiate"]

DROP_REASONS = ("misses", "window", "acceleration", "speed", "pruned", "score", "existence")
"""Why a track was dropped: l misses in a row; k unreachable within m; the polar
acceleration check; a speed beyond v_max (filter.speed_excess); sharing two or more plots
with a confirmed track; a tentative track's score at or below Wald's deletion threshold;
its probability of existence at or below existence_delete."""


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


# ------------------------------------------------------------------ the stages


class _Association(NamedTuple):
    """Stages 2-3: plot (m,) each track took (-1 none) and its gate statistic (0 none);
    taken (n,) the plots confirmed tracks took (no one else may use them); shared the
    tentative tracks' gated pairs on the other plots (existence weighs them all)."""

    plot: np.ndarray
    statistic: np.ndarray
    taken: np.ndarray
    shared: Pairs


def _no_pairs() -> Pairs:
    none = np.zeros(0, dtype=np.int64)
    return Pairs(none, none, np.zeros(0))


def _predicted(tracks: Tracks, t: float, config: InitiationConfig) -> Prediction:
    """Stage 1: every track predicted to the scan time t (constant velocity, white
    acceleration q; the alpha-beta smoother's covariance follows the same model)."""
    dt = t - tracks.t
    x, P = predict(tracks.x, tracks.P, dt, config.q)
    return Prediction(dt, x, P)


def _associate(
    tracks: Tracks, prediction: Prediction, scan: Scan, index: PlotIndex, rules: Rules
) -> _Association:
    """Stages 2-3: confirmed tracks take plots one to one (the least total statistic);
    tentative tracks take the nearest plot in their gate that no confirmed track took
    (several may share one)."""
    plot = np.full(tracks.size, -1, dtype=np.int64)
    statistic = np.zeros(tracks.size)
    taken = np.zeros(scan.size, dtype=bool)
    if scan.size == 0:
        return _Association(plot, statistic, taken, _no_pairs())
    gated = rules.track_pairs(tracks, prediction, scan, index)
    by_confirmed = tracks.confirmed[gated.row]
    owned = Pairs(*one_to_one(*gated.take(by_confirmed)))
    plot[owned.row], statistic[owned.row], taken[owned.plot] = owned.plot, owned.statistic, True
    shared = gated.take(~by_confirmed & ~taken[gated.plot])
    chosen = nearest(shared)
    plot[chosen.row], statistic[chosen.row] = chosen.plot, chosen.statistic
    return _Association(plot, statistic, taken, shared)


def _shift_in(history: np.ndarray, hit: np.ndarray, new: np.ndarray) -> np.ndarray:
    """The history (m, H) with new[i] appended to the i-th hit row (its oldest dropped)."""
    shifted = history.copy()
    shifted[hit] = np.concatenate([history[hit, 1:], new[:, None]], axis=1)
    return shifted


def _put(values: np.ndarray, hit: np.ndarray, new: np.ndarray) -> np.ndarray:
    """values with its hit rows replaced by new."""
    out = values.copy()
    out[hit] = new
    return out


def _updated(
    tracks: Tracks,
    prediction: Prediction,
    association: _Association,
    scan: Scan,
    ids: np.ndarray,
    rules: Rules,
) -> Tracks:
    """The tracks after stages 1-3: each predicted to the scan, updated with the plot it
    took (the rules' gain, the covariance in Joseph form), its counts, histories, last
    plot and score moved on; a track that took none keeps its prediction and counts a
    miss."""
    hit = association.plot >= 0
    plot = association.plot[hit]
    x, P = prediction.x.copy(), prediction.P.copy()
    if plot.size:
        R = scan.R[plot]
        K = rules.gain(tracks.n[hit] + 1.0, prediction.dt[hit], prediction.P[hit], R)
        x[hit], P[hit] = update(prediction.x[hit], prediction.P[hit], scan.z[plot], R, K)
    return Tracks(
        id=tracks.id,
        confirmed=tracks.confirmed,
        x=x,
        P=P,
        t=np.full(tracks.size, scan.t),
        n=tracks.n + hit,
        first_scan=tracks.first_scan,
        confirmed_scan=tracks.confirmed_scan,
        misses=np.where(hit, 0, tracks.misses + 1),
        cost=tracks.cost + association.statistic,
        plots=_shift_in(tracks.plots, hit, ids[plot]),
        ranges=_shift_in(tracks.ranges, hit, scan.r[plot]),
        times=_shift_in(tracks.times, hit, np.full(plot.size, scan.t)),
        sigma_r=_shift_in(tracks.sigma_r, hit, scan.sigma_r[plot]),
        az=_put(tracks.az, hit, scan.az[plot]),
        sigma_az=_put(tracks.sigma_az, hit, scan.sigma_az[plot]),
        sensor=_put(tracks.sensor, hit, scan.sensor[plot]),
        score=rules.confirmation.rescore(tracks, prediction, association.plot, scan),
    )


def _capture(
    ini: Initiators, scan: Scan, index: PlotIndex, taken: np.ndarray, k: int, rules: Rules
) -> Pairs:
    """Stage 4: (initiator, plot) pairs that start tracks: the plots no confirmed track
    took inside the capture gates of the initiators within their window, all of them
    (branch) or each initiator's nearest."""
    if scan.size == 0:
        return _no_pairs()
    return rules.choose(rules.capture(ini, scan, index, ~taken, k))


def _history(first: np.ndarray, second: np.ndarray, fill: float, width: int) -> np.ndarray:
    """Rows of a history (c, width): fill, then the first and the second plot's value."""
    rows = np.full((first.shape[0], width), fill, dtype=np.asarray(first).dtype)
    rows[:, -2], rows[:, -1] = first, second
    return rows


def _born(
    ini: Initiators,
    captured: Pairs,
    scan: Scan,
    ids: np.ndarray,
    k: int,
    first_id: int,
    rules: Rules,
) -> Tracks:
    """Stage 4: a tentative track per captured pair of scan number k, in the
    confirmation rule's starting state."""
    first, plot = captured.row, captured.plot
    c, H = first.size, rules.config.history
    x, P, score = rules.confirmation.start(ini, captured, scan, k)
    return Tracks(
        id=first_id + np.arange(c, dtype=np.int64),
        confirmed=np.zeros(c, dtype=bool),
        x=x,
        P=P,
        t=np.full(c, scan.t),
        n=np.full(c, 2, dtype=np.int64),
        first_scan=ini.scan[first],
        confirmed_scan=np.full(c, -1, dtype=np.int64),
        misses=np.zeros(c, dtype=np.int64),
        cost=np.zeros(c),
        plots=_history(ini.plot[first], ids[plot], -1, H),
        ranges=_history(ini.r[first], scan.r[plot], np.nan, H),
        times=_history(ini.t[first], np.full(c, scan.t), np.nan, H),
        sigma_r=_history(ini.sigma_r[first], scan.sigma_r[plot], np.nan, H),
        az=scan.az[plot],
        sigma_az=scan.sigma_az[plot],
        sensor=scan.sensor[plot],
        score=score,
    )


def _confirm(
    tracks: Tracks, k: int, rules: Rules
) -> tuple[Tracks, np.ndarray, dict[str, np.ndarray]]:
    """Stage 5: the ready tentative tracks confirm, the better of two sharing two or more
    plots first; tentative tracks sharing two or more plots with a confirmed one are
    pruned.

    A ready track that fails the mode's check (polar: the acceleration check) is dropped,
    and so is any track faster than v_max allows (confirmed or not: neither confirms nor
    prunes, and no state carries it; a state with one is refused as tampered). Returns
    the tracks with their new confirmations, the mask of the newly confirmed, and the
    masks of those checks' drops by reason.
    """
    ready = rules.confirmation.ready(tracks, k)
    jerky = ready & ~rules.plausible(tracks)
    fast = speed_excess(tracks.x, tracks.P, rules.config.v_max) > SPEED_SIGMAS
    candidates = np.flatnonzero(ready & ~jerky & ~fast)
    merit = rules.confirmation.merit(tracks, candidates)
    order = candidates[np.argsort(merit, kind="stable")]
    winners = order[keep_greedy(tracks.plots[order])]
    confirmed = tracks.confirmed.copy()
    confirmed[winners] = True
    newly = np.zeros(tracks.size, dtype=bool)
    newly[winners] = True
    tentative = np.flatnonzero(~confirmed)
    pruned = np.zeros(tracks.size, dtype=bool)
    pruned[tentative] = shares_two(tracks.plots[tentative], tracks.plots[confirmed & ~fast])
    after = replace(
        tracks, confirmed=confirmed, confirmed_scan=np.where(newly, k, tracks.confirmed_scan)
    )
    return after, newly, {"acceleration": jerky, "speed": fast, "pruned": pruned}


def _dropped(tracks: Tracks, checks: dict[str, np.ndarray], k: int, rules: Rules) -> np.ndarray:
    """Stage 6: why each track is dropped, as an index into :data:`DROP_REASONS`
    (len(DROP_REASONS) for a track kept): l misses in a row, the confirmation rule's
    lapse (k out of reach within m, or the score at Wald's deletion threshold), or stage
    5's checks; the first reason of :data:`DROP_REASONS` counts."""
    lapse, lapsed = rules.confirmation.lapsed(tracks, k)
    causes = {"misses": tracks.misses >= rules.config.drop_misses, lapse: lapsed, **checks}
    why = np.full(tracks.size, len(DROP_REASONS))
    for code in reversed(range(len(DROP_REASONS))):  # the first reason written last
        if DROP_REASONS[code] in causes:
            why[causes[DROP_REASONS[code]]] = code
    return why


def _initiators(
    ini: Initiators,
    spent: np.ndarray,
    scan: Scan,
    ids: np.ndarray,
    seeds: np.ndarray,
    k: int,
    rules: Rules,
) -> Initiators:
    """Stage 7: the initiators still within their window and not ``spent``, then the
    ``seeds`` of scan number k, each a new initiator (the confirmation rule decides
    both: :meth:`~plotgate.core.initiation.confirmation.Confirmation.consumed` and
    :meth:`~plotgate.core.initiation.confirmation.Confirmation.seeds`)."""
    alive = rules.window.outlives(ini, k, scan.t) & ~spent
    n = int(seeds.sum())
    new = Initiators(
        plot=ids[seeds],
        scan=np.full(n, k, dtype=np.int64),
        t=np.full(n, scan.t),
        z=scan.z[seeds],
        R=scan.R[seeds],
        sensor=scan.sensor[seeds],
        r=scan.r[seeds],
        az=scan.az[seeds],
        sigma_r=scan.sigma_r[seeds],
        sigma_az=scan.sigma_az[seeds],
        score=np.full(n, rules.confirmation.initiator_score(scan.size)),
    )
    return ini.take(alive).join(new)


# ------------------------------------------------------------------ one scan


def _plot_owners(
    tracks: Tracks, association: _Association, born: Tracks, captured: Pairs, n: int
) -> np.ndarray:
    """Per plot of the scan: the track it updated or started (a confirmed one first, then
    a tentative one, then a new one), -1 for none."""
    hit = association.plot >= 0
    owner = np.full(n, -1, dtype=np.int64)
    tentative, confirmed = hit & ~tracks.confirmed, hit & tracks.confirmed
    owner[association.plot[tentative]] = tracks.id[tentative]
    owner[association.plot[confirmed]] = tracks.id[confirmed]
    unset = owner[captured.plot] < 0
    owner[captured.plot[unset]] = born.id[unset]
    return owner


def _step(state: InitiationState, scan: Scan, rules: Rules) -> tuple[InitiationState, ScanReport]:
    """One scan: the stages in order (the module's docstring)."""
    k, n = state.scans, scan.size
    if n > PLOT_STRIDE:
        raise ParameterError("scans", f"a scan may hold at most {PLOT_STRIDE} plots, got {n}")
    ids = k * PLOT_STRIDE + np.arange(n, dtype=np.int64)
    index = rules.index(scan)
    prediction = _predicted(state.tracks, scan.t, rules.config)
    association = _associate(state.tracks, prediction, scan, index, rules)
    clutter = int(n - association.taken.sum())  # plots no confirmed track took
    gated = Gated(association.shared, scan.z, scan.R, state.tracks.misses, clutter)
    updated = _updated(state.tracks, prediction, association, scan, ids, rules)
    updated = rules.confirmation.mixed(updated, prediction, gated)
    captured = _capture(state.initiators, scan, index, association.taken, k, rules)
    born = _born(state.initiators, captured, scan, ids, k, state.next_track, rules)
    owners = _plot_owners(state.tracks, association, born, captured, n)
    confirmed, newly, checks = _confirm(updated.join(born), k, rules)
    why = _dropped(confirmed, checks, k, rules)
    gone = why < len(DROP_REASONS)
    seeds = rules.confirmation.seeds(ids, owners, confirmed)
    spent = rules.confirmation.consumed(state.initiators, captured, confirmed)
    report = ScanReport(
        scan=k,
        t=scan.t,
        plots=n,
        associated=owners,
        initiators=int(seeds.sum()),
        started=born.id,
        confirmed=confirmed.id[newly],
        dropped=confirmed.id[gone],
        reasons=np.array(DROP_REASONS)[why[gone]],
    )
    live = confirmed.take(~gone)
    return InitiationState(
        version=state.version,
        config_digest=state.config_digest,
        scans=k + 1,
        t=scan.t,
        next_track=state.next_track + born.size,
        initiators=_initiators(state.initiators, spent, scan, ids, seeds, k, rules),
        tracks=live,
        plots=held_plots(state.plots, state.initiators, scan, ids, live),
    ), report


def _check_after_scan(state: InitiationState, i: int, max_tracks: int | None) -> None:
    """After the request's scan i: every track's state and covariance finite, and at most
    ``max_tracks`` live tracks; otherwise ParameterError naming ``scans`` at i."""
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
    rules = select_rules(config)
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
                state, report = _step(state, scan, rules)
        except ParameterError as exc:  # a scan's own problem: say which scan
            if exc.field != "scans" or exc.index is not None:
                raise
            raise ParameterError("scans", exc.reason, i) from exc
        _check_after_scan(state, i, max_tracks)
        reports.append(report)
        last = scan.t
    return state, reports
