"""Maximum-likelihood multistatic position and track solves (seed 001, eqs. 4 and 6).

Seed 001 (R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov) estimates the target
position from range sums l_p = |x - rx_p| + |x - tx_p| by maximum likelihood,

.. math:: \\hat{\\mathbf{x}} = \\arg\\min_{\\mathbf{x}} L(\\mathbf{x}), \\quad
          L(\\mathbf{x}) = [\\mathbf{l} - \\mathbf{h}(\\mathbf{x})]^T \\mathbf{G}
          [\\mathbf{l} - \\mathbf{h}(\\mathbf{x})], \\quad
          \\mathbf{G} = \\mathrm{diag}(1/\\sigma_p^2)

(eq. 4), iterating Gauss-Newton (eq. 6)

.. math:: \\mathbf{x}^{(i+1)} = \\mathbf{x}^{(i)} + k\\,(\\mathbf{H}^T\\mathbf{G}
          \\mathbf{H})^{-1}\\mathbf{H}^T\\mathbf{G}[\\mathbf{l} - \\mathbf{h}(\\mathbf{x}^{(i)})].

The same solver fits a constant-velocity track to T samples (the paper's accumulated
measurement vector, eq. 2): parameters (x0, v) with x(t) = x0 + v (t - t_ref).

Step control (the paper's k; not specified there)
-------------------------------------------------
Each iteration takes the Gauss-Newton step with k = 1, 1/2, 1/4, ... (HALVINGS tries)
and keeps the first that lowers the cost L. When no halving does (a step spoiled by a
nearly singular H^T G H, e.g. near a baseline crossing), the problem takes a
Levenberg-Marquardt step instead, (H^T G H + mu I) dx = H^T G r in the column-scaled
parameters, with the smallest damping mu (tried in decades from the last one that
worked) that lowers the cost. A problem has converged when its Gauss-Newton step is
below ``tol (1 + |x|)`` or would lower the cost by less than 1e-14 (1 + L) (a step in
a direction the data hardly determine, such as across a baseline); or when no damped
step lowers its cost any more (rounding) and the Gauss-Newton step promised less than
1e-6 (1 + L) there. Problems are iterated together with per-problem masks; only the
iterations loop in Python.

Start and alternatives
----------------------
By default the start is the sum-range closed form
(:func:`plotgate.core.multistatic.closed_form.sum_range_solve`); with several transmitters,
that of the first transmitter's pairs (problems whose first transmitter has fewer than
D pairs start at the centroid of their platforms). When the closed form has a second
root, Gauss-Newton runs from both; the lower cost wins, and the other becomes the
``alternative`` when it converged, passes the chi-square test and lies more than one
standard deviation (Mahalanobis, by the winner's covariance) from the winner.

A user start ``x0`` is a third start, not a replacement: Gauss-Newton runs from x0 and
from the closed-form roots above, and the lowest cost wins (x0's minimum on a tie, so
with P = D, where both roots fit exactly, x0 picks the root). A start alone is a trap:
at a baseline crossing, a start 500 m off lands at the transmitter's cone point (a false
minimum that fails the chi-square test) more often than not, while the closed form's
roots reach the truth. The ``alternative`` is then the lowest-cost other minimum
(x0's or a root's) that converged, passes the chi-square test and lies more than one
standard deviation from the winner; an inconsistent one (the trapped start) is never
reported. ``closed_form_starts=False`` runs from x0 alone (a local refinement, e.g.
of a point that already is a closed-form root) and searches no alternative.

Consistency
-----------
The cost at the minimum is chi-square with P - D degrees of freedom when the model
holds. ``consistent = cost <= chi2.ppf(1 - alpha, P - D)`` flags a false local
minimum (the solver trapped on the wrong side of a baseline, or a mirror solution)
that does not fit the data. With P = D every solution fits exactly and the test has
nothing to test: consistent is True (as are all P <= D).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from plotgate.core.errors import ParameterError
from plotgate.core.multistatic.closed_form import sum_range_solve
from plotgate.core.multistatic.crlb import (
    _inverse_information,
    _position_covariance,
    _symmetric_eigh,
)
from plotgate.core.multistatic.model import (
    BASELINE_SIGMAS,
    COINCIDENT_RTOL,
    _norm,
    _range_sum_jacobian,
    _range_sums,
    _scale,
    _shape,
    _with_tx_axis,
    validate_problem,
)
from plotgate.core.validation import as_array, as_probability, as_scalar, require_positive

__all__ = ["MLSolution", "TrajectorySolution", "ml_solve", "trajectory_solve"]

HALVINGS = 12
"""Step lengths tried per Gauss-Newton iteration: k = 1, 1/2, ..., 2^-(HALVINGS-1)."""

SECOND_ROOT_COST = 100.0
"""A second closed-form root is not followed when its chi-square cost is above this
many times the consistency threshold while the first root's is within it."""

START_ITERATIONS = 8
"""Gauss-Newton iterations of each per-sample solve behind a track's start (a start
only has to lie in the right basin; the track fit then converges in full)."""

_DAMPING_DECADES = 14  # Levenberg-Marquardt damping values tried per iteration
_DAMPING_START = 1e-3  # first damping, relative to the largest eigenvalue of H^T G H
_DECREASE_TOL = 1e-14  # converged: the Gauss-Newton step would lower the cost by less
_STALL_TOL = 1e-6  # a stalled problem converged if its GN step promised less than this
_TIE = 1e-9  # chi-square costs closer than this are a tie


@dataclass(frozen=True)
class MLSolution:
    """Maximum-likelihood positions of N range-sum problems (seed 001, eqs. 4 and 6).

    Attributes
    ----------
    x : (N, D) ndarray
        Estimated positions, metres.
    covariance : (N, D, D) ndarray
        (H^T G H)^-1 at x, m^2 (eigenvalues of H^T G H floored as in
        :func:`plotgate.core.multistatic.crlb.crlb`: huge, finite, where unobservable).
    residuals : (N, P) ndarray
        l - h(x), metres.
    cost : (N,) ndarray
        Chi-square sum_p r_p^2 / sigma_p^2 at x.
    normalized_cost : (N,) ndarray
        cost / (P - D) (cost itself when P = D); about 1 for a consistent fit.
    consistent : (N,) ndarray of bool
        cost <= chi2.ppf(1 - alpha, P - D); True for every problem when P <= D.
    iterations : (N,) ndarray of int
        Gauss-Newton iterations (Jacobian evaluations) of the reported run.
    converged : (N,) ndarray of bool
        The reported run met the convergence test within max_iter.
    alternative : (N, D) ndarray
        Another consistent local minimum where ``has_alternative``; a copy of x elsewhere.
        Without x0 it comes from the closed form's other root; with x0 it is the
        lowest-cost of the other starts' minima (x0's, when a closed-form root found a
        lower cost; or a root's) that converged and passes the chi-square test.
    has_alternative : (N,) ndarray of bool
        A second, distinct (more than one standard deviation from x), converged and
        consistent solution exists (e.g. the second ellipse intersection with P = D).
    """

    x: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    cost: np.ndarray
    normalized_cost: np.ndarray
    consistent: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    alternative: np.ndarray
    has_alternative: np.ndarray


@dataclass(frozen=True)
class TrajectorySolution:
    """Maximum-likelihood constant-velocity tracks from T samples of P range sums.

    One track (``l`` of shape (T, P)) gives the shapes below; a batch of N tracks
    (``l`` of shape (N, T, P)) puts N in front of every field but ``t_ref``.

    Attributes
    ----------
    state : (2D,) ndarray
        (x0, v): position at ``t_ref`` (metres) and velocity (m/s).
    covariance : (2D, 2D) ndarray
        (H^T G H)^-1 of the state.
    t_ref : float
        Time of the state position: the first sample time t[0], seconds.
    residuals : (T, P) ndarray
        l - h(x(t)), metres.
    cost : float
        Chi-square sum of r^2 / sigma^2 over all T P range sums.
    normalized_cost : float
        cost / (T P - 2D) (cost itself when T P = 2D).
    consistent : bool
        cost <= chi2.ppf(1 - alpha, T P - 2D) (True when T P <= 2D).
    converged : bool
        The solve met its convergence test.
    iterations : int
        Gauss-Newton iterations of the reported run.
    """

    state: np.ndarray
    covariance: np.ndarray
    t_ref: float
    residuals: np.ndarray
    cost: float | np.ndarray
    normalized_cost: float | np.ndarray
    consistent: bool | np.ndarray
    converged: bool | np.ndarray
    iterations: int | np.ndarray

    @property
    def position(self) -> np.ndarray:
        """(D,) or (N, D) position at t_ref, metres."""
        return self.state[..., : self.state.shape[-1] // 2]

    @property
    def velocity(self) -> np.ndarray:
        """(D,) or (N, D) velocity, m/s."""
        return self.state[..., self.state.shape[-1] // 2 :]

    def at(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Positions and their covariances at the requested times.

        Parameters
        ----------
        t : float or (M,) array_like
            Times in seconds, on the epoch of the solved samples.

        Returns
        -------
        positions : (M, D) or (N, M, D) ndarray
            x0 + v (t - t_ref), metres (M = 1 for a scalar t).
        covariances : (M, D, D) or (N, M, D, D) ndarray
            A P A^T with A = [I, (t - t_ref) I], m^2.

        Raises
        ------
        NonFiniteError, ParameterError
            If t is not finite or has more than one axis.
        """
        t = as_array("t", t)
        if t.ndim > 1:
            raise ParameterError("t", f"must be a scalar or have shape (M,), got {t.shape}")
        tau = np.atleast_1d(t) - self.t_ref
        return (
            self.position[..., None, :] + tau[:, None] * self.velocity[..., None, :],
            _position_covariance(self.covariance, tau),
        )


# ---------------------------------------------------------------- the Gauss-Newton core


@dataclass
class _Fit:
    theta: np.ndarray  # (n, K)
    cost: np.ndarray  # (n,)
    residuals: np.ndarray  # (n, M) raw, metres
    information: np.ndarray  # (n, K, K) H^T G H at theta
    covariance: np.ndarray  # (n, K, K)
    iterations: np.ndarray  # (n,)
    converged: np.ndarray  # (n,)


Predict = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(theta (m, K), problem index (m,)) -> model range sums (m, M)."""


def _gauss_newton(
    predict: Predict,
    jacobian: Predict,
    ls: np.ndarray,
    sigma: np.ndarray,
    theta0: np.ndarray,
    max_iter: int,
    tol: float,
) -> _Fit:
    """Weighted Gauss-Newton with step halving and a Levenberg-Marquardt fallback.

    n problems of M measurements and K parameters at once: ``ls``, ``sigma`` (n, M),
    ``theta0`` (n, K); ``jacobian`` returns (m, M, K). Only iterations loop.
    """
    n, k = theta0.shape
    theta = theta0.copy()
    w = 1.0 / sigma
    everyone = np.arange(n)
    r = (ls - predict(theta, everyone)) * w
    cost = np.einsum("nm,nm->n", r, r)
    mu = np.zeros(n)  # last damping that worked (relative); 0 = none yet
    iterations = np.zeros(n, dtype=int)
    converged = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    halving = 0.5 ** np.arange(HALVINGS)
    decades = 10.0 ** np.arange(_DAMPING_DECADES)

    def try_steps(idx: np.ndarray, trials: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Take, per problem idx, the first of the trials (m, J, K) that lowers its cost.

        Returns the success mask (m,) and the index of the trial taken (m,).
        """
        m, j, _ = trials.shape
        h = predict(trials.reshape(m * j, k), np.repeat(idx, j)).reshape(m, j, -1)
        rt = (ls[idx, None] - h) * w[idx, None]
        costs = np.einsum("mjp,mjp->mj", rt, rt)
        lower = costs < cost[idx, None]
        ok = lower.any(axis=1)
        pick = np.argmax(lower, axis=1)
        take, rows = idx[ok], np.flatnonzero(ok)
        theta[take] = trials[rows, pick[ok]]
        r[take] = rt[rows, pick[ok]]
        cost[take] = costs[rows, pick[ok]]
        return ok, pick

    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        iterations[idx] += 1
        th = theta[idx]
        rw = r[idx]
        Hw = jacobian(th, idx) * w[idx, :, None]  # (m, M, K)
        col = np.sqrt(np.einsum("mpk,mpk->mk", Hw, Hw))  # column scaling (m, K)
        col = np.where(col > 0.0, col, 1.0)
        Hs = Hw / col[:, None, :]
        g = np.einsum("mpk,mp->mk", Hs, rw)
        ev, V = _symmetric_eigh(np.einsum("mpi,mpj->mij", Hs, Hs))
        gv = np.einsum("mki,mk->mi", V, g)
        keep = ev > 1e-12 * ev[:, -1:]
        gv_ev = np.divide(gv, ev, out=np.zeros_like(gv), where=keep)
        step = np.einsum("mik,mk->mi", V, gv_ev) / col
        # the cost decrease the Gauss-Newton model promises: g^T (H^T G H)^+ g
        promised = np.einsum("mk,mk->m", gv, gv_ev)
        small = (_norm(step) <= tol * (1.0 + _norm(th))) | (
            promised <= _DECREASE_TOL * (1.0 + cost[idx])
        )
        # seed eq. 6 with k = 1, 1/2, 1/4, ...; a converged problem still takes its
        # last (small) step when that lowers the cost
        ok, _ = try_steps(idx, th[:, None, :] + step[:, None, :])  # k = 1 first
        if not ok.all():
            bad = np.flatnonzero(~ok)
            trials = th[bad, None, :] + halving[None, 1:, None] * step[bad, None, :]
            ok[bad], _ = try_steps(idx[bad], trials)
        converged[idx[small]] = True
        active[idx[small]] = False
        fail = ~ok & ~small
        if not fail.any():
            continue

        # Levenberg-Marquardt for the problems no halving helped
        idx, th, promised = idx[fail], th[fail], promised[fail]
        ev, V, gv, col = ev[fail], V[fail], gv[fail], col[fail]
        top = np.maximum(ev[:, -1], np.finfo(float).tiny)
        start = np.where(mu[idx] > 0.0, mu[idx] / 10.0, _DAMPING_START)
        damp = (start[:, None] * decades[None, :]) * top[:, None]  # (m, J)
        steps = np.einsum("mik,mjk->mji", V, gv[:, None, :] / (ev[:, None, :] + damp[..., None]))
        trials = th[:, None, :] + steps / col[:, None, :]
        ok, pick = try_steps(idx, trials)
        mu[idx[ok]] = start[ok] * decades[pick[ok]]
        # stalled: no step lowers the cost (rounding); a minimum if GN promised little
        stalled = idx[~ok]
        active[stalled] = False
        converged[stalled] = promised[~ok] <= _STALL_TOL * (1.0 + cost[stalled])

    Hw = jacobian(theta, everyone) * w[:, :, None]
    information = np.einsum("npi,npj->nij", Hw, Hw)
    return _Fit(
        theta,
        cost,
        r * sigma,
        information,
        _inverse_information(information),
        iterations,
        converged,
    )


# ---------------------------------------------------------------- inputs and starts


def _options(alpha: float, max_iter: int, tol: float) -> tuple[float, int, float]:
    alpha = float(as_probability("alpha", as_scalar("alpha", alpha)))
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ParameterError("max_iter", f"must be an integer >= 1, got {max_iter!r}")
    tol = as_scalar("tol", tol)
    require_positive("tol", tol)
    return alpha, int(max_iter), tol


def _threshold(alpha: float, dof: int) -> float:
    """chi2.ppf(1 - alpha, dof); +inf (everything consistent) without redundancy."""
    return float(stats.chi2.ppf(1.0 - alpha, dof)) if dof > 0 else np.inf


def _start_points(x0: ArrayLike | None, n: int, d: int, name: str = "x0") -> np.ndarray:
    """A user start (D,) or (N, D) as an (N, D) array."""
    x0 = as_array(name, x0, (d,))
    if x0.ndim > 2 or (x0.ndim == 2 and x0.shape[0] != n):
        raise ParameterError(name, f"must have shape ({d},) or ({n}, {d}), got {x0.shape}")
    return np.array(np.broadcast_to(x0, (n, d)))


def _closed_form_starts(
    ls: np.ndarray, tx: np.ndarray, rx: np.ndarray, sigma: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sum-range closed-form starts: (x (N, D), alternative (N, D), has_alternative (N,)).

    Uses the pairs of each problem's first transmitter; problems are grouped by which
    pairs those are (one group when every problem has a single transmitter).
    """
    n, p, d = tx.shape
    tol = COINCIDENT_RTOL * _scale(tx, rx)
    first = np.linalg.norm(tx - tx[:, :1], axis=-1) <= tol[:, None]  # (N, P)
    x = np.empty((n, d))
    alternative = np.empty((n, d))
    has_alternative = np.zeros(n, dtype=bool)
    if first.all():  # one transmitter: a single group, no sort
        patterns, group = first[:1], np.zeros(n, dtype=int)
    else:
        patterns, group = np.unique(first, axis=0, return_inverse=True)
    for g, pattern in enumerate(patterns):
        rows = np.flatnonzero(group.ravel() == g)
        if pattern.sum() < d:
            centroid = 0.5 * (tx[rows].mean(axis=1) + rx[rows].mean(axis=1))
            x[rows] = alternative[rows] = centroid
            continue
        m = int(pattern.sum())
        sol = sum_range_solve(
            ls[rows][:, pattern],
            np.repeat(tx[rows, :1], m, axis=1),
            rx[rows][:, pattern],
            baseline_tol=BASELINE_SIGMAS * sigma[rows][:, pattern],
        )
        x[rows] = sol.x
        alternative[rows] = sol.alternative
        has_alternative[rows] = sol.has_alternative
    return x, alternative, has_alternative


def _worth_following(
    ls: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    start: np.ndarray,
    alt_start: np.ndarray,
    threshold: float,
) -> np.ndarray:
    """(N,) which second closed-form roots Gauss-Newton also starts from.

    All of them, except where the primary root already fits (chi-square cost within
    the consistency threshold) and the second root's cost exceeds SECOND_ROOT_COST
    times that threshold: on the study's problems the closed form's roots sit within
    80 of a consistent minimum's cost, and this skips most far mirror roots.
    """

    def cost(x: np.ndarray) -> np.ndarray:
        r = (ls - _range_sums(x, tx, rx)) / sigma
        return np.einsum("np,np->n", r, r)

    return (cost(start) > threshold) | (cost(alt_start) <= SECOND_ROOT_COST * threshold)


def _best_and_alternative(
    fit: _Fit, runs: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reported run, the alternative's run and whether there is one, per problem.

    ``runs`` (N, K) are each problem's runs in order of preference on a tie (a problem
    with fewer starts repeats its first run). The lowest cost wins: a later run only
    when its cost is lower by more than the tie tolerance. The alternative is the
    lowest-cost run that converged, passes the chi-square test (cost <= threshold) and
    lies more than one standard deviation (Mahalanobis, by the winner's information)
    from the winner. Loops over the K (at most 3) columns only.
    """
    n, k = runs.shape
    rows = np.arange(n)
    cost = fit.cost[runs]  # (N, K)
    best = np.zeros(n, dtype=int)
    for j in range(1, k):
        lower = cost[:, j] + _TIE * (1.0 + cost[rows, best]) < cost[rows, best]
        best = np.where(lower, j, best)
    chosen = runs[rows, best]
    dx = fit.theta[runs] - fit.theta[chosen][:, None, :]  # (N, K, D)
    distinct = np.einsum("nkj,nkj->nk", dx @ fit.information[chosen], dx) > 1.0
    eligible = distinct & fit.converged[runs] & (cost <= threshold)
    pick = np.argmin(np.where(eligible, cost, np.inf), axis=1)
    return chosen, runs[rows, pick], eligible.any(axis=1)


def _position_model(tx: np.ndarray, rx: np.ndarray) -> tuple[Predict, Predict]:
    """predict / jacobian of the single-shot problems (theta = x)."""

    def predict(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return _range_sums(x, tx[idx], rx[idx])

    def jacobian(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return _range_sum_jacobian(x, tx[idx], rx[idx])

    return predict, jacobian


# ---------------------------------------------------------------- single shot


def ml_solve(
    l: ArrayLike,  # noqa: E741 (seed 001 names the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike,
    x0: ArrayLike | None = None,
    alpha: float = 0.01,
    max_iter: int = 50,
    tol: float = 1e-9,
    *,
    closed_form_starts: bool = True,
) -> MLSolution:
    """Maximum-likelihood position from P range sums, N problems at once (seed 001, eq. 6).

    Minimises L(x) = sum_p (l_p - h_p(x))^2 / sigma_p^2 (eq. 4) by weighted Gauss-Newton
    with step halving and a Levenberg-Marquardt fallback (see the module notes), from
    the sum-range closed form (both of its roots when it has two) and from ``x0`` when
    given; the lowest cost wins.

    Parameters
    ----------
    l : (P,) or (N, P) array_like
        Measured range sums, metres.
    tx : (D,), (P, D) or (N, P, D) array_like
        Transmitter of each pair (one point for a single transmitter), metres.
    rx : (P, D) or (N, P, D) array_like
        Receiver of each pair, metres; D = 2 or 3, P >= D.
    sigma : float, (P,) or (N, P) array_like
        Range-sum noise standard deviations, metres, > 0.
    x0 : (D,) or (N, D) array_like, optional
        A start position, tried besides the closed form's roots: the lowest cost wins,
        x0's minimum on a tie (a start near one of two exact solutions picks it). The
        best other minimum (x0's when a root fit better, or a root's) becomes
        ``alternative`` when it converged, is consistent and is distinct; a start
        trapped in a false minimum is never reported. Default: the closed form's roots
        only.
    alpha : float, optional
        False-alarm probability of the chi-square consistency test, in (0, 1).
        Default 0.01.
    max_iter : int, optional
        Largest number of Gauss-Newton iterations, >= 1. Default 50.
    tol : float, optional
        Convergence when the Gauss-Newton step is below tol (1 + |x|) metres, > 0.
        Default 1e-9.
    closed_form_starts : bool, optional
        With x0: also start from the closed form's roots (default True). False runs
        from x0 alone and searches no alternative: a local refinement that can stay
        in a false minimum (flagged by ``consistent`` when P > D). Needs x0 when False.

    Returns
    -------
    solution : MLSolution
        Batched (N, ...); N = 1 when nothing is batched.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        On wrong shapes, P < D, a negative range sum, sigma <= 0, alpha outside (0, 1),
        max_iter < 1, tol <= 0, or closed_form_starts not a bool or False without x0.
    GeometryError
        On coincident platforms, a repeated pair, or a range sum more than
        BASELINE_SIGMAS sigma shorter than its baseline.

    Notes
    -----
    A problem whose data have no exact solution (the ellipses do not meet) still gets
    the least-squares point, flagged by ``consistent`` when it does not fit. Nothing
    is NaN: an unobservable direction (a target on a baseline with P = D) gets a huge,
    finite variance.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, seed 001, eq. (4) (the
       likelihood criterion) and eq. (6) (Gauss-Newton with the step factor k).

    Examples
    --------
    One transmitter and three receivers about 10 km apart; the range sums of a target
    at (3, 4) km plus a few decimetres of noise:

    >>> from plotgate.core.multistatic.model import range_sums
    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> l = range_sums([3000.0, 4000.0], [0.0, 0.0], rx) + [0.3, -0.4, 0.2]
    >>> sol = ml_solve(l, [0.0, 0.0], rx, sigma=0.5)
    >>> sol.x.round(2), sol.consistent, sol.converged
    (array([[2999.78, 4000.27]]), array([ True]), array([ True]))

    With two receivers (P = D) the ellipses meet twice and both points fit exactly; a
    start near one picks it, and the other is the alternative:

    >>> l2 = range_sums([3000.0, 4000.0], [0.0, 0.0], rx[:2])
    >>> sol = ml_solve(l2, [0.0, 0.0], rx[:2], sigma=0.5, x0=[2900.0, 4100.0])
    >>> sol.x.round(3) + 0.0, sol.alternative.round(1), sol.has_alternative
    (array([[3000., 4000.]]), array([[-1530.4,   -60.8]]), array([ True]))
    """
    alpha, max_iter, tol = _options(alpha, max_iter, tol)
    if not isinstance(closed_form_starts, (bool, np.bool_)):
        raise ParameterError(
            "closed_form_starts", f"must be True or False, got {closed_form_starts!r}"
        )
    if x0 is None and not closed_form_starts:
        raise ParameterError(
            "closed_form_starts", "False needs x0: without a start the closed form is the only one"
        )
    ls, tx, rx, sigma = validate_problem(l, tx, rx, sigma)
    n, p, d = tx.shape
    threshold = _threshold(alpha, p - d)
    # the starts every problem has, in order of preference on a tie (x0, the closed
    # form's primary root), then the second roots worth following
    starts = [] if x0 is None else [_start_points(x0, n, d)]
    second, seconds = np.zeros(0, dtype=int), np.zeros((0, d))
    if closed_form_starts:
        start, alt_start, has_alt_start = _closed_form_starts(ls, tx, rx, sigma)
        starts.append(start)
        second = np.flatnonzero(
            has_alt_start & _worth_following(ls, tx, rx, sigma, start, alt_start, threshold)
        )
        seconds = alt_start[second]
    k = len(starts)
    problem = np.concatenate([np.tile(np.arange(n), k), second])
    predict, jacobian = _position_model(tx[problem], rx[problem])
    fit = _gauss_newton(
        predict,
        jacobian,
        ls[problem],
        sigma[problem],
        np.concatenate([*starts, seconds]),
        max_iter,
        tol,
    )

    # runs (N, k + 1): run r = j n + i is problem i's start j; the last column is the
    # second root's run, or the problem's first run where there is none
    runs = np.arange(n)[:, None] + n * np.arange(k + 1)
    runs[:, k] = np.arange(n)
    runs[second, k] = k * n + np.arange(second.size)
    chosen, other, has_alternative = _best_and_alternative(fit, runs, threshold)
    x = fit.theta[chosen]
    cost = fit.cost[chosen]
    return MLSolution(
        x=x,
        covariance=fit.covariance[chosen],
        residuals=fit.residuals[chosen],
        cost=cost,
        normalized_cost=cost / max(p - d, 1),
        consistent=cost <= threshold,
        iterations=fit.iterations[chosen],
        converged=fit.converged[chosen],
        alternative=np.where(has_alternative[:, None], fit.theta[other], x),
        has_alternative=has_alternative,
    )


# ---------------------------------------------------------------- constant-velocity track


def _line_terms(
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
    M, b = _line_terms(x, W, tau, use)
    return np.einsum("nij,nj->ni", _inverse_information(M.sum(axis=1)), b.sum(axis=1))


def _chain(cand: np.ndarray, tau: np.ndarray, first: int) -> np.ndarray:
    """Pick one of two candidates (N, T, 2, D) per time-sorted sample by continuity: (N, T)."""
    n, n_t = cand.shape[:2]
    tracks = np.arange(n)
    pick = np.zeros((n, n_t), dtype=int)
    pick[:, 0] = first
    prev = pred = cand[:, 0, first]
    for i in range(1, n_t):  # sequential in the samples, vectorized over the tracks
        pick[:, i] = np.argmin(_norm(cand[:, i] - pred[:, None]), axis=1)
        here = cand[tracks, i, pick[:, i]]
        if i + 1 < n_t:
            dt = tau[i] - tau[i - 1]
            rate = (here - prev) / dt if dt > 0.0 else np.zeros_like(here)
            pred = here + rate * (tau[i + 1] - tau[i])
        prev = here
    return pick


def _track_starts(
    ls: np.ndarray,
    tau: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    alpha: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(x0, v) starts of N tracks: (starts (S, 2D), the track of each start (S,)).

    ls, sigma (N, T, P), tx, rx (N, T, P, D). Each sample is solved by :func:`ml_solve`
    from the closed form's primary root. With P = D the closed form's second root is
    an exact second solution, and the true and mirror tracks may cross. Two chains are
    then followed through the samples, starting from either root of the first sample
    and taking at each sample the root nearer the straight-line extrapolation of the
    chain; each chain seeds a line fit, refined three times by keeping at each sample
    the root nearer the line (Mahalanobis). The per-sample solves stop after
    START_ITERATIONS; samples whose fit fails the chi-square test are left out of the
    line fits when at least two distinct times remain.
    """
    n, n_t, p, d = tx.shape
    flat = [a.reshape((n * n_t, *a.shape[2:])) for a in (ls, tx, rx, sigma)]
    start, alternative, has_alternative = _closed_form_starts(*flat)
    sol = ml_solve(
        *flat, x0=start, alpha=alpha, max_iter=START_ITERATIONS, closed_form_starts=False
    )
    has_alternative &= p == d
    cand = np.stack([sol.x, np.where(has_alternative[:, None], alternative, sol.x)], axis=1)
    cand = cand.reshape(n, n_t, 2, d)
    has_alternative = has_alternative.reshape(n, n_t)
    H = _range_sum_jacobian(cand, tx[:, :, None], rx[:, :, None]) / sigma[:, :, None, :, None]
    W = np.einsum("ntcpi,ntcpj->ntcij", H, H)  # information of each candidate
    good = sol.consistent.reshape(n, n_t)
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


def _per_sample(name: str, value: ArrayLike, n: int, n_t: int, core_ndim: int) -> ArrayLike:
    """A per-sample (T, ...) or per-track (N, T, ...) argument as (N T, ...) rows.

    Arguments with at most ``core_ndim`` axes (fixed platforms, one sigma per pair)
    pass through unchanged for :func:`validate_problem` to broadcast.
    """
    shape = tuple(_shape(name, value))
    extra = len(shape) - core_ndim
    if extra <= 0:
        return value
    if extra > 2 or shape[:extra] != (n, n_t)[2 - extra :]:
        want = f"({n_t}, ...) or ({n}, {n_t}, ...)" if n > 1 else f"({n_t}, ...)"
        raise ParameterError(
            name, f"has shape {shape}: per-sample values need {want} for the {n_t} sample times"
        )
    core = shape[extra:]
    return np.broadcast_to(as_array(name, value), (n, n_t, *core)).reshape(n * n_t, *core)


def trajectory_solve(
    l: ArrayLike,  # noqa: E741 (seed 001 names the range sum l)
    t: ArrayLike,
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike,
    x0: ArrayLike | None = None,
    alpha: float = 0.01,
    max_iter: int = 50,
    tol: float = 1e-9,
) -> TrajectorySolution:
    """Maximum-likelihood constant-velocity tracks from T samples of range sums (seed 001).

    The accumulated measurement vector of eq. 2 (all T P range sums) is fitted by the
    Gauss-Newton solver of :func:`ml_solve` with parameters theta = (x0, v),
    x(t_i) = x0 + v (t_i - t_ref), t_ref = t[0]: the Jacobian of l_{p,i} is
    [H_{p,i}, (t_i - t_ref) H_{p,i}] (eq. 6 over the whole track). N independent
    tracks sampled at the same times (e.g. Monte Carlo runs) are solved at once.

    Parameters
    ----------
    l : (T, P) or (N, T, P) array_like
        Range sums of each sample, metres; (N, T, P) for N tracks.
    t : (T,) array_like
        Sample times, seconds (any epoch); at least two distinct times.
    tx : (D,), (P, D), (T, P, D) or (N, T, P, D) array_like
        Transmitter of each pair, fixed or per sample (moving platforms, e.g. from
        :func:`plotgate.core.multistatic.model.platform_positions`), metres; the same for every
        track unless given per track.
    rx : (P, D), (T, P, D) or (N, T, P, D) array_like
        Receiver of each pair, metres; P >= D.
    sigma : float, (P,), (T, P) or (N, T, P) array_like
        Range-sum noise standard deviations, metres, > 0.
    x0 : (2D,) or (N, 2D) array_like, optional
        Start state (position at t[0], velocity). Default: a straight line fitted to
        the per-sample :func:`ml_solve` positions, weighted by their information
        (two variants when samples have two solutions; the lower final cost wins).
    alpha, max_iter, tol : optional
        As :func:`ml_solve`; the chi-square test has T P - 2D degrees of freedom.

    Returns
    -------
    solution : TrajectorySolution
        The state, its covariance and the fit (N in front of each field for N
        tracks); ``solution.at(times)`` gives positions and covariances at any times.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`ml_solve`, with the index of the first bad sample (flat over tracks
        and samples, n T + i, for N tracks); ParameterError also when l is not (T, P)
        or (N, T, P), a per-sample argument does not have T samples, x0 is not (2D,)
        or (N, 2D), or t is not (T,) with two distinct times.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, seed 001, eqs. (2), (4), (6):
       the n accumulated samples of a target on a straight line (Fig. 3, curves 2, 3).

    Examples
    --------
    A target at 80 m/s north, five samples a second apart, noise-free:

    >>> from plotgate.core.multistatic.model import range_sums
    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> t = np.arange(5.0)
    >>> x = np.array([3000.0, 4000.0]) + t[:, None] * [0.0, 80.0]
    >>> l = range_sums(x, [0.0, 0.0], rx)
    >>> sol = trajectory_solve(l, t, [0.0, 0.0], rx, sigma=0.5)
    >>> sol.state.round(6) + 0.0, sol.converged
    (array([3000., 4000.,    0.,   80.]), True)
    >>> sol.at(10.0)[0].round(6)
    array([[3000., 4800.]])

    Three tracks at once (the same data with three noise draws):

    >>> rng = np.random.default_rng(0)
    >>> many = trajectory_solve(l + rng.normal(0.0, 0.5, (3, 5, 3)), t, [0.0, 0.0], rx, 0.5)
    >>> many.state.shape, many.at([0.0, 10.0])[1].shape, many.converged.all()
    ((3, 4), (3, 2, 2, 2), np.True_)
    """
    alpha, max_iter, tol = _options(alpha, max_iter, tol)
    t = as_array("t", t)
    if t.ndim != 1:
        raise ParameterError("t", f"must have shape (T,), got {t.shape}")
    l_shape = tuple(_shape("l", l))
    if len(l_shape) not in (2, 3) or l_shape[-2] != t.size:
        raise ParameterError(
            "l",
            f"must have shape (T, P) or (N, T, P) with T = {t.size} samples as t, got {l_shape}",
        )
    if t.size < 2 or not (t != t[0]).any():
        raise ParameterError("t", "needs at least two distinct times to observe the velocity")
    n, n_t = (l_shape[0] if len(l_shape) == 3 else 1), t.size
    tx = _per_sample("tx", _with_tx_axis(tx), n, n_t, 2)
    rx = _per_sample("rx", rx, n, n_t, 2)
    sigma = _per_sample("sigma", sigma, n, n_t, 1)
    ls, tx, rx, sigma = validate_problem(np.reshape(l, (n * n_t, -1)), tx, rx, sigma)
    p, d = tx.shape[1:]
    ls, sigma = ls.reshape(n, n_t, p), sigma.reshape(n, n_t, p)
    tx, rx = tx.reshape(n, n_t, p, d), rx.reshape(n, n_t, p, d)
    tau = t - t[0]
    if x0 is None:
        starts, owner = _track_starts(ls, tau, tx, rx, sigma, alpha)
    else:
        starts, owner = _start_points(x0, n, 2 * d), np.arange(n)

    def predict(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]  # (m, T, D)
        return _range_sums(x, tx[owner[idx]], rx[owner[idx]]).reshape(idx.size, n_t * p)

    def jacobian(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]
        H = _range_sum_jacobian(x, tx[owner[idx]], rx[owner[idx]])  # (m, T, P, D)
        H = np.concatenate([H, tau[:, None, None] * H], axis=-1)
        return H.reshape(idx.size, n_t * p, 2 * d)

    fit = _gauss_newton(
        predict,
        jacobian,
        ls.reshape(n, -1)[owner],
        sigma.reshape(n, -1)[owner],
        starts,
        max_iter,
        tol,
    )
    # the lowest cost of each track's starts (its primary start on a tie)
    order = np.lexsort((np.arange(owner.size), fit.cost, owner))
    best = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]
    dof = n_t * p - 2 * d
    cost = fit.cost[best]
    solution = TrajectorySolution(
        state=fit.theta[best],
        covariance=fit.covariance[best],
        t_ref=float(t[0]),
        residuals=fit.residuals[best].reshape(n, n_t, p),
        cost=cost,
        normalized_cost=cost / max(dof, 1),
        consistent=cost <= _threshold(alpha, dof),
        converged=fit.converged[best],
        iterations=fit.iterations[best],
    )
    return solution if len(l_shape) == 3 else _single_track(solution)


def _single_track(sol: TrajectorySolution) -> TrajectorySolution:
    """The first (only) track of a batch, with plain Python scalars."""
    return TrajectorySolution(
        state=sol.state[0],
        covariance=sol.covariance[0],
        t_ref=sol.t_ref,
        residuals=sol.residuals[0],
        cost=float(sol.cost[0]),
        normalized_cost=float(sol.normalized_cost[0]),
        consistent=bool(sol.consistent[0]),
        converged=bool(sol.converged[0]),
        iterations=int(sol.iterations[0]),
    )
