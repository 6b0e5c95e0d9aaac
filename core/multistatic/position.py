"""Maximum-likelihood single-shot positions from range sums (Fadeev et al., eqs. 4 and 6).

Fadeev, Myakinkov and Ogurtsov estimate the target position from range sums
l_p = |x - rx_p| + |x - tx_p| by maximum likelihood,

.. math:: \\hat{\\mathbf{x}} = \\arg\\min_{\\mathbf{x}} L(\\mathbf{x}), \\quad
          L(\\mathbf{x}) = [\\mathbf{l} - \\mathbf{h}(\\mathbf{x})]^T \\mathbf{G}
          [\\mathbf{l} - \\mathbf{h}(\\mathbf{x})], \\quad
          \\mathbf{G} = \\mathrm{diag}(1/\\sigma_p^2)

(eq. 4), iterating Gauss-Newton (eq. 6) with the compiled range-sum engine of
:mod:`plotgate.core.multistatic.gauss_newton`.

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
holds. ``consistent = cost <= chi2.ppf(1 - alpha, P - D)``
(:func:`plotgate.core.multistatic.gauss_newton.consistency_threshold`) flags a false local
minimum (the solver trapped on the wrong side of a baseline, or a mirror solution)
that does not fit the data. With P = D every solution fits exactly and the test has
nothing to test: consistent is True (as are all P <= D).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, cast

import numba
import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import ARRAY_1D, ARRAY_2D, ARRAY_3D, kernel, record, tuple_of
from plotgate.core.errors import ParameterError
from plotgate.core.multistatic.closed_form import (
    ROOT_WORK,
    ClosedFormSolution,
    RootWork,
    root_work,
    sum_range_roots,
    sum_range_roots_into,
    sum_range_roots_reference,
)
from plotgate.core.multistatic.gauss_newton import (
    CHUNK,
    MEASUREMENTS,
    PARALLEL_MIN,
    WORK,
    GaussNewtonFit,
    Measurements,
    Work,
    consistency_threshold,
    gauss_newton_reference,
    information_into,
    iterate,
    position_model,
    solver_options,
    start_points,
    work_space,
)
from plotgate.core.multistatic.information import inverse_information_into
from plotgate.core.multistatic.model import (
    COINCIDENT_RTOL,
    coerce_problem,
    coordinate_scale,
    copy_into,
    range_sums_unchecked,
    scale_of,
    valid_geometry,
    validate_problem_reference,
)

__all__ = [
    "RUNS",
    "SECOND_ROOT_COST",
    "MLSolution",
    "Runs",
    "closed_form_roots",
    "ml_solve",
    "ml_solve_reference",
    "run_space",
    "sum_range_starts",
]

SECOND_ROOT_COST = 100.0
"""A second closed-form root is not followed when its chi-square cost is above this
many times the consistency threshold while the first root's is within it."""

_TIE = 1e-9  # chi-square costs closer than this are a tie


@dataclass(frozen=True)
class MLSolution:
    """Maximum-likelihood positions of N range-sum problems (Fadeev et al., eqs. 4 and 6).

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


def sum_range_starts(
    ls: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    roots: Callable[[np.ndarray, np.ndarray, np.ndarray], ClosedFormSolution] = sum_range_roots,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sum-range closed-form starts: (x (N, D), alternative (N, D), has_alternative (N,)).

    ls (N, P), tx, rx (N, P, D) checked by
    :func:`plotgate.core.multistatic.model.validate_problem`. Uses the pairs of each problem's
    first transmitter (:func:`plotgate.core.multistatic.closed_form.sum_range_roots`);
    problems are grouped by which pairs those are (one group when every problem has a
    single transmitter). Problems whose first transmitter has fewer than D pairs start
    at the centroid of their platforms. ``roots`` is the closed form (the compiled one,
    or :func:`plotgate.core.multistatic.closed_form.sum_range_roots_reference`).
    """
    n, p, d = tx.shape
    tol = COINCIDENT_RTOL * coordinate_scale(tx, rx)
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
        sol = roots(ls[rows][:, pattern], np.repeat(tx[rows, :1], m, axis=1), rx[rows][:, pattern])
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
        r = (ls - range_sums_unchecked(x, tx, rx)) / sigma
        chi2: np.ndarray = np.einsum("np,np->n", r, r)
        return chi2

    return (cost(start) > threshold) | (cost(alt_start) <= SECOND_ROOT_COST * threshold)


def _best_and_alternative(
    fit: GaussNewtonFit, runs: np.ndarray, threshold: float
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


class Shots(NamedTuple):
    """N single-shot problems as the fused kernel reads them (coerced, not yet checked).

    data (N rows, tau zeros), sigma and allow (N, P) (metres a range sum may fall below
    its baseline), x0 (N, D) the user's starts or (0, D) without.
    """

    data: Measurements
    sigma: np.ndarray
    allow: np.ndarray
    x0: np.ndarray


SHOTS = record(Shots, MEASUREMENTS, ARRAY_2D, ARRAY_2D, ARRAY_2D)


class Settings(NamedTuple):
    """The options of a solve: iterations, tolerance, chi-square threshold, closed-form starts."""

    max_iter: int
    tol: float
    threshold: float
    closed_form_starts: bool


SETTINGS = record(Settings, numba.int64, numba.float64, numba.float64, numba.boolean)


class Solutions(NamedTuple):
    """The fused kernel's output: :class:`MLSolution`'s arrays, and which problems are valid."""

    x: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    alternative: np.ndarray
    has_alternative: np.ndarray
    valid: np.ndarray


SOLUTIONS = record(
    Solutions,
    *(ARRAY_2D, ARRAY_3D, ARRAY_2D, ARRAY_1D, numba.int64[::1], numba.boolean[::1]),
    *(ARRAY_2D, numba.boolean[::1], numba.boolean[::1]),
)


class Runs(NamedTuple):
    """Scratch space of one problem: its (at most 3) Gauss-Newton runs and its roots.

    theta (3, D), r (3, P), information (3, D, D), cost (3,), iterations (3,),
    converged (3,); l, tx, rx (P,), (P, D) the first transmitter's pairs; roots (2, D),
    root_residuals (2,) and root_flags (2,) of the closed form.
    """

    theta: np.ndarray
    r: np.ndarray
    information: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    l: np.ndarray  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray
    rx: np.ndarray
    roots: np.ndarray
    root_residuals: np.ndarray
    root_flags: np.ndarray


RUNS = record(
    Runs,
    *(ARRAY_2D, ARRAY_2D, ARRAY_3D, ARRAY_1D, numba.int64[::1], numba.boolean[::1]),
    *(ARRAY_1D, ARRAY_2D, ARRAY_2D, ARRAY_2D, ARRAY_1D, numba.boolean[::1]),
)


@kernel(RUNS(numba.int64, numba.int64))
def run_space(p: int, d: int) -> Runs:  # pragma: no cover (compiled)
    """:class:`Runs` of problems of p pairs in d dimensions."""
    return Runs(
        np.empty((3, d)),
        np.empty((3, p)),
        np.empty((3, d, d)),
        np.empty(3),
        np.empty(3, dtype=np.int64),
        np.empty(3, dtype=np.bool_),
        np.empty(p),
        np.empty((p, d)),
        np.empty((p, d)),
        np.empty((2, d)),
        np.empty(2),
        np.empty(2, dtype=np.bool_),
    )


@kernel(numba.float64(ARRAY_1D, ARRAY_1D, ARRAY_2D, ARRAY_2D, ARRAY_1D), inline=True)
def _chi_square(
    x: np.ndarray,
    l: np.ndarray,  # noqa: E741
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
) -> float:  # pragma: no cover (compiled)
    """sum_p ((l_p - h_p(x)) / sigma_p)^2 of one problem, as :func:`_worth_following`."""
    p, d = tx.shape
    total = 0.0
    for k in range(p):
        a = 0.0
        b = 0.0
        for i in range(d):
            a += (x[i] - rx[k, i]) * (x[i] - rx[k, i])
            b += (x[i] - tx[k, i]) * (x[i] - tx[k, i])
        e = (l[k] - (np.sqrt(a) + np.sqrt(b))) / sigma[k]
        total += e * e
    return total


@kernel(numba.boolean(ARRAY_1D, ARRAY_2D, ARRAY_2D, RUNS, ROOT_WORK), inline=True)
def closed_form_roots(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray,
    rx: np.ndarray,
    runs: Runs,
    work: RootWork,
) -> bool:  # pragma: no cover (compiled)
    """A problem's closed-form roots into runs.roots, as :func:`sum_range_starts`: a second?

    The roots of its first transmitter's pairs; the centroid of its platforms when that
    transmitter has fewer than D pairs.
    """
    pair_l, pair_tx, pair_rx, roots = runs.l, runs.tx, runs.rx, runs.roots
    p, d = tx.shape
    tol = COINCIDENT_RTOL * scale_of(tx, rx)
    m = 0
    for k in range(p):
        dist = 0.0
        for j in range(d):
            dist += (tx[k, j] - tx[0, j]) * (tx[k, j] - tx[0, j])
        if np.sqrt(dist) <= tol:
            pair_l[m] = l[k]
            copy_into(tx[0], pair_tx[m])
            copy_into(rx[k], pair_rx[m])
            m += 1
    if m < d:
        for j in range(d):
            st = 0.0
            sr = 0.0
            for k in range(p):
                st += tx[k, j]
                sr += rx[k, j]
            roots[0, j] = roots[1, j] = 0.5 * (st / p + sr / p)
        return False
    if m == p:
        sum_range_roots_into(
            pair_l, pair_tx, pair_rx, work, roots, runs.root_residuals, runs.root_flags
        )
    else:  # several transmitters: the first one's pairs, in the leading rows of the space
        pairs = RootWork(
            work.M[:m],
            work.U[:m],
            work.V,
            work.S,
            work.h[:m],
            work.a,
            work.c,
            work.s,
            work.x,
            work.R,
            work.consistent,
            work.residual,
            work.fallback,
        )
        sum_range_roots_into(
            pair_l[:m],
            pair_tx[:m],
            pair_rx[:m],
            pairs,
            roots,
            runs.root_residuals,
            runs.root_flags,
        )
    return bool(runs.root_flags[1])


@kernel(numba.int64(numba.int64, SHOTS, SETTINGS, RUNS, ROOT_WORK), inline=True)
def _starts(
    i: int, shots: Shots, settings: Settings, runs: Runs, work: RootWork
) -> int:  # pragma: no cover (compiled)
    """Problem i's starts into runs.theta, in order of preference on a tie: how many.

    x0, the closed form's primary root, then its second root where it is worth
    following (:func:`_worth_following`).
    """
    k = 0
    if shots.x0.shape[0] > 0:
        copy_into(shots.x0[i], runs.theta[k])
        k += 1
    if not settings.closed_form_starts:
        return k
    ls, tx, rx = shots.data.ls[i], shots.data.tx[i], shots.data.rx[i]
    second = closed_form_roots(ls, tx, rx, runs, work)
    copy_into(runs.roots[0], runs.theta[k])
    k += 1
    if second:
        sigma = shots.sigma[i]
        threshold = settings.threshold
        if _chi_square(runs.roots[0], ls, tx, rx, sigma) > threshold or (
            _chi_square(runs.roots[1], ls, tx, rx, sigma) <= SECOND_ROOT_COST * threshold
        ):
            copy_into(runs.roots[1], runs.theta[k])
            k += 1
    return k


@kernel(tuple_of(numba.int64, numba.int64)(numba.int64, RUNS, numba.float64), inline=True)
def _choice(k: int, runs: Runs, threshold: float) -> tuple[int, int]:  # pragma: no cover
    """The reported run and the alternative's (-1 for none), as :func:`_best_and_alternative`."""
    cost, theta, converged = runs.cost, runs.theta, runs.converged
    best = 0
    for j in range(1, k):
        if cost[j] + _TIE * (1.0 + cost[best]) < cost[best]:
            best = j
    d = theta.shape[1]
    J = runs.information[best]
    other = -1
    for j in range(k):
        q = 0.0
        for b in range(d):
            s = 0.0
            for a in range(d):
                s += (theta[j, a] - theta[best, a]) * J[a, b]
            q += s * (theta[j, b] - theta[best, b])
        if q > 1.0 and converged[j] and cost[j] <= threshold:
            if other < 0 or cost[j] < cost[other]:
                other = j
    return best, other


@kernel(numba.void(numba.int64, SHOTS, SETTINGS, SOLUTIONS, RUNS, WORK, ROOT_WORK), inline=True)
def _solve_one(
    i: int,
    shots: Shots,
    settings: Settings,
    out: Solutions,
    runs: Runs,
    work: Work,
    roots: RootWork,
) -> None:  # pragma: no cover (compiled)
    """Problem i of :func:`ml_solve`: its check, starts, runs and the choice among them."""
    ls, w, tx, rx, tau = shots.data
    sigma = shots.sigma[i]
    one = Measurements(ls[i], w[i], tx[i], rx[i], tau)
    out.valid[i] = valid_geometry(ls[i], sigma, tx[i], rx[i], shots.allow[i])
    k = _starts(i, shots, settings, runs, roots)
    theta, r, information = runs.theta, runs.r, runs.information
    for j in range(k):
        cost, it, conv = iterate(theta[j], one, r[j], work, settings.max_iter, settings.tol)
        runs.cost[j], runs.iterations[j], runs.converged[j] = cost, it, conv
        information_into(theta[j], one, work.Hw, information[j])
    best, other = _choice(k, runs, settings.threshold)
    copy_into(theta[best], out.x[i])
    out.cost[i] = runs.cost[best]
    out.iterations[i] = runs.iterations[best]
    out.converged[i] = runs.converged[best]
    residuals = out.residuals[i]
    for p in range(sigma.size):
        residuals[p] = r[best, p] * sigma[p]
    out.has_alternative[i] = other >= 0
    copy_into(theta[other] if other >= 0 else theta[best], out.alternative[i])
    inverse_information_into(
        information[best], out.covariance[i], work.square[0], work.vec[0], work.square[1]
    )


@kernel(
    numba.void(numba.int64, numba.int64, SHOTS, SETTINGS, SOLUTIONS, RUNS, WORK, ROOT_WORK),
    refcounts=False,
)
def _solve_range(
    lo: int,
    hi: int,
    shots: Shots,
    settings: Settings,
    out: Solutions,
    runs: Runs,
    work: Work,
    roots: RootWork,
) -> None:  # pragma: no cover (compiled)
    """Problems lo to hi - 1 of :func:`ml_solve`, one after the other, in the caller's
    scratch space (:func:`run_space`, ``work_space``, ``root_work``), counting no
    references."""
    for i in range(lo, hi):
        _solve_one(i, shots, settings, out, runs, work, roots)


@kernel(numba.void(SHOTS, SETTINGS, SOLUTIONS), parallel=True)
def _solve_parallel(
    shots: Shots, settings: Settings, out: Solutions
) -> None:  # pragma: no cover (compiled)
    """Every problem of :func:`ml_solve`, in chunks over a parallel loop."""
    n = out.x.shape[0]
    # a parallel loop takes flat records only: the nested one is rebuilt in each task
    ls, w, tx, rx, tau = shots.data
    sigma, allow, x0 = shots.sigma, shots.allow, shots.x0
    p, d = tx.shape[1:]
    for c in numba.prange((n + CHUNK - 1) // CHUNK):
        chunk = Shots(Measurements(ls, w, tx, rx, tau), sigma, allow, x0)
        runs, work, roots = run_space(p, d), work_space(p, d), root_work(p, d)
        _solve_range(c * CHUNK, min(n, (c + 1) * CHUNK), chunk, settings, out, runs, work, roots)


def ml_solve(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
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
    """Maximum-likelihood position from P range sums, N problems at once (Fadeev et al., eq. 6).

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
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (4) (the
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
    alpha, max_iter, tol = _options(alpha, max_iter, tol, x0, closed_form_starts)
    (ls, tx_, rx_, checked_sigma), allow = coerce_problem(l, tx, rx, sigma)
    sig = cast(np.ndarray, checked_sigma)  # given, so checked: never None
    n, p, d = tx_.shape
    threshold = consistency_threshold(alpha, p - d)
    with np.errstate(divide="ignore"):  # sigma = 0 is refused below, named by the reference
        w = 1.0 / sig
    shots = Shots(
        Measurements(ls, w, tx_, rx_, np.zeros(p)),
        sig,
        allow,
        np.zeros((0, d)) if x0 is None else np.ascontiguousarray(start_points(x0, n, d)),
    )
    out = Solutions(
        np.empty((n, d)),
        np.empty((n, d, d)),
        np.empty((n, p)),
        np.empty(n),
        np.empty(n, dtype=np.int64),
        np.empty(n, dtype=bool),
        np.empty((n, d)),
        np.empty(n, dtype=bool),
        np.empty(n, dtype=bool),
    )
    settings = Settings(max_iter, tol, threshold, bool(closed_form_starts))
    if n >= PARALLEL_MIN:
        _solve_parallel(shots, settings, out)
    else:
        _solve_range(
            0, n, shots, settings, out, run_space(p, d), work_space(p, d), root_work(p, d)
        )
    if not out.valid.all():  # the numpy checks name the field and the problem
        validate_problem_reference(l, tx, rx, sigma)
    return MLSolution(
        x=out.x,
        covariance=out.covariance,
        residuals=out.residuals,
        cost=out.cost,
        normalized_cost=out.cost / max(p - d, 1),
        consistent=out.cost <= threshold,
        iterations=out.iterations,
        converged=out.converged,
        alternative=out.alternative,
        has_alternative=out.has_alternative,
    )


def _options(
    alpha: float, max_iter: int, tol: float, x0: ArrayLike | None, closed_form_starts: bool
) -> tuple[float, int, float]:
    """Check ml_solve's options: (alpha, max_iter, tol)."""
    alpha, max_iter, tol = solver_options(alpha, max_iter, tol)
    if not isinstance(closed_form_starts, (bool, np.bool_)):
        raise ParameterError(
            "closed_form_starts", f"must be True or False, got {closed_form_starts!r}"
        )
    if x0 is None and not closed_form_starts:
        raise ParameterError(
            "closed_form_starts", "False needs x0: without a start the closed form is the only one"
        )
    return alpha, max_iter, tol


def ml_solve_reference(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
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
    """:func:`ml_solve` in numpy: the reference of its fused kernel.

    The same solve, each stage a batched numpy pass: the checks
    (:func:`plotgate.core.multistatic.model.validate_problem_reference`), the closed
    form's roots (:func:`plotgate.core.multistatic.closed_form.sum_range_roots_reference`),
    the second roots worth following, Gauss-Newton from every start
    (:func:`plotgate.core.multistatic.gauss_newton.gauss_newton_reference`) and the choice
    of the solution and its alternative.
    """
    alpha, max_iter, tol = _options(alpha, max_iter, tol, x0, closed_form_starts)
    ls, tx, rx, checked_sigma = validate_problem_reference(l, tx, rx, sigma)
    sigma = cast(np.ndarray, checked_sigma)  # given, so checked: never None
    n, p, d = tx.shape
    threshold = consistency_threshold(alpha, p - d)
    # the starts every problem has, in order of preference on a tie (x0, the closed
    # form's primary root), then the second roots worth following
    starts = [] if x0 is None else [start_points(x0, n, d)]
    second, seconds = np.zeros(0, dtype=int), np.zeros((0, d))
    if closed_form_starts:
        start, alt_start, has_alt_start = sum_range_starts(ls, tx, rx, sum_range_roots_reference)
        starts.append(start)
        second = np.flatnonzero(
            has_alt_start & _worth_following(ls, tx, rx, sigma, start, alt_start, threshold)
        )
        seconds = alt_start[second]
    k = len(starts)
    problem = np.concatenate([np.tile(np.arange(n), k), second])
    fit = gauss_newton_reference(
        *position_model(tx, rx, problem),
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
