"""Starts of the constant-velocity track solve: straight lines through single-shot fixes.

The trajectory solve (:func:`plotgate.core.multistatic.trajectory.trajectory_solve`)
fits x(t) = x0 + v (t - t_ref) to all T P range sums of a track (Fadeev et al., eq. 2,
the accumulated measurement vector). Gauss-Newton needs a start in the right basin:
:func:`track_starts` solves each sample alone (:func:`plotgate.core.multistatic.position.ml_solve`)
and fits information-weighted straight lines through those positions; with two exact
solutions per sample (P = D) it follows both chains of roots.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from plotgate.core.compiled import ARRAY_1D, ARRAY_2D, ARRAY_3D, kernel, record
from plotgate.core.multistatic.closed_form import root_work, sum_range_roots_reference
from plotgate.core.multistatic.gauss_newton import (
    MEASUREMENTS,
    Measurements,
    consistency_threshold,
    gauss_newton_reference,
    information_into,
    iterate,
    measurements,
    position_model,
    work_space,
)
from plotgate.core.multistatic.information import inverse_information, inverse_information_into
from plotgate.core.multistatic.model import range_sum_jacobian_unchecked, vector_norm
from plotgate.core.multistatic.position import closed_form_roots, run_space, sum_range_starts

__all__ = [
    "SAMPLE_FIXES",
    "START_ITERATIONS",
    "START_TOL",
    "SampleFixes",
    "line_terms",
    "sample_fixes",
    "sample_fixes_reference",
    "track_starts",
]

START_ITERATIONS = 8
"""Gauss-Newton iterations of each per-sample solve behind a track's start (a start
only has to lie in the right basin; the track fit then converges in full)."""

START_TOL = 1e-9
"""Convergence tolerance of those per-sample solves (the default of
:func:`plotgate.core.multistatic.position.ml_solve`)."""


def line_terms(
    x: np.ndarray, W: np.ndarray, tau: np.ndarray, use: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's share of the normal equations of a line x_i ~ x0 + tau_i v.

    x (N, T, D) points with information W (N, T, D, D) at times tau (T,); use (N, T)
    marks the samples the line goes through. Returns M (N, T, 2D, 2D) and b (N, T, 2D):
    the line through samples S solves (sum_S M) theta = sum_S b.
    """
    Wm = W * use[..., None, None]
    tw = tau[:, None, None] * Wm
    M = np.concatenate(
        [
            np.concatenate([Wm, tw], axis=-1),
            np.concatenate([tw, tau[:, None, None] * tw], axis=-1),
        ],
        axis=-2,
    )
    b = np.concatenate(
        [np.einsum("ntij,ntj->nti", Wm, x), np.einsum("ntij,ntj->nti", tw, x)], axis=-1
    )
    return M, b


class SampleFixes(NamedTuple):
    """Each sample's fixes, the track start kernel's output (S = N T samples).

    candidates (S, 2, D): the per-sample solve and the closed form's second root (a copy
    of the first where there is none, or P > D); information (S, 2, D, D) of each;
    consistent (S,) the solve passes the chi-square test; mirrored (S,) a second root
    with P = D; lines (N, 2D) the line through each track's fixes (where no sample of
    the track is mirrored).
    """

    candidates: np.ndarray
    information: np.ndarray
    consistent: np.ndarray
    mirrored: np.ndarray
    lines: np.ndarray


SAMPLE_FIXES = record(
    SampleFixes,
    ARRAY_3D,
    numba.float64[:, :, :, ::1],
    numba.boolean[::1],
    numba.boolean[::1],
    ARRAY_2D,
)


@kernel(numba.void(ARRAY_1D, MEASUREMENTS, numba.float64, SAMPLE_FIXES))
def _fixes(
    tau: np.ndarray, samples: Measurements, threshold: float, out: SampleFixes
) -> None:  # pragma: no cover (compiled)
    """Every sample's fix and information, and each plain track's line, in one pass.

    Per sample: the closed form's roots, START_ITERATIONS of Gauss-Newton from the
    primary one, the chi-square test, the information of both candidates; per track
    without mirrored samples, the line fit of :func:`_line_fit` through the consistent
    fixes (all of them when those span fewer than two times). tau (T,) are the sample
    times; samples (N T rows) the samples, each a position.
    """
    ls, w, tx, rx, zeros = samples
    n_t = tau.size
    s_all, p, d = tx.shape
    cand, info, consistent, mirrored, lines = out
    runs, work, roots = run_space(p, d), work_space(p, d), root_work(p, d)
    for s in range(s_all):
        one = Measurements(ls[s], w[s], tx[s], rx[s], zeros)
        second = closed_form_roots(ls[s], tx[s], rx[s], runs, roots)
        theta = cand[s, 0]
        theta[:] = runs.roots[0]
        cost, _, _ = iterate(theta, one, runs.r[0], work, START_ITERATIONS, START_TOL)
        consistent[s] = cost <= threshold
        mirrored[s] = second and p == d
        cand[s, 1] = runs.roots[1] if mirrored[s] else theta
        for c in range(2):
            information_into(cand[s, c], one, work.Hw, info[s, c])
    M = np.empty((2 * d, 2 * d))
    b = np.empty(2 * d)
    cov = np.empty((2 * d, 2 * d))
    scratch = np.empty((2, 2 * d, 2 * d))
    ev = np.empty(2 * d)
    for track in range(lines.shape[0]):
        first, last = track * n_t, (track + 1) * n_t
        if mirrored[first:last].any():
            continue
        lo, hi = np.inf, -np.inf
        for s in range(first, last):
            if consistent[s]:
                lo, hi = min(lo, tau[s - first]), max(hi, tau[s - first])
        spread = hi > lo
        M[:, :] = 0.0
        b[:] = 0.0
        for s in range(first, last):
            if spread and not consistent[s]:
                continue
            t = tau[s - first]
            W, x = info[s, 0], cand[s, 0]
            for i in range(d):
                wx = 0.0
                for j in range(d):
                    M[i, j] += W[i, j]
                    M[i, d + j] += t * W[i, j]
                    M[d + i, j] += t * W[i, j]
                    M[d + i, d + j] += t * (t * W[i, j])
                    wx += W[i, j] * x[j]
                b[i] += wx
                b[d + i] += t * wx
        inverse_information_into(M, cov, scratch[0], ev, scratch[1])
        for i in range(2 * d):
            total = 0.0
            for j in range(2 * d):
                total += cov[i, j] * b[j]
            lines[track, i] = total


def _line_fit(x: np.ndarray, W: np.ndarray, tau: np.ndarray, use: np.ndarray) -> np.ndarray:
    """Information-weighted straight lines x_i ~ x0 + tau_i v, one per track: (N, 2D)."""
    M, b = line_terms(x, W, tau, use)
    theta: np.ndarray = np.einsum("nij,nj->ni", inverse_information(M.sum(axis=1)), b.sum(axis=1))
    return theta


def _chain(cand: np.ndarray, tau: np.ndarray, first: int) -> np.ndarray:
    """Pick one of two candidates (N, T, 2, D) per time-sorted sample by continuity: (N, T)."""
    n, n_t = cand.shape[:2]
    tracks = np.arange(n)
    pick = np.zeros((n, n_t), dtype=int)
    pick[:, 0] = first
    prev = pred = cand[:, 0, first]
    for i in range(1, n_t):  # sequential in the samples, vectorized over the tracks
        pick[:, i] = np.argmin(vector_norm(cand[:, i] - pred[:, None]), axis=1)
        here = cand[tracks, i, pick[:, i]]
        if i + 1 < n_t:
            dt = tau[i] - tau[i - 1]
            rate = (here - prev) / dt if dt > 0.0 else np.zeros_like(here)
            pred = here + rate * (tau[i + 1] - tau[i])
        prev = here
    return pick


def sample_fixes(
    ls: np.ndarray,
    tau: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    alpha: float,
) -> SampleFixes:
    """Each sample's fixes and each plain track's line (:class:`SampleFixes`), compiled.

    ls, sigma (N, T, P), tx, rx (N, T, P, D) checked; tau (T,). The fused kernel of
    :func:`sample_fixes_reference`.
    """
    n, n_t, p, d = tx.shape
    samples = measurements(
        ls.reshape(n * n_t, p),
        sigma.reshape(n * n_t, p),
        tx.reshape(n * n_t, p, d),
        rx.reshape(n * n_t, p, d),
        np.zeros(p),  # each sample is a position
    )
    fixes = SampleFixes(
        np.empty((n * n_t, 2, d)),
        np.empty((n * n_t, 2, d, d)),
        np.empty(n * n_t, dtype=bool),
        np.empty(n * n_t, dtype=bool),
        np.empty((n, 2 * d)),
    )
    _fixes(
        np.ascontiguousarray(tau, dtype=float), samples, consistency_threshold(alpha, p - d), fixes
    )
    return fixes


def sample_fixes_reference(
    ls: np.ndarray,
    tau: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    alpha: float,
) -> SampleFixes:
    """:func:`sample_fixes` in numpy, the reference of its kernel: batched passes.

    The closed form (:func:`plotgate.core.multistatic.closed_form.sum_range_roots_reference`),
    Gauss-Newton (:func:`plotgate.core.multistatic.gauss_newton.gauss_newton_reference`),
    the information of each candidate and :func:`_line_fit` (every track's line).
    """
    n, n_t, p, d = tx.shape
    flat_l, flat_tx, flat_rx, flat_sigma = (
        a.reshape((n * n_t, *a.shape[2:])) for a in (ls, tx, rx, sigma)
    )
    start, alternative, has_alternative = sum_range_starts(
        flat_l, flat_tx, flat_rx, sum_range_roots_reference
    )
    fit = gauss_newton_reference(
        *position_model(flat_tx, flat_rx, np.arange(n * n_t)),
        flat_l,
        flat_sigma,
        start,
        START_ITERATIONS,
        START_TOL,
    )
    consistent = fit.cost <= consistency_threshold(alpha, p - d)
    has_alternative &= p == d
    cand = np.stack([fit.theta, np.where(has_alternative[:, None], alternative, fit.theta)], 1)
    H = (
        range_sum_jacobian_unchecked(cand, flat_tx[:, None], flat_rx[:, None])
        / flat_sigma[:, None, :, None]
    )
    W = np.einsum("scpi,scpj->scij", H, H)  # information of each candidate
    good = consistent.reshape(n, n_t)
    spread = np.where(good, tau, -np.inf).max(axis=1) > np.where(good, tau, np.inf).min(axis=1)
    good |= ~spread[:, None]
    lines = _line_fit(cand[:, 0].reshape(n, n_t, d), W[:, 0].reshape(n, n_t, d, d), tau, good)
    return SampleFixes(cand, W, consistent, has_alternative, lines)


def track_starts(
    ls: np.ndarray,
    tau: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    alpha: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(x0, v) starts of N tracks: (starts (S, 2D), the track of each start (S,)).

    ls, sigma (N, T, P), tx, rx (N, T, P, D), checked. Each sample is solved as
    :func:`plotgate.core.multistatic.position.ml_solve` with
    ``closed_form_starts=False`` would, from the closed form's primary root (the
    compiled engine on the checked samples). With P = D the closed form's second root is
    an exact second solution, and the true and mirror tracks may cross. Two chains are
    then followed through the samples, starting from either root of the first sample and
    taking at each sample the root nearer the straight-line extrapolation of the chain;
    each chain seeds a line fit, refined three times by keeping at each sample the root
    nearer the line (Mahalanobis). The per-sample solves stop after START_ITERATIONS;
    samples whose fit fails the chi-square test are left out of the line fits when at
    least two distinct times remain.
    """
    n, n_t, p, d = tx.shape
    fixes = sample_fixes(ls, tau, tx, rx, sigma, alpha)
    has_alternative = fixes.mirrored.reshape(n, n_t)
    mirrored = np.flatnonzero(has_alternative.any(axis=1))
    if mirrored.size == 0:  # one root per sample (P > D): a single line each
        return fixes.lines, np.arange(n)
    cand = fixes.candidates.reshape(n, n_t, 2, d)
    W = fixes.information.reshape(n, n_t, 2, d, d)
    consistent = fixes.consistent
    good = consistent.reshape(n, n_t)
    spread = np.where(good, tau, -np.inf).max(axis=1) > np.where(good, tau, np.inf).min(axis=1)
    good |= ~spread[:, None]
    tracks, times = np.arange(n)[:, None], np.arange(n_t)
    order = np.argsort(tau, kind="stable")
    starts, owners = [], []
    for first, rows in ((0, np.arange(n)), (1, mirrored)):
        if rows.size == 0:
            continue
        c, w, use, alt = cand[rows], W[rows], good[rows], has_alternative[rows]
        pick = np.empty((rows.size, n_t), dtype=int)
        pick[:, order] = _chain(c[:, order], tau[order], first)
        for _ in range(3):
            i = tracks[: rows.size]
            theta = _line_fit(c[i, times, pick], w[i, times, pick], tau, use)
            e = c - (theta[:, None, :d] + tau[:, None] * theta[:, None, d:])[:, :, None]
            dist = np.einsum("ntci,ntcij,ntcj->ntc", e, w, e)
            pick = np.where(alt, np.argmin(dist, axis=2), 0)
        i = tracks[: rows.size]
        starts.append(_line_fit(c[i, times, pick], w[i, times, pick], tau, use))
        owners.append(rows)
    return np.concatenate(starts), np.concatenate(owners)
