"""Starts of the constant-velocity track solve: straight lines through single-shot fixes.

The trajectory solve (:func:`plotgate.core.multistatic.trajectory.trajectory_solve`)
fits x(t) = x0 + v (t - t_ref) to all T P range sums of a track (Fadeev et al., eq. 2,
the accumulated measurement vector). Gauss-Newton needs a start in the right basin:
:func:`track_starts` solves each sample alone (:func:`plotgate.core.multistatic.position.ml_solve`)
and fits information-weighted straight lines through those positions; with two exact
solutions per sample (P = D) it follows both chains of roots.
"""

from __future__ import annotations

import numpy as np

from plotgate.core.multistatic.gauss_newton import consistency_threshold, range_sum_gauss_newton
from plotgate.core.multistatic.information import inverse_information
from plotgate.core.multistatic.model import range_sum_jacobian_unchecked, vector_norm
from plotgate.core.multistatic.position import sum_range_starts

__all__ = ["START_ITERATIONS", "START_TOL", "line_terms", "track_starts"]

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
    flat_l, flat_tx, flat_rx, flat_sigma = (
        a.reshape((n * n_t, *a.shape[2:])) for a in (ls, tx, rx, sigma)
    )
    start, alternative, has_alternative = sum_range_starts(flat_l, flat_tx, flat_rx)
    fit = range_sum_gauss_newton(
        flat_l,
        flat_sigma,
        flat_tx,
        flat_rx,
        np.zeros(p),
        np.arange(n * n_t),
        start,
        START_ITERATIONS,
        START_TOL,
    )
    # ml_solve(..., x0=start, closed_form_starts=False) on the checked samples
    sol_x, consistent = fit.theta, fit.cost <= consistency_threshold(alpha, p - d)
    has_alternative &= p == d
    cand = np.stack([sol_x, np.where(has_alternative[:, None], alternative, sol_x)], axis=1)
    cand = cand.reshape(n, n_t, 2, d)
    has_alternative = has_alternative.reshape(n, n_t)
    H = (
        range_sum_jacobian_unchecked(cand, tx[:, :, None], rx[:, :, None])
        / sigma[:, :, None, :, None]
    )
    W = np.einsum("ntcpi,ntcpj->ntcij", H, H)  # information of each candidate
    good = consistent.reshape(n, n_t)
    spread = np.where(good, tau, -np.inf).max(axis=1) > np.where(good, tau, np.inf).min(axis=1)
    good |= ~spread[:, None]
    tracks, samples = np.arange(n)[:, None], np.arange(n_t)
    order = np.argsort(tau, kind="stable")
    mirrored = np.flatnonzero(has_alternative.any(axis=1))
    if mirrored.size == 0:  # one root per sample (P > D): a single line each
        return _line_fit(cand[:, :, 0], W[:, :, 0], tau, good), np.arange(n)
    starts, owners = [], []
    for first, rows in ((0, np.arange(n)), (1, mirrored)):
        if rows.size == 0:
            continue
        c, w, use, alt = cand[rows], W[rows], good[rows], has_alternative[rows]
        pick = np.empty((rows.size, n_t), dtype=int)
        pick[:, order] = _chain(c[:, order], tau[order], first)
        for _ in range(3):
            i = tracks[: rows.size]
            theta = _line_fit(c[i, samples, pick], w[i, samples, pick], tau, use)
            e = c - (theta[:, None, :d] + tau[:, None] * theta[:, None, d:])[:, :, None]
            dist = np.einsum("ntci,ntcij,ntcj->ntc", e, w, e)
            pick = np.where(alt, np.argmin(dist, axis=2), 0)
        i = tracks[: rows.size]
        starts.append(_line_fit(c[i, samples, pick], w[i, samples, pick], tau, use))
        owners.append(rows)
    return np.concatenate(starts), np.concatenate(owners)
