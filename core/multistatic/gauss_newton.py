"""Batched weighted Gauss-Newton engine of the multistatic solves (Fadeev et al., eq. 6).

Fadeev, Myakinkov and Ogurtsov estimate parameters theta from range sums l by
maximum likelihood (eq. 4), minimising

.. math:: L(\\theta) = [\\mathbf{l} - \\mathbf{h}(\\theta)]^T \\mathbf{G}
          [\\mathbf{l} - \\mathbf{h}(\\theta)], \\quad
          \\mathbf{G} = \\mathrm{diag}(1/\\sigma_p^2),

by Gauss-Newton iterations (eq. 6)

.. math:: \\theta^{(i+1)} = \\theta^{(i)} + k\\,(\\mathbf{H}^T\\mathbf{G}
          \\mathbf{H})^{-1}\\mathbf{H}^T\\mathbf{G}[\\mathbf{l} -
          \\mathbf{h}(\\theta^{(i)})].

:func:`gauss_newton` runs them for n problems at once, whatever the model: a position
(:mod:`plotgate.core.multistatic.position`) or a constant-velocity track
(:mod:`plotgate.core.multistatic.trajectory`).

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

Compiled engine
---------------
:func:`gauss_newton` takes any model and is the reference. The solves use
:func:`range_sum_gauss_newton`, the same iteration and step control for the range-sum
model of a position or of a constant-velocity track, compiled (numba) and fused per
problem: each problem iterates alone to its convergence, the batch runs on every core.
The two agree to rounding (the tests hold them together on random batches and on the
degenerate cases).

Consistency
-----------
The cost at the minimum is chi-square with M - K degrees of freedom (M measurements,
K parameters) when the model holds; :func:`consistency_threshold` is the test's
threshold.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import kernel
from plotgate.core.errors import ParameterError
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.multistatic.information import (
    inverse_information,
    inverse_information_into,
    symmetric_eigh,
    symmetric_eigh_into,
)
from plotgate.core.multistatic.model import vector_norm
from plotgate.core.validation import as_array, as_probability, as_scalar, require_positive

__all__ = [
    "HALVINGS",
    "GaussNewtonFit",
    "Predict",
    "consistency_threshold",
    "gauss_newton",
    "range_sum_gauss_newton",
    "solver_options",
    "start_points",
]

HALVINGS = 12
"""Step lengths tried per Gauss-Newton iteration: k = 1, 1/2, ..., 2^-(HALVINGS-1)."""

_DAMPING_DECADES = 14  # Levenberg-Marquardt damping values tried per iteration
_DAMPING_START = 1e-3  # first damping, relative to the largest eigenvalue of H^T G H
_DECREASE_TOL = 1e-14  # converged: the Gauss-Newton step would lower the cost by less
_STALL_TOL = 1e-6  # a stalled problem converged if its GN step promised less than this
_CHUNK = 64  # problems per task of the compiled engine's parallel loop
_PARALLEL_MIN = 2048  # fewer problems run on one thread (waking the others costs more)


@dataclass
class GaussNewtonFit:
    """Minima of n weighted least-squares problems of M measurements, K parameters.

    Attributes
    ----------
    theta : (n, K) ndarray
        Parameters at the minimum.
    cost : (n,) ndarray
        Chi-square cost sum_m r_m^2 / sigma_m^2 at theta.
    residuals : (n, M) ndarray
        l - h(theta), in the measurements' units (metres).
    information : (n, K, K) ndarray
        H^T G H at theta.
    covariance : (n, K, K) ndarray
        Its floored inverse (:func:`plotgate.core.multistatic.information.inverse_information`).
    iterations : (n,) ndarray of int
        Gauss-Newton iterations (Jacobian evaluations).
    converged : (n,) ndarray of bool
        The problem met the convergence test within max_iter.
    """

    theta: np.ndarray
    cost: np.ndarray
    residuals: np.ndarray
    information: np.ndarray
    covariance: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray


Predict = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(theta (m, K), problem index (m,)) -> model range sums (m, M)."""


def gauss_newton(
    predict: Predict,
    jacobian: Predict,
    ls: np.ndarray,
    sigma: np.ndarray,
    theta0: np.ndarray,
    max_iter: int,
    tol: float,
) -> GaussNewtonFit:
    """Weighted Gauss-Newton with step halving and a Levenberg-Marquardt fallback.

    n problems of M measurements and K parameters at once (Fadeev et al., eq. 6, with
    the step control of the module notes); only the iterations loop.

    Parameters
    ----------
    predict, jacobian : Predict
        Model range sums (m, M) and their Jacobian (m, M, K) of parameters (m, K) of
        the problems with the given indices (m,).
    ls, sigma : (n, M) ndarray
        Measurements and their noise standard deviations, checked.
    theta0 : (n, K) ndarray
        Starts.
    max_iter : int
        Largest number of iterations, >= 1.
    tol : float
        Convergence when the step is below tol (1 + |theta|).

    Returns
    -------
    fit : GaussNewtonFit
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
        ev, V = symmetric_eigh(np.einsum("mpi,mpj->mij", Hs, Hs))
        gv = np.einsum("mki,mk->mi", V, g)
        keep = ev > 1e-12 * ev[:, -1:]
        gv_ev = np.divide(gv, ev, out=np.zeros_like(gv), where=keep)
        step = np.einsum("mik,mk->mi", V, gv_ev) / col
        # the cost decrease the Gauss-Newton model promises: g^T (H^T G H)^+ g
        promised = np.einsum("mk,mk->m", gv, gv_ev)
        small = (vector_norm(step) <= tol * (1.0 + vector_norm(th))) | (
            promised <= _DECREASE_TOL * (1.0 + cost[idx])
        )
        # Fadeev et al., eq. 6 with k = 1, 1/2, 1/4, ...; a converged problem still takes its
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
    return GaussNewtonFit(
        theta,
        cost,
        r * sigma,
        information,
        inverse_information(information),
        iterations,
        converged,
    )


@kernel(
    "float64(float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1], "
    "float64[::1], float64[::1])"
)
def _weighted_residuals(
    theta: np.ndarray,
    ls: np.ndarray,
    w: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    r: np.ndarray,
) -> float:  # pragma: no cover (compiled)
    """r = (l - h(theta)) w of one problem; returns the cost r^T r.

    theta is a position (K = D) or a track (x0, v) (K = 2D, x = x0 + tau v).
    """
    m, d = tx.shape
    moving = theta.size != d
    cost = 0.0
    for p in range(m):
        a = 0.0
        b = 0.0
        for i in range(d):
            x = theta[i] + tau[p] * theta[d + i] if moving else theta[i]
            a += (x - rx[p, i]) * (x - rx[p, i])
            b += (x - tx[p, i]) * (x - tx[p, i])
        r[p] = (ls[p] - (np.sqrt(a) + np.sqrt(b))) * w[p]
        cost += r[p] * r[p]
    return cost


@kernel(
    "void(float64[::1], float64[::1], float64[:, ::1], float64[:, ::1], float64[::1], "
    "float64[:, ::1])"
)
def _weighted_jacobian(
    theta: np.ndarray,
    w: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    Hw: np.ndarray,
) -> None:  # pragma: no cover (compiled)
    """Hw = dh/dtheta w (M, K) of one problem: unit vectors from the two foci (0 on one)."""
    m, d = tx.shape
    moving = theta.size != d
    for p in range(m):
        a = 0.0
        b = 0.0
        for i in range(d):
            x = theta[i] + tau[p] * theta[d + i] if moving else theta[i]
            a += (x - rx[p, i]) * (x - rx[p, i])
            b += (x - tx[p, i]) * (x - tx[p, i])
        a, b = np.sqrt(a), np.sqrt(b)
        for i in range(d):
            x = theta[i] + tau[p] * theta[d + i] if moving else theta[i]
            u = (x - rx[p, i]) / a if a > 0.0 else 0.0
            v = (x - tx[p, i]) / b if b > 0.0 else 0.0
            Hw[p, i] = (u + v) * w[p]
            if moving:
                Hw[p, d + i] = (tau[p] * (u + v)) * w[p]


@kernel(
    "void(int64, float64[:, ::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], "
    "float64[::1], int64[::1], float64[:, ::1], float64[:, ::1], float64[::1], int64[::1], "
    "boolean[::1], float64[:, :, ::1], float64[:, :, ::1], int64, float64, float64[:, ::1], "
    "float64[::1], float64[:, :, ::1], float64[:, ::1])"
)
def _solve_one(
    n: int,
    ls: np.ndarray,
    w: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    row: np.ndarray,
    theta: np.ndarray,
    r: np.ndarray,
    cost: np.ndarray,
    iterations: np.ndarray,
    converged: np.ndarray,
    information: np.ndarray,
    covariance: np.ndarray,
    max_iter: int,
    tol: float,
    Hw: np.ndarray,
    rt: np.ndarray,
    square: np.ndarray,
    vec: np.ndarray,
) -> None:  # pragma: no cover (compiled)
    """Problem n of :func:`range_sum_gauss_newton`, the step control of :func:`gauss_newton`.

    Hw (M, K), rt (M,), square (2, K, K) and vec (7, K) are scratch space.
    """
    k = theta.shape[1]
    m = ls.shape[1]
    j = row[n]
    lj, wj, txj, rxj = ls[j], w[j], tx[j], rx[j]
    th = theta[n]
    rn = r[n]
    c = _weighted_residuals(th, lj, wj, txj, rxj, tau, rn)
    mu = 0.0
    it = 0
    conv = False
    A, V = square[0], square[1]
    ev, col, g, gv, gv_ev, step, trial = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6]
    for _ in range(max_iter):
        it += 1
        _weighted_jacobian(th, wj, txj, rxj, tau, Hw)
        for a in range(k):
            s = 0.0
            for p in range(m):
                s += Hw[p, a] * Hw[p, a]
            s = np.sqrt(s)
            col[a] = s if s > 0.0 else 1.0
        for p in range(m):
            for a in range(k):
                Hw[p, a] /= col[a]
        for a in range(k):
            s = 0.0
            for p in range(m):
                s += Hw[p, a] * rn[p]
            g[a] = s
            for b in range(k):
                s = 0.0
                for p in range(m):
                    s += Hw[p, a] * Hw[p, b]
                A[a, b] = s
        symmetric_eigh_into(A, ev, V)
        promised = 0.0
        for a in range(k):
            s = 0.0
            for b in range(k):
                s += V[b, a] * g[b]
            gv[a] = s
            gv_ev[a] = s / ev[a] if ev[a] > 1e-12 * ev[k - 1] else 0.0
            promised += gv[a] * gv_ev[a]
        step_norm = 0.0
        th_norm = 0.0
        for a in range(k):
            s = 0.0
            for b in range(k):
                s += V[a, b] * gv_ev[b]
            step[a] = s / col[a]
            step_norm += step[a] * step[a]
            th_norm += th[a] * th[a]
        small = np.sqrt(step_norm) <= tol * (
            1.0 + np.sqrt(th_norm)
        ) or promised <= _DECREASE_TOL * (1.0 + c)
        ok = False
        for h in range(HALVINGS):
            for a in range(k):
                trial[a] = th[a] + step[a] if h == 0 else th[a] + 0.5**h * step[a]
            ct = _weighted_residuals(trial, lj, wj, txj, rxj, tau, rt)
            if ct < c:
                th[:] = trial
                rn[:] = rt
                c = ct
                ok = True
                break
        if small:
            conv = True
            break
        if ok:
            continue
        # Levenberg-Marquardt: the smallest damping (in decades) that lowers the cost
        top = max(ev[k - 1], np.finfo(np.float64).tiny)
        start = mu / 10.0 if mu > 0.0 else _DAMPING_START
        for h in range(_DAMPING_DECADES):
            damp = (start * 10.0**h) * top
            for a in range(k):
                s = 0.0
                for b in range(k):
                    s += V[a, b] * (gv[b] / (ev[b] + damp))
                trial[a] = th[a] + s / col[a]
            ct = _weighted_residuals(trial, lj, wj, txj, rxj, tau, rt)
            if ct < c:
                th[:] = trial
                rn[:] = rt
                c = ct
                mu = start * 10.0**h
                ok = True
                break
        if not ok:  # stalled: a minimum if Gauss-Newton promised little
            conv = promised <= _STALL_TOL * (1.0 + c)
            break
    cost[n] = c
    iterations[n] = it
    converged[n] = conv
    _weighted_jacobian(th, wj, txj, rxj, tau, Hw)
    for a in range(k):
        for b in range(k):
            s = 0.0
            for p in range(m):
                s += Hw[p, a] * Hw[p, b]
            information[n, a, b] = s
    inverse_information_into(information[n], covariance[n], A, ev, V)


@kernel(
    "void(int64, int64, "
    "float64[:, ::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], "
    "float64[::1], int64[::1], float64[:, ::1], float64[:, ::1], float64[::1], int64[::1], "
    "boolean[::1], float64[:, :, ::1], float64[:, :, ::1], int64, float64)"
)
def _solve_range(
    lo: int,
    hi: int,
    ls: np.ndarray,
    w: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    row: np.ndarray,
    theta: np.ndarray,
    r: np.ndarray,
    cost: np.ndarray,
    iterations: np.ndarray,
    converged: np.ndarray,
    information: np.ndarray,
    covariance: np.ndarray,
    max_iter: int,
    tol: float,
) -> None:  # pragma: no cover (compiled)
    """Problems lo to hi - 1 of :func:`range_sum_gauss_newton`, one after the other."""
    k = theta.shape[1]
    m = ls.shape[1]
    Hw = np.empty((m, k))
    rt = np.empty(m)
    square = np.empty((2, k, k))
    vec = np.empty((7, k))
    for i in range(lo, hi):
        _solve_one(
            i,
            ls,
            w,
            tx,
            rx,
            tau,
            row,
            theta,
            r,
            cost,
            iterations,
            converged,
            information,
            covariance,
            max_iter,
            tol,
            Hw,
            rt,
            square,
            vec,
        )


@kernel(
    "void("
    "float64[:, ::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], "
    "float64[::1], int64[::1], float64[:, ::1], float64[:, ::1], float64[::1], int64[::1], "
    "boolean[::1], float64[:, :, ::1], float64[:, :, ::1], int64, float64)",
    parallel=True,
)
def _solve_parallel(
    ls: np.ndarray,
    w: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    row: np.ndarray,
    theta: np.ndarray,
    r: np.ndarray,
    cost: np.ndarray,
    iterations: np.ndarray,
    converged: np.ndarray,
    information: np.ndarray,
    covariance: np.ndarray,
    max_iter: int,
    tol: float,
) -> None:  # pragma: no cover (compiled)
    """Every problem of :func:`range_sum_gauss_newton`, in chunks over a parallel loop."""
    n = theta.shape[0]
    for c in numba.prange((n + _CHUNK - 1) // _CHUNK):
        _solve_range(
            c * _CHUNK,
            min(n, (c + 1) * _CHUNK),
            ls,
            w,
            tx,
            rx,
            tau,
            row,
            theta,
            r,
            cost,
            iterations,
            converged,
            information,
            covariance,
            max_iter,
            tol,
        )


def range_sum_gauss_newton(
    ls: np.ndarray,
    sigma: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    tau: np.ndarray,
    row: np.ndarray,
    theta0: np.ndarray,
    max_iter: int,
    tol: float,
) -> GaussNewtonFit:
    """:func:`gauss_newton` of the range-sum model, compiled: positions or tracks.

    Problem n fits the M range sums of data row ``row[n]`` from ``theta0[n]``: a
    position x (K = D), h_m = |x - rx_m| + |x - tx_m| (Fadeev et al., eq. 1), or a
    constant-velocity track (x0, v) (K = 2D), x = x0 + tau_m v. Several problems may
    share a data row (several starts of one problem). The iteration and its step
    control are those of :func:`gauss_newton`, per problem.

    Parameters
    ----------
    ls, sigma : (R, M) ndarray
        Measurements and noise standard deviations of R data rows, checked.
    tx, rx : (R, M, D) ndarray
        Transmitter and receiver of every measurement.
    tau : (M,) ndarray
        Time of each measurement after the track's reference time (unused for K = D).
    row : (n,) ndarray of int
        Data row of each problem.
    theta0 : (n, K) ndarray
        Starts.
    max_iter, tol :
        As :func:`gauss_newton`.

    Returns
    -------
    fit : GaussNewtonFit
    """
    n, k = theta0.shape
    m = ls.shape[1]
    theta = np.array(theta0, dtype=float, order="C")
    r = np.empty((n, m))
    cost = np.empty(n)
    iterations = np.empty(n, dtype=np.int64)
    converged = np.empty(n, dtype=bool)
    information = np.empty((n, k, k))
    covariance = np.empty((n, k, k))
    sigma = np.ascontiguousarray(sigma, dtype=float)
    data = (
        np.ascontiguousarray(ls, dtype=float),
        1.0 / sigma,
        np.ascontiguousarray(tx, dtype=float),
        np.ascontiguousarray(rx, dtype=float),
        np.ascontiguousarray(tau, dtype=float),
        np.ascontiguousarray(row, dtype=np.int64),
        theta,
        r,
        cost,
        iterations,
        converged,
        information,
        covariance,
        max_iter,
        tol,
    )
    if n >= _PARALLEL_MIN:
        _solve_parallel(*data)
    else:
        _solve_range(0, n, *data)
    return GaussNewtonFit(
        theta,
        cost,
        r * sigma[row],
        information,
        covariance,
        iterations,
        converged,
    )


def solver_options(alpha: float, max_iter: int, tol: float) -> tuple[float, int, float]:
    """Check the options the solves share: alpha in (0, 1), max_iter >= 1, tol > 0.

    Raises
    ------
    ParameterError
        Naming ``"alpha"``, ``"max_iter"`` or ``"tol"``.
    """
    alpha = float(as_probability("alpha", as_scalar("alpha", alpha)))
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ParameterError("max_iter", f"must be an integer >= 1, got {max_iter!r}")
    tol = as_scalar("tol", tol)
    require_positive("tol", tol)
    return alpha, int(max_iter), tol


def consistency_threshold(alpha: float, dof: int) -> float:
    """Chi-square threshold of the consistency test: F^-1(1 - alpha) with dof degrees.

    :func:`plotgate.core.gates.thresholds.gate_threshold` of 1 - alpha; +inf (every fit
    consistent) without redundancy (dof <= 0), and when alpha is below the float
    spacing at 1, where 1 - alpha rounds to 1.
    """
    if dof <= 0 or 1.0 - alpha >= 1.0:
        return np.inf
    return float(gate_threshold(1.0 - alpha, dof))


def start_points(x0: ArrayLike, n: int, d: int, name: str = "x0") -> np.ndarray:
    """A user start (K,) or (N, K) as an (N, K) array (``d`` = K parameters).

    Raises
    ------
    NonFiniteError, ParameterError
        Naming ``name`` when it is not finite or not (K,) or (N, K).
    """
    x0 = as_array(name, x0, (d,))
    if x0.ndim > 2 or (x0.ndim == 2 and x0.shape[0] != n):
        raise ParameterError(name, f"must have shape ({d},) or ({n}, {d}), got {x0.shape}")
    return np.array(np.broadcast_to(x0, (n, d)))
