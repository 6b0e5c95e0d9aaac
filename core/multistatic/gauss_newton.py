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

:func:`gauss_newton` runs them for n problems at once, for the range-sum model of a
position (:mod:`plotgate.core.multistatic.position`) or of a constant-velocity track
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
1e-6 (1 + L) there.

Compiled engine and reference
-----------------------------
:func:`gauss_newton` is compiled (numba) and fused per run: each run iterates alone to
its convergence through :func:`iterate`, the one compiled copy of the step control,
which the fused single shot and the track start call as well; a large batch runs on
every core. :func:`gauss_newton_reference` takes any model in numpy, iterating the
problems together with per-problem masks, and is the oracle the tests hold the engine
to: the two agree to rounding, with the same iterations on the study's problems. The
rules the two share (step lengths, dampings, the convergence and stall tests, which
eigenvalues a step uses) are written once, as numba ufuncs (:func:`converged_step`,
:func:`stalled_at_minimum`, :func:`resolved`, :func:`first_damping`) and constants
(``STEP_LENGTHS``, ``DAMPINGS``) that the kernel calls on scalars and the reference on
arrays; only the loop around them differs (one run against a masked batch). The
kernels take their arrays as records (:class:`Measurements`, :class:`Fits`,
:class:`Work`), so each signature is stated once.

Consistency
-----------
The cost at the minimum is chi-square with M - K degrees of freedom (M measurements,
K parameters) when the model holds; :func:`consistency_threshold` is the test's
threshold.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import ARRAY_1D, ARRAY_2D, ARRAY_3D, kernel, record, rule, tuple_of
from plotgate.core.errors import ParameterError
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.multistatic.information import (
    inverse_information,
    inverse_information_into,
    symmetric_eigh,
    symmetric_eigh_into,
)
from plotgate.core.multistatic.model import (
    copy_into,
    range_sum_jacobian_unchecked,
    range_sums_unchecked,
    vector_norm,
)
from plotgate.core.validation import as_array, as_probability, as_scalar, require_positive

__all__ = [
    "CHUNK",
    "DAMPINGS",
    "FITS",
    "HALVINGS",
    "MEASUREMENTS",
    "PARALLEL_MIN",
    "ROW",
    "STEP_LENGTHS",
    "WORK",
    "Fits",
    "GaussNewtonFit",
    "Measurements",
    "Predict",
    "Work",
    "consistency_threshold",
    "converged_step",
    "first_damping",
    "gauss_newton",
    "gauss_newton_reference",
    "information_into",
    "iterate",
    "measurements",
    "position_model",
    "resolved",
    "solver_options",
    "stalled_at_minimum",
    "start_points",
    "weighted_jacobian",
    "weighted_residuals",
    "work_space",
]

HALVINGS = 12
"""Step lengths tried per Gauss-Newton iteration: k = 1, 1/2, ..., 2^-(HALVINGS-1)."""

STEP_LENGTHS = 0.5 ** np.arange(HALVINGS)
"""The step factors k of eq. 6, in the order they are tried."""

DAMPINGS = 10.0 ** np.arange(14)
"""Levenberg-Marquardt dampings tried per iteration, times the first one."""

_DAMPING_START = 1e-3  # first damping, relative to the largest eigenvalue of H^T G H
_DECREASE_TOL = 1e-14  # converged: the Gauss-Newton step would lower the cost by less
_STALL_TOL = 1e-6  # a stalled problem converged if its GN step promised less than this
_RESOLVED_RTOL = 1e-12  # eigenvalues of H^T G H below this times the largest are dropped
CHUNK = 64
"""Problems per task of a compiled solve's parallel loop."""
PARALLEL_MIN = 2048
"""Fewer problems than this run on one thread (waking the others costs more)."""


# The rules of the step control, written once: the compiled engine calls them on the
# scalars of one run, the numpy reference on the arrays of its batch.


@rule("boolean(float64, float64, float64, float64, float64)")
def converged_step(
    step_norm: float, theta_norm: float, promised: float, cost: float, tol: float
) -> bool:  # pragma: no cover (compiled)
    """The run has converged: its Gauss-Newton step is below tol (1 + |theta|), or it
    would lower the cost by less than 1e-14 (1 + L)."""
    return step_norm <= tol * (1.0 + theta_norm) or promised <= _DECREASE_TOL * (1.0 + cost)


@rule("boolean(float64, float64)")
def stalled_at_minimum(promised: float, cost: float) -> bool:  # pragma: no cover (compiled)
    """A run no damped step improves is at a minimum if Gauss-Newton promised little there."""
    return promised <= _STALL_TOL * (1.0 + cost)


@rule("boolean(float64, float64)")
def resolved(eigenvalue: float, largest: float) -> bool:  # pragma: no cover (compiled)
    """An eigenvalue of H^T G H the step uses: above 1e-12 times the largest."""
    return eigenvalue > _RESOLVED_RTOL * largest


@rule("float64(float64)")
def first_damping(mu: float) -> float:  # pragma: no cover (compiled)
    """The first Levenberg-Marquardt damping (relative) tried: a decade below the last one
    that worked, or 1e-3 when none has yet."""
    return mu / 10.0 if mu > 0.0 else _DAMPING_START


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


def position_model(tx: np.ndarray, rx: np.ndarray, row: np.ndarray) -> tuple[Predict, Predict]:
    """The range sums of positions and their Jacobian, for :func:`gauss_newton_reference`.

    Problem n has the platforms tx[row[n]], rx[row[n]] (R, P, D) (several starts of one
    problem share its row).
    """

    def predict(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return range_sums_unchecked(theta, tx[row[idx]], rx[row[idx]])

    def jacobian(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return range_sum_jacobian_unchecked(theta, tx[row[idx]], rx[row[idx]])

    return predict, jacobian


def gauss_newton_reference(
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
        keep = resolved(ev, ev[:, -1:])
        gv_ev = np.divide(gv, ev, out=np.zeros_like(gv), where=keep)
        step = np.einsum("mik,mk->mi", V, gv_ev) / col
        # the cost decrease the Gauss-Newton model promises: g^T (H^T G H)^+ g
        promised = np.einsum("mk,mk->m", gv, gv_ev)
        small = converged_step(vector_norm(step), vector_norm(th), promised, cost[idx], tol)
        # Fadeev et al., eq. 6 with k = 1, 1/2, 1/4, ...; a converged problem still takes its
        # last (small) step when that lowers the cost
        ok, _ = try_steps(idx, th[:, None, :] + step[:, None, :])  # k = 1 first
        if not ok.all():
            bad = np.flatnonzero(~ok)
            trials = th[bad, None, :] + STEP_LENGTHS[None, 1:, None] * step[bad, None, :]
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
        start = first_damping(mu[idx])
        damp = (start[:, None] * DAMPINGS[None, :]) * top[:, None]  # (m, J)
        steps = np.einsum("mik,mjk->mji", V, gv[:, None, :] / (ev[:, None, :] + damp[..., None]))
        trials = th[:, None, :] + steps / col[:, None, :]
        ok, pick = try_steps(idx, trials)
        mu[idx[ok]] = start[ok] * DAMPINGS[pick[ok]]
        # stalled: no step lowers the cost (rounding); a minimum if GN promised little
        stalled = idx[~ok]
        active[stalled] = False
        converged[stalled] = stalled_at_minimum(promised[~ok], cost[stalled])

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


class Measurements(NamedTuple):
    """Range sums as the compiled engine reads them: C-contiguous float64 arrays.

    A batch has R data rows: ls, w (R, M), tx, rx (R, M, D); one problem's row has
    ls, w (M,), tx, rx (M, D). ``w`` is 1 / sigma; ``tau`` (M,) is each measurement's
    time after the track's reference time (zeros for a position).
    """

    ls: np.ndarray
    w: np.ndarray
    tx: np.ndarray
    rx: np.ndarray
    tau: np.ndarray


MEASUREMENTS = record(Measurements, ARRAY_2D, ARRAY_2D, ARRAY_3D, ARRAY_3D, ARRAY_1D)
"""numba type of a batch of :class:`Measurements`."""
ROW = record(Measurements, ARRAY_1D, ARRAY_1D, ARRAY_2D, ARRAY_2D, ARRAY_1D)
"""numba type of one problem's :class:`Measurements`."""


class Fits(NamedTuple):
    """The compiled engine's output arrays of n runs (the fields of :class:`GaussNewtonFit`).

    theta (n, K), r (n, M) weighted residuals (l - h) w, cost (n,), iterations (n,)
    int64, converged (n,) bool, information and covariance (n, K, K).
    """

    theta: np.ndarray
    r: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    information: np.ndarray
    covariance: np.ndarray


FITS = record(
    Fits,
    ARRAY_2D,
    ARRAY_2D,
    ARRAY_1D,
    numba.int64[::1],
    numba.boolean[::1],
    ARRAY_3D,
    ARRAY_3D,
)
"""numba type of :class:`Fits`."""


class Work(NamedTuple):
    """Scratch space of one run of M measurements and K parameters.

    Hw (M, K) the weighted Jacobian, rt (M,) a trial's residuals, square (2, K, K) and
    vec (7, K) the normal equations, their eigen-decomposition and the steps.
    """

    Hw: np.ndarray
    rt: np.ndarray
    square: np.ndarray
    vec: np.ndarray


WORK = record(Work, ARRAY_2D, ARRAY_1D, ARRAY_3D, ARRAY_2D)
"""numba type of :class:`Work`."""


@kernel(WORK(numba.int64, numba.int64))
def work_space(m: int, k: int) -> Work:  # pragma: no cover (compiled)
    """:class:`Work` for runs of m measurements and k parameters."""
    return Work(np.empty((m, k)), np.empty(m), np.empty((2, k, k)), np.empty((7, k)))


@kernel(numba.float64(ARRAY_1D, ROW, ARRAY_1D), inline=True)
def weighted_residuals(
    theta: np.ndarray, row: Measurements, r: np.ndarray
) -> float:  # pragma: no cover (compiled)
    """r = (l - h(theta)) w of one problem; returns the cost r^T r.

    theta is a position (K = D) or a track (x0, v) (K = 2D, x = x0 + tau v).
    """
    ls, w, tx, rx, tau = row  # fields read once: each read of a record's field counts a reference
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


@kernel(numba.void(ARRAY_1D, ROW, ARRAY_2D), inline=True)
def weighted_jacobian(
    theta: np.ndarray, row: Measurements, Hw: np.ndarray
) -> None:  # pragma: no cover (compiled)
    """Hw = dh/dtheta w (M, K) of one problem: unit vectors from the two foci (0 on one)."""
    _, w, tx, rx, tau = row
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


@kernel(numba.void(ARRAY_1D, ROW, ARRAY_1D, WORK), inline=True)
def _scaled_normal_equations(
    theta: np.ndarray, row: Measurements, r: np.ndarray, work: Work
) -> None:  # pragma: no cover (compiled)
    """A = Hs^T Hs and g = Hs^T r of the column-scaled Jacobian Hs = Hw / col.

    Into work.square[0] (A), work.vec[1] (col) and work.vec[2] (g). Each sum runs over
    the measurements in order, in a scalar (a register: accumulating into the work
    arrays, which may alias, was a third slower).
    """
    Hw, A, col, g = work.Hw, work.square[0], work.vec[1], work.vec[2]
    m, k = Hw.shape
    weighted_jacobian(theta, row, Hw)
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
            s += Hw[p, a] * r[p]
        g[a] = s
        for b in range(k):
            s = 0.0
            for p in range(m):
                s += Hw[p, a] * Hw[p, b]
            A[a, b] = s


@kernel(
    tuple_of(numba.boolean, numba.float64)(ARRAY_1D, ROW, ARRAY_1D, ARRAY_1D, numba.float64, WORK),
    inline=True,
)
def _lower(
    trial: np.ndarray, row: Measurements, theta: np.ndarray, r: np.ndarray, cost: float, work: Work
) -> tuple[bool, float]:  # pragma: no cover (compiled)
    """Move theta (and its residuals r) to the trial if it lowers the cost: (moved, cost)."""
    rt = work.rt
    trial_cost = weighted_residuals(trial, row, rt)
    if trial_cost < cost:
        copy_into(trial, theta)
        copy_into(rt, r)
        return True, trial_cost
    return False, cost


@kernel(
    tuple_of(numba.float64, numba.int64, numba.boolean)(
        ARRAY_1D, ROW, ARRAY_1D, WORK, numba.int64, numba.float64
    ),
    inline=True,
)
def iterate(
    theta: np.ndarray, row: Measurements, r: np.ndarray, work: Work, max_iter: int, tol: float
) -> tuple[float, int, bool]:  # pragma: no cover (compiled)
    """One run of the step control of the module notes, in place: (cost, iterations, converged).

    The only compiled copy of the step control: every compiled solve (a batch of
    positions or tracks, the fused single shot, the track start) iterates through it.
    theta (K,) is the start and becomes the minimum, r (M,) its weighted residuals.
    """
    k = theta.size
    A, V = work.square[0], work.square[1]
    vec = work.vec
    ev, col, g, gv, gv_ev, step, trial = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6]
    cost = weighted_residuals(theta, row, r)
    mu = 0.0
    it = 0
    for _ in range(max_iter):
        it += 1
        _scaled_normal_equations(theta, row, r, work)
        symmetric_eigh_into(A, ev, V)
        promised = 0.0
        for a in range(k):
            s = 0.0
            for b in range(k):
                s += V[b, a] * g[b]
            gv[a] = s
            gv_ev[a] = s / ev[a] if resolved(ev[a], ev[k - 1]) else 0.0
            promised += gv[a] * gv_ev[a]
        step_norm = 0.0
        theta_norm = 0.0
        for a in range(k):
            s = 0.0
            for b in range(k):
                s += V[a, b] * gv_ev[b]
            step[a] = s / col[a]
            step_norm += step[a] * step[a]
            theta_norm += theta[a] * theta[a]
        small = converged_step(np.sqrt(step_norm), np.sqrt(theta_norm), promised, cost, tol)
        moved = False
        for h in range(HALVINGS):  # Fadeev et al., eq. 6 with k = 1, 1/2, 1/4, ...
            for a in range(k):
                trial[a] = theta[a] + STEP_LENGTHS[h] * step[a]
            moved, cost = _lower(trial, row, theta, r, cost, work)
            if moved:
                break
        if small:
            return cost, it, True
        if moved:
            continue
        # Levenberg-Marquardt: the smallest damping (in decades) that lowers the cost
        top = max(ev[k - 1], np.finfo(np.float64).tiny)
        start = first_damping(mu)
        for h in range(DAMPINGS.size):
            damp = (start * DAMPINGS[h]) * top
            for a in range(k):
                s = 0.0
                for b in range(k):
                    s += V[a, b] * (gv[b] / (ev[b] + damp))
                trial[a] = theta[a] + s / col[a]
            moved, cost = _lower(trial, row, theta, r, cost, work)
            if moved:
                mu = start * DAMPINGS[h]
                break
        if not moved:  # stalled: a minimum if Gauss-Newton promised little
            return cost, it, stalled_at_minimum(promised, cost)
    return cost, it, False


@kernel(numba.void(ARRAY_1D, ROW, ARRAY_2D, ARRAY_2D), inline=True)
def information_into(
    theta: np.ndarray, row: Measurements, Hw: np.ndarray, J: np.ndarray
) -> None:  # pragma: no cover (compiled)
    """J = Hw^T Hw (K, K), the information H^T G H at theta; Hw (M, K) is scratch."""
    weighted_jacobian(theta, row, Hw)
    m, k = Hw.shape
    for a in range(k):
        for b in range(k):
            s = 0.0
            for p in range(m):
                s += Hw[p, a] * Hw[p, b]
            J[a, b] = s


@kernel(
    numba.void(
        numba.int64, numba.int64, MEASUREMENTS, numba.int64[::1], FITS, numba.int64, numba.float64
    )
)
def _fit_range(
    lo: int, hi: int, data: Measurements, row: np.ndarray, fits: Fits, max_iter: int, tol: float
) -> None:  # pragma: no cover (compiled)
    """Runs lo to hi - 1 of :func:`gauss_newton`, one after the other."""
    k = fits.theta.shape[1]
    work = work_space(data.ls.shape[1], k)
    A, ev, V = work.square[0], work.vec[0], work.square[1]
    for n in range(lo, hi):
        j = row[n]
        one = Measurements(data.ls[j], data.w[j], data.tx[j], data.rx[j], data.tau)
        theta = fits.theta[n]
        cost, it, conv = iterate(theta, one, fits.r[n], work, max_iter, tol)
        fits.cost[n] = cost
        fits.iterations[n] = it
        fits.converged[n] = conv
        information_into(theta, one, work.Hw, fits.information[n])
        inverse_information_into(fits.information[n], fits.covariance[n], A, ev, V)


@kernel(
    numba.void(MEASUREMENTS, numba.int64[::1], FITS, numba.int64, numba.float64), parallel=True
)
def _fit_parallel(
    data: Measurements, row: np.ndarray, fits: Fits, max_iter: int, tol: float
) -> None:  # pragma: no cover (compiled)
    """Every run of :func:`gauss_newton`, in chunks over a parallel loop."""
    n = fits.theta.shape[0]
    for c in numba.prange((n + CHUNK - 1) // CHUNK):
        _fit_range(c * CHUNK, min(n, (c + 1) * CHUNK), data, row, fits, max_iter, tol)


def measurements(
    ls: np.ndarray, sigma: np.ndarray, tx: np.ndarray, rx: np.ndarray, tau: np.ndarray
) -> Measurements:
    """Checked range sums as the kernels read them (w = 1 / sigma)."""
    return Measurements(
        np.ascontiguousarray(ls, dtype=float),
        1.0 / np.ascontiguousarray(sigma, dtype=float),
        np.ascontiguousarray(tx, dtype=float),
        np.ascontiguousarray(rx, dtype=float),
        np.ascontiguousarray(tau, dtype=float),
    )


def gauss_newton(
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
    """:func:`gauss_newton_reference` of the range-sum model, compiled: positions or tracks.

    Run n fits the M range sums of data row ``row[n]`` from ``theta0[n]``: a
    position x (K = D), h_m = |x - rx_m| + |x - tx_m| (Fadeev et al., eq. 1), or a
    constant-velocity track (x0, v) (K = 2D), x = x0 + tau_m v. Several runs may
    share a data row (several starts of one problem). The iteration and its step
    control are those of :func:`gauss_newton_reference`, per run.

    Parameters
    ----------
    ls, sigma : (R, M) ndarray
        Measurements and noise standard deviations of R data rows, checked.
    tx, rx : (R, M, D) ndarray
        Transmitter and receiver of every measurement.
    tau : (M,) ndarray
        Time of each measurement after the track's reference time (unused for K = D).
    row : (n,) ndarray of int
        Data row of each run.
    theta0 : (n, K) ndarray
        Starts.
    max_iter, tol :
        As :func:`gauss_newton_reference`.

    Returns
    -------
    fit : GaussNewtonFit
    """
    n, k = theta0.shape
    m = ls.shape[1]
    fits = Fits(
        np.array(theta0, dtype=float, order="C"),
        np.empty((n, m)),
        np.empty(n),
        np.empty(n, dtype=np.int64),
        np.empty(n, dtype=bool),
        np.empty((n, k, k)),
        np.empty((n, k, k)),
    )
    data = measurements(ls, sigma, tx, rx, tau)
    row = np.ascontiguousarray(row, dtype=np.int64)
    if n >= PARALLEL_MIN:
        _fit_parallel(data, row, fits, max_iter, tol)
    else:
        _fit_range(0, n, data, row, fits, max_iter, tol)
    return GaussNewtonFit(
        fits.theta,
        fits.cost,
        fits.r * np.asarray(sigma)[row],
        fits.information,
        fits.covariance,
        fits.iterations,
        fits.converged,
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
