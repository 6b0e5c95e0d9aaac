"""Monte Carlo accuracy study of the multistatic solvers (Fadeev et al., Fig. 3, curves 1-6).

Fadeev et al. judge their solvers along a target's track by six curves of the position error
against the target's position: 1, the single-shot CRLB; 2, the CRLB accumulated over the
samples so far; 3, the ML trajectory (constant-velocity fit to the samples so far); 4,
the ML single shot; 5, the sum-range closed form; 6, the difference-range closed form.
:func:`accuracy_study` computes all six for any single-transmitter geometry with
moving platforms, with the diagnostics that say whether a solver is efficient:

* ``linearised``: the RMSE of the linearised efficient estimator J^-1 H^T G n on the
  *same* noise n (its expected RMSE is exactly the CRLB), so RMSE / RMSE_linearised
  cancels most of the Monte Carlo noise of RMSE / CRLB; ``linearised_track`` likewise
  for curve 3;
* ``max_distance``: the largest Mahalanobis distance sqrt(e^T J e) of an ML single-shot
  error by the Fisher information J at the truth (a solution 10 CRLB away has 10);
* false minima: an ML single-shot solution more than one standard deviation
  (Mahalanobis) from the minimum that Gauss-Newton reaches from the truth, with a
  higher cost; each should fail the chi-square test (``false_unflagged`` counts those
  that do not);
* ``full_track``: the trajectory fitted to all T samples, evaluated at every sample
  time, against its own bound ``full_track_crlb``.

Every solver runs batched over the runs; the noise is the same for every method. The
noise is drawn once, in the caller, from one generator as it always was (so a seed gives
the numbers it always gave), and the solves are cut into chunks of
:data:`STUDY_CHUNK_RUNS` runs, each handed its slice of the noisy range sums
(:func:`solve_runs`): every solver treats each run alone, so the chunks may run anywhere
(a Dask cluster's workers) and the answer is the same bit for bit. What the chunks return
is per run; every mean over the runs is taken here, over all of them at once.
Curve 3 takes one batched :func:`plotgate.core.multistatic.trajectory.trajectory_solve` per prefix
0..i, started from the information-weighted line through the consistent single-shot
positions of that prefix (what ``trajectory_solve`` starts from itself, computed here
once for all prefixes with cumulative sums).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.chunks import Mapper, mapped, spans
from plotgate.core.errors import ParameterError
from plotgate.core.multistatic.closed_form import difference_range_solve, sum_range_solve
from plotgate.core.multistatic.crlb import CRLB, crlb, difference_crlb
from plotgate.core.multistatic.information import inverse_information, position_covariance
from plotgate.core.multistatic.model import (
    BASELINE_SIGMAS,
    range_sum_jacobian,
    range_sums,
    validate_track,
    with_tx_axis,
)
from plotgate.core.multistatic.noise import range_sum_noise
from plotgate.core.multistatic.position import ml_solve
from plotgate.core.multistatic.track_start import line_terms
from plotgate.core.multistatic.trajectory import trajectory_solve
from plotgate.core.validation import as_array, require_positive

__all__ = [
    "CURVES",
    "NOISE_WINDOW",
    "STUDY_CHUNK_RUNS",
    "AccuracyStudy",
    "RunSolves",
    "StudyChunk",
    "accuracy_study",
    "solve_runs",
]

CURVES = ("ml_track", "ml_single", "sum_range", "difference_range")
"""The solver curves of Fadeev et al., Fig. 3: 3, 4, 5 and 6."""

NOISE_WINDOW = 50
"""Samples per window of the eq. 5 noise estimate (a quadratic fits a range-sum series
over a few seconds, not over a whole baseline crossing)."""

STUDY_CHUNK_RUNS = 100
"""Runs per chunk of a study: fixed, whatever the number of workers. At the documented
study's 200 samples a chunk is a few seconds of solves, and its 200 batched trajectory
solves of 100 runs each still amortise numpy's per-call cost."""


@dataclass(frozen=True)
class AccuracyStudy:
    """Per-sample results of :func:`accuracy_study` (T samples, D coordinates).

    Attributes
    ----------
    t : (T,) ndarray
        Sample times, s.
    x : (T, D) ndarray
        True target positions, m.
    crlb, crlb_accumulated, crlb_difference : (T, D) ndarray
        Per-axis bounds, m: single shot (curve 1), accumulated over samples 0..i
        (curve 2; the single-shot bound at i = 0), and for the range differences.
    rmse : dict of str to (T, D) ndarray
        Per-axis RMSE over the runs, m, of each of :data:`CURVES` and of
        ``linearised`` and ``linearised_track``; the track curves are NaN at i = 0
        and everywhere when ``tracks`` is False.
    rmse_se : (T,) ndarray
        Relative Monte Carlo standard error of the ML single-shot total RMSE.
    full_track, full_track_crlb : (T, D) ndarray
        RMSE of the all-samples trajectory at each sample time, and its bound (NaN
        without tracks).
    max_distance, max_track_distance : (T,) ndarray
        Largest Mahalanobis error of the ML single shot and of the ML track.
    gradient : (T, P) ndarray
        |dl_p/dx| of each pair at the truth; near 0 where the target crosses that
        pair's baseline.
    inconsistent, not_converged, false_minima, false_unflagged : (T,) ndarray of int
        ML single-shot runs failing the chi-square test, not converged, at a false
        minimum, and at a false minimum yet passing the test.
    track_inconsistent, track_not_converged : (T,) ndarray of int
        The same for the ML tracks (0 at i = 0 and without tracks).
    sum_range_unsolvable, difference_range_unsolvable : (T,) ndarray of int
        Closed-form runs with no consistent root.
    noise_sigma : tuple of float
        Mean and standard deviation over the runs and pairs of the Fadeev et al., eq. 5 noise
        estimate of each range-sum series (variances pooled over consecutive windows of
        NOISE_WINDOW samples).
    runs, seed : int
        The Monte Carlo size and seed.
    """

    t: np.ndarray
    x: np.ndarray
    crlb: np.ndarray
    crlb_accumulated: np.ndarray
    crlb_difference: np.ndarray
    rmse: dict[str, np.ndarray]
    rmse_se: np.ndarray
    full_track: np.ndarray
    full_track_crlb: np.ndarray
    max_distance: np.ndarray
    max_track_distance: np.ndarray
    gradient: np.ndarray
    inconsistent: np.ndarray
    not_converged: np.ndarray
    false_minima: np.ndarray
    false_unflagged: np.ndarray
    track_inconsistent: np.ndarray
    track_not_converged: np.ndarray
    sum_range_unsolvable: np.ndarray
    difference_range_unsolvable: np.ndarray
    noise_sigma: tuple[float, float]
    runs: int
    seed: int


def _rmse(e: np.ndarray) -> np.ndarray:
    """(runs, T, D) errors -> (T, D) per-axis RMSE."""
    rmse: np.ndarray = np.sqrt(np.mean(e * e, axis=0))
    return rmse


def _mahalanobis(e: np.ndarray, J: np.ndarray) -> np.ndarray:
    distance: np.ndarray = np.sqrt(np.maximum(np.einsum("...i,...ij,...j->...", e, J, e), 0.0))
    return distance


def _count(mask: np.ndarray) -> np.ndarray:
    count: np.ndarray = mask.sum(axis=0).astype(int)
    return count


def _prefix_lines(x: np.ndarray, W: np.ndarray, tau: np.ndarray, good: np.ndarray) -> np.ndarray:
    """(runs, T, 2D): for each prefix 0..i the information-weighted line x0 + tau v through
    the positions x (runs, T, D) with information W (runs, T, D, D), using the ``good``
    samples when at least two of them are in the prefix and all samples otherwise."""

    def sums(use: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        M, b = line_terms(x, W, tau, use)
        return np.cumsum(M, axis=1), np.cumsum(b, axis=1)

    M_good, b_good = sums(good.astype(float))
    M_all, b_all = sums(np.ones(good.shape))
    enough = np.cumsum(good, axis=1) >= 2
    M = np.where(enough[..., None, None], M_good, M_all)
    b = np.where(enough[..., None], b_good, b_all)
    lines: np.ndarray = np.einsum("rtij,rtj->rti", inverse_information(M), b)
    return lines


@dataclass(frozen=True)
class StudyChunk:
    """What one chunk of runs needs: its noisy range sums and the scenario.

    Attributes
    ----------
    L : (R, T, P) ndarray
        The chunk's R runs of range sums, truth plus noise, m.
    t : (T,) ndarray
    tx, rx : (T, P, D) ndarray
        The transmitter and the receivers per sample and pair, m.
    x : (T, D) ndarray
        True target positions, m.
    sigma, alpha : float
    tracks : bool
    """

    L: np.ndarray
    t: np.ndarray
    tx: np.ndarray
    rx: np.ndarray
    x: np.ndarray
    sigma: float
    alpha: float
    tracks: bool


@dataclass(frozen=True)
class RunSolves:
    """Every solver's answer for each run of a chunk (R runs, T samples, D coordinates).

    Attributes
    ----------
    single, reference : (R, T, D) ndarray
        ML single shot from the closed-form starts, and from the truth.
    cost, reference_cost : (R, T) ndarray
    consistent, converged : (R, T) ndarray of bool
        The ML single shot's chi-square test and convergence.
    sum_range, difference_range : (R, T, D) ndarray
    sum_range_ok, difference_range_ok : (R, T) ndarray of bool
        Whether each closed form had a consistent root.
    state : (R, T, 2D) ndarray
        The ML track (x0, v) fitted to samples 0..i (NaN at i = 0, and without tracks).
    track_ok : (2, R, T) ndarray of bool
        The tracks' chi-square test and convergence (True where not fitted).
    """

    single: np.ndarray
    reference: np.ndarray
    cost: np.ndarray
    reference_cost: np.ndarray
    consistent: np.ndarray
    converged: np.ndarray
    sum_range: np.ndarray
    difference_range: np.ndarray
    sum_range_ok: np.ndarray
    difference_range_ok: np.ndarray
    state: np.ndarray
    track_ok: np.ndarray

    @classmethod
    def joined(cls, parts: list[RunSolves]) -> RunSolves:
        """The chunks' answers as one, runs in order (``track_ok`` on its runs axis, 1)."""
        runs_axis = {name: int(name == "track_ok") for name in cls.__dataclass_fields__}
        return cls(
            **{
                name: np.concatenate([getattr(p, name) for p in parts], axis=axis)
                for name, axis in runs_axis.items()
            }
        )


def solve_runs(chunk: StudyChunk) -> RunSolves:
    """Curves 3-6 and the reference minimum for the runs of one chunk.

    Each solver is batched over the chunk's runs and samples and treats every problem
    alone, so the answer for a run does not depend on which chunk carried it.
    """
    L, x, sigma, alpha = chunk.L, chunk.x, chunk.sigma, chunk.alpha
    runs, n_t, p = L.shape
    d = x.shape[-1]
    flat = L.reshape(-1, p)
    ftx = np.broadcast_to(chunk.tx, (runs, n_t, p, d)).reshape(-1, p, d)
    frx = np.broadcast_to(chunk.rx, (runs, n_t, p, d)).reshape(-1, p, d)

    # curves 4-6 and the reference minimum (Gauss-Newton from the truth)
    ml = ml_solve(flat, ftx, frx, sigma, alpha=alpha)
    truth = np.broadcast_to(x, (runs, n_t, d)).reshape(-1, d)
    ref = ml_solve(flat, ftx, frx, sigma, x0=truth, alpha=alpha, closed_form_starts=False)
    single = ml.x.reshape(runs, n_t, d)
    closed = [
        solver(flat, ftx, frx, baseline_tol=BASELINE_SIGMAS * sigma)
        for solver in (sum_range_solve, difference_range_solve)
    ]
    consistent = ml.consistent.reshape(runs, n_t)
    state, track_ok = _tracks(chunk, single, consistent)
    return RunSolves(
        single=single,
        reference=ref.x.reshape(runs, n_t, d),
        cost=ml.cost.reshape(runs, n_t),
        reference_cost=ref.cost.reshape(runs, n_t),
        consistent=consistent,
        converged=ml.converged.reshape(runs, n_t),
        sum_range=closed[0].x.reshape(runs, n_t, d),
        difference_range=closed[1].x.reshape(runs, n_t, d),
        sum_range_ok=closed[0].solvable.reshape(runs, n_t),
        difference_range_ok=closed[1].solvable.reshape(runs, n_t),
        state=state,
        track_ok=track_ok,
    )


def _tracks(
    chunk: StudyChunk, single: np.ndarray, consistent: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Curve 3: a batched trajectory solve per prefix 0..i of the chunk's runs, each
    started from the information-weighted line through its consistent single shots."""
    L, t, sigma = chunk.L, chunk.t, chunk.sigma
    runs, n_t, _ = L.shape
    d = single.shape[-1]
    state = np.full((runs, n_t, 2 * d), np.nan)
    track_ok = np.ones((2, runs, n_t), dtype=bool)  # consistent, converged
    if not chunk.tracks:
        return state, track_ok
    tau = t - t[0]
    Hx = range_sum_jacobian(single, chunk.tx, chunk.rx) / sigma  # at each run's position
    W = np.einsum("rtpi,rtpj->rtij", Hx, Hx)
    starts = _prefix_lines(single, W, tau, consistent)
    for i in range(1, n_t):
        fit = trajectory_solve(
            L[:, : i + 1],
            t[: i + 1],
            chunk.tx[: i + 1],
            chunk.rx[: i + 1],
            sigma,
            x0=starts[:, i],
            alpha=chunk.alpha,
        )
        state[:, i] = fit.state
        track_ok[:, :, i] = fit.consistent, fit.converged
    return state, track_ok


def _checked(
    x0: ArrayLike, v: ArrayLike, t: ArrayLike, runs: int, seed: int, sigma: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The study's inputs checked: x0, v, t as :func:`validate_track` gives them, T >= 2
    increasing times, runs >= 2, seed >= 0 and sigma > 0 (m)."""
    x0, v, t = validate_track(x0, v, t)
    if t.size < 2 or not np.all(np.diff(t) > 0.0):
        raise ParameterError("t", f"must be strictly increasing with T >= 2, got {t}")
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 2:
        raise ParameterError("runs", f"must be an integer >= 2, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError("seed", f"must be an integer >= 0, got {seed!r}")
    sigma = float(as_array("sigma", sigma))
    require_positive("sigma", sigma)
    return x0, v, t, sigma


class _Linearised(NamedTuple):
    """The linearised estimators' errors (curves 2 and 4) and the accumulated bound."""

    single: np.ndarray
    """(runs, T, D) errors of the linearised single-shot estimator, m."""
    track: np.ndarray
    """(runs, T, D) errors of the linearised track estimator on every prefix 0..i, m."""
    cov: np.ndarray
    """(T, 2D, 2D) inverse information of [position at t0, velocity] on each prefix."""
    A_cov: np.ndarray
    """(T, D, D) the position bound at t_i on the prefix 0..i, m^2."""
    accumulated: np.ndarray
    """(T, D) its sigmas (the single-shot bound at t0), m."""


def _linearised(
    Hw: np.ndarray, b1: CRLB, tau: np.ndarray, white: np.ndarray, tracks: bool
) -> _Linearised:
    """The linearised single-shot and track estimators on the runs' whitened noise
    ``white`` (runs, T, P), with the whitened Jacobians Hw (T, P, D): the accumulated bound
    and linearised track estimator for every prefix 0..i of the samples (NaN at the first
    sample, which holds no track, and everywhere without ``tracks``)."""
    d = Hw.shape[-1]
    single = np.einsum("tij,tpj,rtp->rti", b1.covariance, Hw, white)
    Hs = np.concatenate([Hw, tau[:, None, None] * Hw], axis=-1)  # (T, P, 2D)
    J = np.cumsum(np.einsum("tpi,tpj->tij", Hs, Hs), axis=0)
    cov = inverse_information(J)
    P_xv, tau3 = cov[:, :d, d:], tau[:, None, None]  # position bound at t_i, prefix 0..i
    A_cov = cov[:, :d, :d] + tau3 * (P_xv + np.swapaxes(P_xv, 1, 2)) + tau3 * tau3 * cov[:, d:, d:]
    acc = np.sqrt(np.diagonal(A_cov, axis1=-2, axis2=-1)).copy()
    acc[0] = b1.sigma[0]
    theta = np.einsum("tij,rtj->rti", cov, np.cumsum(np.einsum("tpi,rtp->rti", Hs, white), axis=1))
    track = theta[..., :d] + tau[:, None] * theta[..., d:]
    track[:, 0] = np.nan
    if not tracks:
        track[:] = np.nan
    return _Linearised(single, track, cov, A_cov, acc)


class _TrackCurves(NamedTuple):
    """Curve 3 and the full track: errors, RMSE, bound and largest distance."""

    ml_track: np.ndarray
    """(runs, T, D) errors of the ML track on every prefix 0..i, at t_i, m."""
    full_track: np.ndarray
    """(T, D) RMSE of the track of all T samples, at each t_i, m (NaN without tracks)."""
    full_crlb: np.ndarray
    """(T, D) its bound, m (NaN without tracks)."""
    distance: np.ndarray
    """(T,) the ML track's largest Mahalanobis distance from the truth (NaN at t0 and
    without tracks)."""


def _track_curves(
    solved: RunSolves, x: np.ndarray, tau: np.ndarray, line: _Linearised, tracks: bool
) -> _TrackCurves:
    """Curve 3 (the track solved per chunk on every prefix) and the full track, against
    the accumulated bound of :func:`_linearised`."""
    n_t, d = x.shape
    state = solved.state
    full_track = full_crlb = np.full((n_t, d), np.nan)
    if tracks:
        full = state[:, -1]
        full_track = _rmse(full[:, None, :d] + tau[:, None] * full[:, None, d:] - x)
        full_crlb = np.sqrt(
            np.diagonal(position_covariance(line.cov[-1], tau), axis1=-2, axis2=-1)
        )
    ml_track = state[..., :d] + tau[:, None] * state[..., d:] - x
    J_track = np.linalg.inv(line.A_cov[1:])
    distance = np.full(n_t, np.nan)
    if tracks:
        distance[1:] = _mahalanobis(ml_track[:, 1:], J_track).max(axis=0)
    return _TrackCurves(ml_track, full_track, full_crlb, distance)


def _tallies(solved: RunSolves, J1: np.ndarray) -> dict[str, np.ndarray]:
    """Per sample, the runs flagged: inconsistent (the chi-square test), not converged,
    false minima (a solution more than one CRLB from the best start's that costs more),
    false minima the test did not flag, the track's two flags, and the closed forms'
    unsolvable runs."""
    false_min = (_mahalanobis(solved.single - solved.reference, J1) > 1.0) & (
        solved.cost > solved.reference_cost + 1e-9
    )
    inconsistent = ~solved.consistent
    return {
        "inconsistent": _count(inconsistent),
        "not_converged": _count(~solved.converged),
        "false_minima": _count(false_min),
        "false_unflagged": _count(false_min & ~inconsistent),
        "track_inconsistent": _count(~solved.track_ok[0]),
        "track_not_converged": _count(~solved.track_ok[1]),
        "sum_range_unsolvable": _count(~solved.sum_range_ok),
        "difference_range_unsolvable": _count(~solved.difference_range_ok),
    }


def _noise_estimate(t: np.ndarray, L: np.ndarray) -> np.ndarray:
    """The range-sum noise sigma estimated from the measured sums L (runs, T, P), window by
    window of :data:`NOISE_WINDOW` samples (:func:`range_sum_noise`), m."""
    n_t = t.size
    series = np.moveaxis(L, 0, 1).reshape(n_t, -1)  # (T, runs P)
    w = min(NOISE_WINDOW, n_t)
    est: np.ndarray = np.sqrt(
        np.mean(
            [
                range_sum_noise(t[i : i + w], series[i : i + w]).variance
                for i in range(0, n_t - w + 1, w)
            ],
            axis=0,
        )
    )
    return est


def accuracy_study(
    t: ArrayLike,
    tx: ArrayLike,
    rx: ArrayLike,
    x0: ArrayLike,
    v: ArrayLike,
    sigma: float,
    runs: int,
    seed: int,
    alpha: float = 0.01,
    tracks: bool = True,
    mapper: Mapper | None = None,
) -> AccuracyStudy:
    """Fadeev et al., Fig. 3 (curves 1-6) by Monte Carlo for one transmitter and its receivers.

    Parameters
    ----------
    t : (T,) array_like
        Sample times, s, strictly increasing, T >= 2.
    tx : (D,), (P, D) or (T, P, D) array_like
        The transmitter (one point for every pair), fixed or per sample, m.
    rx : (P, D) or (T, P, D) array_like
        Receivers, fixed or per sample (e.g. from
        :func:`plotgate.core.multistatic.model.platform_positions`), m; P >= D + 1.
    x0, v : (D,) array_like
        Target position at t[0] (m) and constant velocity (m/s).
    sigma : float
        Range-sum noise standard deviation, m, > 0.
    runs : int
        Monte Carlo runs, >= 2.
    seed : int
        Seed of the noise: ``sigma * numpy.random.default_rng(seed).standard_normal((runs,
        T, P))`` is added to the true range sums, >= 0.
    alpha : float, optional
        False-alarm probability of the chi-square consistency tests. Default 0.01.
    tracks : bool, optional
        Compute curve 3 and the full track (T batched trajectory solves, most of the
        cost). Default True.
    mapper : Mapper, optional
        How the chunks of :data:`STUDY_CHUNK_RUNS` runs are solved: a ``map`` (default the
        builtin, in this process; a cluster's to spread them). The result is the same bit
        for bit.

    Returns
    -------
    study : AccuracyStudy

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        On bad inputs, as the solvers word them (a target passing through a platform
        is refused by the bound), and ParameterError for t not increasing, runs < 2,
        seed < 0, or x0, v not (D,).

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, Fig. 3: curves 1-6
       along the track of a target crossing the baselines of a multistatic system of
       moving platforms.

    Examples
    --------
    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> s = accuracy_study(np.arange(5.0), [0.0, 0.0], rx, [3000.0, 4000.0], [0.0, 80.0],
    ...                    sigma=0.5, runs=200, seed=1)
    >>> bool(np.all(np.abs(s.rmse["ml_single"] / s.crlb - 1.0) < 0.25))
    True
    """
    x0, v, t, sigma = _checked(x0, v, t, runs, seed, sigma)
    n_t, d = t.size, x0.size
    tau = t - t[0]
    x = x0 + tau[:, None] * v
    b1 = crlb(x, tx, rx, sigma)  # checks the geometry
    bd = difference_crlb(x, tx, rx, sigma)
    clean = range_sums(x, tx, rx)
    p = clean.shape[-1]
    txb = np.broadcast_to(np.asarray(with_tx_axis(tx), dtype=float), (n_t, p, d))
    rxb = np.broadcast_to(np.asarray(rx, dtype=float), (n_t, p, d))
    noise = sigma * np.random.default_rng(seed).standard_normal((runs, n_t, p))
    L = clean + noise

    chunks = [
        StudyChunk(L[a:b], t, txb, rxb, x, sigma, alpha, tracks)
        for a, b in spans(runs, STUDY_CHUNK_RUNS)
    ]
    solved = RunSolves.joined(mapped(mapper, solve_runs, chunks))
    single = solved.single
    e = {
        "ml_single": single - x,
        "sum_range": solved.sum_range - x,
        "difference_range": solved.difference_range - x,
    }

    H = range_sum_jacobian(x, txb, rxb)  # (T, P, D)
    line = _linearised(H / sigma, b1, tau, noise / sigma, tracks)
    e["linearised"], e["linearised_track"] = line.single, line.track

    curves = _track_curves(solved, x, tau, line, tracks)
    e["ml_track"] = curves.ml_track
    J1 = b1.information
    sq = np.sum(e["ml_single"] ** 2, axis=-1)
    est = _noise_estimate(t, L)
    return AccuracyStudy(
        t=t,
        x=x,
        crlb=b1.sigma,
        crlb_accumulated=line.accumulated,
        crlb_difference=bd.sigma,
        rmse={k: _rmse(v) for k, v in e.items()},
        rmse_se=sq.std(axis=0, ddof=1) / (2.0 * np.sqrt(runs) * sq.mean(axis=0)),
        full_track=curves.full_track,
        full_track_crlb=curves.full_crlb,
        max_distance=_mahalanobis(e["ml_single"], J1).max(axis=0),
        max_track_distance=curves.distance,
        gradient=np.linalg.norm(H, axis=-1),
        **_tallies(solved, J1),
        noise_sigma=(float(est.mean()), float(est.std())),
        runs=int(runs),
        seed=int(seed),
    )
