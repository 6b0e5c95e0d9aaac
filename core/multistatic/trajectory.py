"""Maximum-likelihood constant-velocity tracks from samples of range sums (Fadeev et al.).

The same compiled Gauss-Newton engine as the single-shot position
(:func:`plotgate.core.multistatic.gauss_newton.gauss_newton`, Fadeev et al.,
eq. 6) fits a constant-velocity track to T samples (the paper's accumulated measurement vector,
eq. 2): parameters (x0, v) with x(t) = x0 + v (t - t_ref). Its default start is
:func:`plotgate.core.multistatic.track_start.track_starts` on START_SAMPLES samples
spread over the track, fitted to their range sums: solving every sample alone cost more
than the whole fit from a given start.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError
from plotgate.core.multistatic.gauss_newton import (
    consistency_threshold,
    gauss_newton,
    solver_options,
    start_points,
)
from plotgate.core.multistatic.information import position_covariance
from plotgate.core.multistatic.model import (
    array_shape,
    validate_problem,
    with_tx_axis,
)
from plotgate.core.multistatic.track_start import track_starts
from plotgate.core.validation import as_array

__all__ = ["START_SAMPLES", "TrajectorySolution", "trajectory_solve"]

START_SAMPLES = 16
"""Samples of a track (evenly spread over its times) its default start is fitted to."""


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
            position_covariance(self.covariance, tau),
        )


def _per_sample(name: str, value: ArrayLike, n: int, n_t: int, core_ndim: int) -> ArrayLike:
    """A per-sample (T, ...) or per-track (N, T, ...) argument as (N T, ...) rows.

    Arguments with at most ``core_ndim`` axes (fixed platforms, one sigma per pair)
    pass through unchanged for :func:`validate_problem` to broadcast.
    """
    shape = tuple(array_shape(name, value))
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


def _subset_starts(
    ls: np.ndarray,
    tau: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    sigma: np.ndarray,
    alpha: float,
    max_iter: int,
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(x0, v) starts of N tracks from START_SAMPLES of their samples: (starts, track of each).

    ls, sigma (N, T, P), tx, rx (N, T, P, D) checked, tau (T,). The samples at
    START_SAMPLES evenly spaced ranks of time (the first and the last among them) get
    :func:`plotgate.core.multistatic.track_start.track_starts`' lines, and each line is
    fitted by Gauss-Newton to those samples' range sums (eq. 6 over the subset's
    accumulated vector, eq. 2): a start near the whole track's minimum for a tenth of the
    per-sample solves. Tracks of at most START_SAMPLES samples use them all, unfitted.
    """
    n, n_t, p, d = tx.shape
    if n_t <= START_SAMPLES:
        return track_starts(ls, tau, tx, rx, sigma, alpha)
    order = np.argsort(tau, kind="stable")
    sub = np.sort(order[np.round(np.linspace(0.0, n_t - 1.0, START_SAMPLES)).astype(int)])
    ls, tx, rx, sigma = ls[:, sub], tx[:, sub], rx[:, sub], sigma[:, sub]
    starts, owner = track_starts(ls, tau[sub], tx, rx, sigma, alpha)
    fit = gauss_newton(
        ls.reshape(n, -1),
        sigma.reshape(n, -1),
        tx.reshape(n, -1, d),
        rx.reshape(n, -1, d),
        np.repeat(tau[sub], p),
        owner,
        starts,
        max_iter,
        tol,
    )
    return fit.theta, owner


def trajectory_solve(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    t: ArrayLike,
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike,
    x0: ArrayLike | None = None,
    alpha: float = 0.01,
    max_iter: int = 50,
    tol: float = 1e-9,
) -> TrajectorySolution:
    """Maximum-likelihood constant-velocity tracks from T samples of range sums (Fadeev et al.).

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
        Start state (position at t[0], velocity). Default: on START_SAMPLES samples
        spread over the track's times, a straight line fitted to their per-sample
        :func:`ml_solve` positions, weighted by their information, then fitted to
        their range sums (two variants when samples have two solutions; the lower
        final cost wins).
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
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eqs. (2), (4), (6):
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
    alpha, max_iter, tol = solver_options(alpha, max_iter, tol)
    t = as_array("t", t)
    if t.ndim != 1:
        raise ParameterError("t", f"must have shape (T,), got {t.shape}")
    l_shape = tuple(array_shape("l", l))
    if len(l_shape) not in (2, 3) or l_shape[-2] != t.size:
        raise ParameterError(
            "l",
            f"must have shape (T, P) or (N, T, P) with T = {t.size} samples as t, got {l_shape}",
        )
    if t.size < 2 or not (t != t[0]).any():
        raise ParameterError("t", "needs at least two distinct times to observe the velocity")
    n, n_t = (l_shape[0] if len(l_shape) == 3 else 1), t.size
    tx = _per_sample("tx", with_tx_axis(tx), n, n_t, 2)
    rx = _per_sample("rx", rx, n, n_t, 2)
    sigma = _per_sample("sigma", sigma, n, n_t, 1)
    ls, tx, rx, checked_sigma = validate_problem(np.reshape(l, (n * n_t, -1)), tx, rx, sigma)
    p, d = tx.shape[1:]
    ls, sigma = ls.reshape(n, n_t, p), cast(np.ndarray, checked_sigma).reshape(n, n_t, p)
    tx, rx = tx.reshape(n, n_t, p, d), rx.reshape(n, n_t, p, d)
    tau = t - t[0]
    if x0 is None:
        starts, owner = _subset_starts(ls, tau, tx, rx, sigma, alpha, max_iter, tol)
    else:
        starts, owner = start_points(x0, n, 2 * d), np.arange(n)

    fit = gauss_newton(
        ls.reshape(n, n_t * p),
        sigma.reshape(n, n_t * p),
        tx.reshape(n, n_t * p, d),
        rx.reshape(n, n_t * p, d),
        np.repeat(tau, p),
        owner,
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
        consistent=cost <= consistency_threshold(alpha, dof),
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
        cost=float(np.asarray(sol.cost)[0]),
        normalized_cost=float(np.asarray(sol.normalized_cost)[0]),
        consistent=bool(np.asarray(sol.consistent)[0]),
        converged=bool(np.asarray(sol.converged)[0]),
        iterations=int(np.asarray(sol.iterations)[0]),
    )
