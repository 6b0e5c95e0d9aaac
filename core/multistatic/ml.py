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
(:func:`core.multistatic.closed_form.sum_range_solve`); with several transmitters,
that of the first transmitter's pairs (problems whose first transmitter has fewer than
D pairs start at the centroid of their platforms). When the closed form has a second
root, Gauss-Newton runs from both; the lower cost wins, and the other becomes the
``alternative`` when it converged, passes the chi-square test and lies more than one
standard deviation (Mahalanobis, by the winner's covariance) from the winner.

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

from core._validate import as_array, as_probability, as_scalar, require_positive
from core.errors import ParameterError
from core.multistatic.closed_form import sum_range_solve
from core.multistatic.crlb import _inverse_information, _position_covariance, _symmetric_eigh
from core.multistatic.model import (
    BASELINE_SIGMAS,
    COINCIDENT_RTOL,
    _norm,
    _range_sum_jacobian,
    _range_sums,
    _scale,
    range_sum_jacobian,
    range_sums,
    validate_problem,
)

__all__ = ["MLSolution", "TrajectorySolution", "ml_solve", "trajectory_solve"]

HALVINGS = 12
"""Step lengths tried per Gauss-Newton iteration: k = 1, 1/2, ..., 2^-(HALVINGS-1)."""

SECOND_ROOT_COST = 100.0
"""A second closed-form root is not followed when its chi-square cost is above this
many times the consistency threshold while the first root's is within it."""

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
        :func:`core.multistatic.crlb.crlb`: huge, finite, where unobservable).
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
    has_alternative : (N,) ndarray of bool
        A second, distinct, consistent solution exists (e.g. the second ellipse
        intersection with P = D).
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
    """Maximum-likelihood constant-velocity track from T samples of P range sums.

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
    cost: float
    normalized_cost: float
    consistent: bool
    converged: bool
    iterations: int

    @property
    def position(self) -> np.ndarray:
        """(D,) position at t_ref, metres."""
        return self.state[: self.state.size // 2]

    @property
    def velocity(self) -> np.ndarray:
        """(D,) velocity, m/s."""
        return self.state[self.state.size // 2:]

    def at(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Positions and their covariances at the requested times.

        Parameters
        ----------
        t : float or (M,) array_like
            Times in seconds, on the epoch of the solved samples.

        Returns
        -------
        positions : (M, D) ndarray
            x0 + v (t - t_ref), metres (M = 1 for a scalar t).
        covariances : (M, D, D) ndarray
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
        return (self.position + tau[:, None] * self.velocity,
                _position_covariance(self.covariance, tau))


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
        small = ((_norm(step) <= tol * (1.0 + _norm(th)))
                 | (promised <= _DECREASE_TOL * (1.0 + cost[idx])))
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
    return _Fit(theta, cost, r * sigma, information, _inverse_information(information),
                iterations, converged)


# ---------------------------------------------------------------- inputs and starts


def _options(alpha: float, max_iter: int, tol: float) -> tuple[float, int, float]:
    alpha = float(as_probability("alpha", as_scalar("alpha", alpha)))
    if (isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer))
            or max_iter < 1):
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
        sol = sum_range_solve(ls[rows][:, pattern], np.repeat(tx[rows, :1], m, axis=1),
                              rx[rows][:, pattern],
                              baseline_tol=BASELINE_SIGMAS * sigma[rows][:, pattern])
        x[rows] = sol.x
        alternative[rows] = sol.alternative
        has_alternative[rows] = sol.has_alternative
    return x, alternative, has_alternative


def _worth_following(
    ls: np.ndarray, tx: np.ndarray, rx: np.ndarray, sigma: np.ndarray,
    start: np.ndarray, alt_start: np.ndarray, threshold: float,
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
) -> MLSolution:
    """Maximum-likelihood position from P range sums, N problems at once (seed 001, eq. 6).

    Minimises L(x) = sum_p (l_p - h_p(x))^2 / sigma_p^2 (eq. 4) by weighted Gauss-Newton
    with step halving and a Levenberg-Marquardt fallback (see the module notes), from
    the sum-range closed form (both of its roots when it has two) or from ``x0``.

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
        Start position. Default: the sum-range closed form, both roots.
        With a given start no alternative is searched for.
    alpha : float, optional
        False-alarm probability of the chi-square consistency test, in (0, 1).
        Default 0.01.
    max_iter : int, optional
        Largest number of Gauss-Newton iterations, >= 1. Default 50.
    tol : float, optional
        Convergence when the Gauss-Newton step is below tol (1 + |x|) metres, > 0.
        Default 1e-9.

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
        max_iter < 1 or tol <= 0.
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

    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> l = range_sums([3000.0, 4000.0], [0.0, 0.0], rx) + [0.3, -0.4, 0.2]
    >>> sol = ml_solve(l, [0.0, 0.0], rx, sigma=0.5)
    >>> sol.x.round(2), sol.consistent, sol.converged
    (array([[2999.78, 4000.27]]), array([ True]), array([ True]))
    """
    alpha, max_iter, tol = _options(alpha, max_iter, tol)
    ls, tx, rx, sigma = validate_problem(l, tx, rx, sigma)
    n, p, d = tx.shape
    if x0 is None:
        start, alt_start, has_alt_start = _closed_form_starts(ls, tx, rx, sigma)
    else:
        start = _start_points(x0, n, d)
        alt_start, has_alt_start = start, np.zeros(n, dtype=bool)

    # one run per start: the N primaries, then the second roots worth following
    threshold = _threshold(alpha, p - d)
    second = np.flatnonzero(has_alt_start & _worth_following(
        ls, tx, rx, sigma, start, alt_start, threshold))
    problem = np.concatenate([np.arange(n), second])
    predict, jacobian = _position_model(tx[problem], rx[problem])
    fit = _gauss_newton(predict, jacobian, ls[problem], sigma[problem],
                        np.concatenate([start, alt_start[second]]), max_iter, tol)

    chosen = np.arange(n)  # run index reported for each problem
    other = np.arange(n)
    other[second] = n + np.arange(second.size)
    swap = fit.cost[other] + _TIE * (1.0 + fit.cost[chosen]) < fit.cost[chosen]
    chosen, other = np.where(swap, other, chosen), np.where(swap, chosen, other)

    x = fit.theta[chosen]
    dx = fit.theta[other] - x
    distinct = np.einsum("ni,nij,nj->n", dx, fit.information[chosen], dx) > 1.0
    has_alternative = (has_alt_start & distinct & fit.converged[other]
                       & (fit.cost[other] <= threshold))
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


def _line_fit(x: np.ndarray, W: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Information-weighted straight line x_i ~ x0 + tau_i v through (T, D) points: (2D,)."""
    d = x.shape[1]
    tw = tau[:, None, None] * W
    M = np.block([[W.sum(0), tw.sum(0)], [tw.sum(0), (tau[:, None, None] * tw).sum(0)]])
    b = np.concatenate([np.einsum("tij,tj->i", W, x), np.einsum("tij,tj->i", tw, x)])
    theta: np.ndarray = _inverse_information(M) @ b
    return theta.reshape(2 * d)


def _chain(cand: np.ndarray, tau: np.ndarray, first: int) -> np.ndarray:
    """Pick one of two candidates (T, 2, D) per time-sorted sample by continuity: (T,)."""
    n_t = cand.shape[0]
    pick = np.zeros(n_t, dtype=int)
    pick[0] = first
    prev = cand[0, first]
    pred = prev
    for i in range(1, n_t):  # a sequential scan of one track's samples
        pick[i] = np.argmin(np.linalg.norm(cand[i] - pred, axis=-1))
        here = cand[i, pick[i]]
        if i + 1 < n_t:
            dt = tau[i] - tau[i - 1]
            rate = (here - prev) / dt if dt > 0.0 else np.zeros_like(here)
            pred = here + rate * (tau[i + 1] - tau[i])
        prev = here
    return pick


def _track_starts(
    ls: np.ndarray, tau: np.ndarray, tx: np.ndarray, rx: np.ndarray, sigma: np.ndarray,
    alpha: float,
) -> np.ndarray:
    """(x0, v) starts, (1, 2D) or (2, 2D), from per-sample positions.

    Each sample is solved by :func:`ml_solve` from the closed form's primary root.
    With P = D the closed form's second root is an exact second solution, and the
    true and mirror tracks may cross. Two chains are then followed through the
    samples, starting from either root of the first sample and taking at each sample
    the root nearer the straight-line extrapolation of the chain; each chain seeds a
    line fit, refined three times by keeping at each sample the root nearer the line
    (Mahalanobis). Samples that did not converge or fit are left out of the line fits
    when at least two distinct times remain.
    """
    n_t, p, d = tx.shape
    start, alternative, has_alternative = _closed_form_starts(ls, tx, rx, sigma)
    sol = ml_solve(ls, tx, rx, sigma, x0=start, alpha=alpha)
    has_alternative &= p == d
    cand = np.stack([sol.x, np.where(has_alternative[:, None], alternative, sol.x)], axis=1)
    H = range_sum_jacobian(cand, tx[:, None], rx[:, None]) / sigma[:, None, :, None]
    W = np.einsum("tcpi,tcpj->tcij", H, H)  # (T, 2, D, D) information of each candidate
    good = sol.converged & sol.consistent
    if np.unique(tau[good]).size < 2:
        good = np.ones_like(good)
    rows = np.arange(n_t)
    starts = []
    order = np.argsort(tau, kind="stable")
    for first in (0, 1) if has_alternative.any() else (0,):
        pick = np.empty(n_t, dtype=int)
        pick[order] = _chain(cand[order], tau[order], first)
        for _ in range(3):
            theta = _line_fit(cand[rows, pick][good], W[rows, pick][good], tau[good])
            e = cand - (theta[:d] + tau[:, None] * theta[d:])[:, None]  # (T, 2, D)
            dist = np.einsum("tci,tcij,tcj->tc", e, W, e)
            pick = np.where(has_alternative, np.argmin(dist, axis=1), 0)
        starts.append(_line_fit(cand[rows, pick][good], W[rows, pick][good], tau[good]))
    return np.stack(starts)


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
    """Maximum-likelihood constant-velocity track from T samples of range sums (seed 001).

    The accumulated measurement vector of eq. 2 (all T P range sums) is fitted by the
    Gauss-Newton solver of :func:`ml_solve` with parameters theta = (x0, v),
    x(t_i) = x0 + v (t_i - t_ref), t_ref = t[0]: the Jacobian of l_{p,i} is
    [H_{p,i}, (t_i - t_ref) H_{p,i}] (eq. 6 over the whole track).

    Parameters
    ----------
    l : (T, P) array_like
        Range sums of each sample, metres.
    t : (T,) array_like
        Sample times, seconds (any epoch); at least two distinct times.
    tx : (D,), (P, D) or (T, P, D) array_like
        Transmitter of each pair, fixed or per sample (moving platforms, e.g. from
        :func:`core.multistatic.model.platform_positions`), metres.
    rx : (P, D) or (T, P, D) array_like
        Receiver of each pair, metres; P >= D.
    sigma : float, (P,) or (T, P) array_like
        Range-sum noise standard deviations, metres, > 0.
    x0 : (2D,) array_like, optional
        Start state (position at t[0], velocity). Default: a straight line fitted to
        the per-sample :func:`ml_solve` positions, weighted by their information
        (two variants when samples have two solutions; the lower final cost wins).
    alpha, max_iter, tol : optional
        As :func:`ml_solve`; the chi-square test has T P - 2D degrees of freedom.

    Returns
    -------
    solution : TrajectorySolution
        The state, its covariance and the fit; ``solution.at(times)`` gives positions
        and covariances at any times.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`ml_solve` (indices are samples); ParameterError also when l is not
        (T, P), x0 is not (2D,), or t is not (T,) with two distinct times.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, seed 001, eqs. (2), (4), (6):
       the n accumulated samples of a target on a straight line (Fig. 3, curves 2, 3).

    Examples
    --------
    A target at 80 m/s north, five samples a second apart, noise-free:

    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> t = np.arange(5.0)
    >>> x = np.array([3000.0, 4000.0]) + t[:, None] * [0.0, 80.0]
    >>> l = range_sums(x, [0.0, 0.0], rx)
    >>> sol = trajectory_solve(l, t, [0.0, 0.0], rx, sigma=0.5)
    >>> sol.state.round(6) + 0.0, sol.converged
    (array([3000., 4000.,    0.,   80.]), True)
    >>> sol.at(10.0)[0].round(6)
    array([[3000., 4800.]])
    """
    alpha, max_iter, tol = _options(alpha, max_iter, tol)
    t = as_array("t", t)
    if t.ndim != 1:
        raise ParameterError("t", f"must have shape (T,), got {t.shape}")
    if np.ndim(l) != 2 or np.shape(l)[0] != t.size:
        raise ParameterError(
            "l", f"must have shape (T, P) with T = {t.size} samples as t, got {np.shape(l)}")
    if t.size < 2 or not (t != t[0]).any():
        raise ParameterError("t", "needs at least two distinct times to observe the velocity")
    ls, tx, rx, sigma = validate_problem(l, tx, rx, sigma)
    n_t, p, d = tx.shape
    if n_t != t.size:
        raise ParameterError("tx", f"has {n_t} samples but t has {t.size}")
    tau = t - t[0]
    if x0 is None:
        starts = _track_starts(ls, tau, tx, rx, sigma, alpha)
    else:
        starts = as_array("x0", x0, (2 * d,))
        if starts.ndim != 1:
            raise ParameterError("x0", f"must have shape ({2 * d},), got {starts.shape}")
        starts = starts[None]

    def predict(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]  # (m, T, D)
        return range_sums(x, tx, rx).reshape(theta.shape[0], n_t * p)

    def jacobian(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]
        H = range_sum_jacobian(x, tx, rx)  # (m, T, P, D)
        H = np.concatenate([H, tau[:, None, None] * H], axis=-1)
        return H.reshape(theta.shape[0], n_t * p, 2 * d)

    m = starts.shape[0]
    fit = _gauss_newton(predict, jacobian, np.repeat(ls.reshape(1, -1), m, axis=0),
                        np.repeat(sigma.reshape(1, -1), m, axis=0), starts, max_iter, tol)
    best = int(np.argmin(fit.cost))
    dof = n_t * p - 2 * d
    cost = float(fit.cost[best])
    return TrajectorySolution(
        state=fit.theta[best],
        covariance=fit.covariance[best],
        t_ref=float(t[0]),
        residuals=fit.residuals[best].reshape(n_t, p),
        cost=cost,
        normalized_cost=cost / max(dof, 1),
        consistent=bool(cost <= _threshold(alpha, dof)),
        converged=bool(fit.converged[best]),
        iterations=int(fit.iterations[best]),
    )
