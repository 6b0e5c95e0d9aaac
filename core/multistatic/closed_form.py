"""Closed-form multistatic position solves of Fadeev et al.: sum-range and difference-range.

Fadeev, Myakinkov and Ogurtsov compare the maximum-likelihood estimate with two
analytic solutions of the position-line equations built on eq. (1) (their ref. [10]):
the *sum-range* method intersects the ellipses of equal range sum (Fig. 3, curves 5),
the *difference-range* method the hyperbolae of the receiver-pair differences of the
range sums (curves 6). Both are solved here by spherical intersection: squaring the
range equation around a reference point makes it linear in the offset s and the
reference range R,

.. math:: \\mathbf{M} \\mathbf{s} = \\mathbf{h} + R \\, \\mathbf{g},

whose least-squares solution is a line :math:`\\mathbf{s} = \\mathbf{a} + R\\mathbf{c}`;
:math:`|\\mathbf{a} + R\\mathbf{c}|^2 = R^2` is then a quadratic with up to two roots.

Root choice (both methods)
--------------------------
A root is *consistent* when it is real, R >= 0 and every range it implies is >= 0
(within rounding), i.e. the squared equations hold unsquared. Of the consistent roots
the one with the smaller range-sum residual ``|l - h(x)|`` is chosen (on a tie to
rounding, the one nearer the reference point: smaller R); the other is
reported as ``alternative`` when it is also consistent and a different point. With
exactly as many equations as unknowns both roots fit the data exactly (two ellipse
intersections) and both are reported; with more equations the wrong root usually
leaves a large residual, given as ``alternative_residual`` so the caller can judge it
(e.g. against sigma).

Degenerate platforms: when M has rank D - 1 (2D: the reference and every receiver on
one line; 3D: all platforms in one plane, e.g. at one altitude) the position is fixed
only up to its mirror image in that line or plane. If there is an equation more than
the rank, R follows from the equations outside the platforms' span and both mirror
images are returned (on this tie the one with the larger last coordinate is chosen:
3D, the target above the plane). ``solvable`` is False when no consistent root exists
(the position lines do not meet, e.g. nested ellipses) or the rank is lower still
(3D: all platforms on one line); those problems get a finite best-effort ``x`` (at the
quadratic's vertex), never NaN and never an exception.

Numerics: everything is computed relative to the reference point, (|b|^2 - l^2)/2 is
formed as a product, and the discriminant through Lagrange's identity, so noise-free
data are solved to about 1e-6 m even where M is poorly conditioned. Near a double root
(two intersections close together) the root is inherently sensitive to rounding.

The sum-range roots are compiled (numba, one problem at a time, the SVD by one-sided
Jacobi rotations): :func:`sum_range_roots`, behind :func:`sum_range_solve` and the
maximum-likelihood solves' starts. :func:`sum_range_roots_reference` is the same
arithmetic in numpy (LAPACK's batched SVD), the tests' reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import ARRAY_1D, ARRAY_2D, ARRAY_3D, kernel, record, tuple_of
from plotgate.core.errors import ParameterError
from plotgate.core.multistatic.model import (
    COINCIDENT_RTOL,
    coordinate_scale,
    copy_into,
    range_sums,
    scale_of,
    validate_problem,
)

__all__ = [
    "RANK_RTOL",
    "ROOT_RTOL",
    "ROOT_WORK",
    "ClosedFormSolution",
    "RootWork",
    "difference_range_solve",
    "root_work",
    "sum_range_roots",
    "sum_range_roots_into",
    "sum_range_roots_reference",
    "sum_range_solve",
]

RANK_RTOL = 1e-10
"""The linear system is rank deficient (solvable False) when its smallest singular
value is below RANK_RTOL times its largest."""

ROOT_RTOL = 1e-8
"""Rounding allowance, relative to the problem's coordinate scale (largest |platform
coordinate|, at least 1 m): on the signs of R and the implied ranges, between residuals
that count as a tie, and below which two roots count as the same point."""


@dataclass(frozen=True)
class ClosedFormSolution:
    """Closed-form positions of N range-sum problems.

    Attributes
    ----------
    x : (N, D) ndarray
        Chosen position, metres. Where ``solvable`` is False it is only a finite
        best-effort point (the vertex of the quadratic), not a solution.
    alternative : (N, D) ndarray
        The other consistent root where ``has_alternative``; a copy of ``x`` elsewhere.
    has_alternative : (N,) ndarray of bool
        A second consistent, distinct root exists.
    solvable : (N,) ndarray of bool
        At least one consistent real root exists and the geometry has full rank.
    residual : (N,) ndarray
        Range-sum residual norm |l - h(x)| of ``x``, metres (sqrt of the sum of squares
        over the P measurements).
    alternative_residual : (N,) ndarray
        The same for ``alternative`` (equal to ``residual`` where there is none).
    """

    x: np.ndarray
    alternative: np.ndarray
    has_alternative: np.ndarray
    solvable: np.ndarray
    residual: np.ndarray
    alternative_residual: np.ndarray


def _single_transmitter(tx: np.ndarray, tol: np.ndarray) -> None:
    """Raise ParameterError (field tx) unless every pair of a problem shares its tx."""
    spread = np.linalg.norm(tx - tx[:, :1], axis=-1)  # (N, P)
    bad = (spread > tol[:, None]).any(axis=-1)
    if bad.any():
        index = int(np.argmax(bad))
        k = int(np.argmax(spread[index] > tol[index]))
        raise ParameterError(
            "tx",
            f"this closed form needs one transmitter per problem, but pair {k} has "
            f"tx {tx[index, k].tolist()} and pair 0 has {tx[index, 0].tolist()}; "
            f"solve each transmitter's pairs separately",
            index,
        )


def _least_norm_line(
    M: np.ndarray, g: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares line s = a + R c of M s = h + R g through the SVD (batched
    pseudo-inverse over the singular values kept). Returns U, V^T, the kept singular
    values (N, D), whether M has full rank (N,), a and c (N, D)."""
    U, S, Vt = np.linalg.svd(M, full_matrices=False)  # (N,K,D), (N,D), (N,D,D)
    full_rank = S[:, -1] > RANK_RTOL * S[:, 0]
    keep = S > RANK_RTOL * S[:, :1]
    inv_s = np.divide(1.0, S, out=np.zeros_like(S), where=keep)
    pinv = np.einsum("nji,nj,nkj->nik", Vt, inv_s, U)  # (N, D, K): V S^-1 U^T
    a = np.einsum("ndk,nk->nd", pinv, h)
    c = np.einsum("ndk,nk->nd", pinv, g)
    return U, Vt, keep, full_rank, a, c


def _circle_roots(
    a: np.ndarray, c: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The roots of |a + R c|^2 = R^2, alpha R^2 + 2 beta R + gamma = 0, and their points
    s (N, 2, D). Returns alpha, beta (N,), R (N, 2), s and whether the roots are real."""
    alpha = np.einsum("nd,nd->n", c, c) - 1.0
    beta = np.einsum("nd,nd->n", a, c)
    gamma = np.einsum("nd,nd->n", a, a)
    # beta^2 - alpha gamma = |a|^2 - (|a|^2 |c|^2 - (a.c)^2) = |a|^2 - |a ^ c|^2
    # (Lagrange's identity): a and c are nearly parallel when M is poorly conditioned,
    # and the wedge product keeps the digits that beta^2 - alpha gamma would cancel.
    wedge = a[:, :, None] * c[:, None, :] - a[:, None, :] * c[:, :, None]
    wedge2 = 0.5 * np.einsum("nij,nij->n", wedge, wedge)
    norm_a = np.sqrt(gamma)
    norm_w = np.sqrt(wedge2)
    disc = (norm_a - norm_w) * (norm_a + norm_w)
    real = disc >= -1e-12 * (gamma + wedge2)
    root = np.sqrt(np.maximum(disc, 0.0))
    q = -(beta + np.where(beta >= 0, root, -root))  # no cancellation
    with np.errstate(divide="ignore", invalid="ignore"):
        R = np.stack([q / alpha, gamma / q], axis=1)  # (N, 2); product gamma / alpha
    s = a[:, None, :] + R[..., None] * c[:, None, :]  # (N, 2, D)
    return alpha, beta, R, s, real


def _mirror_images(
    U: np.ndarray,
    Vt: np.ndarray,
    keep: np.ndarray,
    g: np.ndarray,
    h: np.ndarray,
    a: np.ndarray,
    c: np.ndarray,
    R: np.ndarray,
    s: np.ndarray,
    real: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rank D - 1 (2D: receivers on one line through the reference; 3D: all platforms
    in one plane): M s fixes s only in the platforms' span, but the equations outside
    range(M) fix R, and |s| = R gives the offset +-t along the null direction n: two
    mirror images. Needs an equation more than the rank. Returns where it applies (N,),
    its R_m (0 elsewhere), and R, s and real with the mirror images put in."""
    d = a.shape[1]
    rank = keep.sum(axis=1)
    g_out = g - np.einsum("nkd,nd->nk", U, keep * np.einsum("nkd,nk->nd", U, g))
    h_out = h - np.einsum("nkd,nd->nk", U, keep * np.einsum("nkd,nk->nd", U, h))
    gg = np.einsum("nk,nk->n", g_out, g_out)
    mirror = (rank == d - 1) & (gg > 1e-16 * np.einsum("nk,nk->n", g, g))
    with np.errstate(divide="ignore", invalid="ignore"):
        R_m = -np.einsum("nk,nk->n", h_out, g_out) / gg
    R_m = np.where(mirror, R_m, 0.0)
    s_m = a + R_m[:, None] * c
    t2 = R_m * R_m - np.einsum("nd,nd->n", s_m, s_m)
    t = np.sqrt(np.maximum(t2, 0.0))
    null = Vt[:, -1]  # (N, D), unit
    sign = np.array([1.0, -1.0])
    s = np.where(
        mirror[:, None, None],
        s_m[:, None, :] + (sign[:, None] * t[:, None, None]) * null[:, None, :],
        s,
    )
    R = np.where(mirror[:, None], R_m[:, None], R)
    real = np.where(mirror, t2 >= -1e-12 * R_m * R_m, real)
    return mirror, R_m, R, s, real


def _intersect(
    M: np.ndarray,
    g: np.ndarray,
    h: np.ndarray,
    ranges: np.ndarray,
    ranges_slope: np.ndarray,
    base: np.ndarray,
    ls: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
) -> ClosedFormSolution:
    """Solve M s = h + R g, |s| = R for s = x - base, batched; choose the root.

    ``ranges + R * ranges_slope`` (N, K) are the other ranges the root implies; they
    must be >= 0 for the root to be consistent.
    """
    n, _, d = M.shape
    tol = ROOT_RTOL * coordinate_scale(tx, rx)  # (N,)

    U, Vt, keep, full_rank, a, c = _least_norm_line(M, g, h)
    alpha, beta, R, s, real = _circle_roots(a, c)
    mirror, R_m, R, s, real = _mirror_images(U, Vt, keep, g, h, a, c, R, s, real)
    solvable_rank = full_rank | mirror

    finite = np.isfinite(R) & np.isfinite(s).all(axis=-1)
    R = np.where(finite, R, 0.0)
    s = np.where(finite[..., None], s, 0.0)
    x = base[:, None, :] + s
    implied = ranges[:, None, :] + R[..., None] * ranges_slope[:, None, :]  # (N, 2, K)
    consistent = (
        finite
        & real[:, None]
        & solvable_rank[:, None]
        & (R >= -tol[:, None])
        & (implied >= -tol[:, None, None]).all(axis=-1)
    )
    residual = np.linalg.norm(
        ls[:, None, :] - range_sums(x, tx[:, None], rx[:, None]), axis=-1
    )  # (N, 2)

    # Smaller residual wins. Residuals equal to rounding (a square system, where both
    # roots are exact) fall back to the smaller reference range R, and equal R (mirror
    # images) to the larger last coordinate (3D: the target above the platforms' plane).
    tie = np.abs(residual[:, 0] - residual[:, 1]) <= tol
    same_r = np.abs(R[:, 0] - R[:, 1]) <= tol
    by_r = np.where(same_r, x[:, 0, -1] >= x[:, 1, -1], R[:, 0] < R[:, 1])
    first = np.where(tie, by_r, residual[:, 0] < residual[:, 1])
    best = np.where(consistent[:, 0] & (first | ~consistent[:, 1]), 0, 1)  # (N,)
    other = 1 - best
    rows = np.arange(n)
    solvable = consistent[rows, best]
    x_best, x_other = x[rows, best], x[rows, other]
    distinct = np.linalg.norm(x_best - x_other, axis=-1) > tol
    has_alt = solvable & consistent[rows, other] & distinct

    # Unsolvable problems: a finite best-effort point at the quadratic's vertex (or at
    # the least-squares R of the rank-deficient case).
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.maximum(np.where(mirror, R_m, -beta / alpha), 0.0)
    vertex = np.where(np.isfinite(vertex), vertex, 0.0)
    fallback = base + a + vertex[:, None] * c
    x_out = np.where(solvable[:, None], x_best, fallback)
    res_out = np.where(
        solvable, residual[rows, best], np.linalg.norm(ls - range_sums(fallback, tx, rx), axis=-1)
    )
    alt_out = np.where(has_alt[:, None], x_other, x_out)
    alt_res = np.where(has_alt, residual[rows, other], res_out)
    return ClosedFormSolution(x_out, alt_out, has_alt, solvable, res_out, alt_res)


def sum_range_solve(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    *,
    baseline_tol: ArrayLike | None = None,
) -> ClosedFormSolution:
    """Sum-range method: intersect the ellipses of equal range sum (Fadeev et al., curves 5).

    With one transmitter per problem, s = x - tx, R_t = |s|, b_k = rx_k - tx, the
    range to receiver k is l_k - R_t; squaring it gives the linear equations

    .. math:: \\mathbf{b}_k^T \\mathbf{s} - l_k R_t = \\frac{|\\mathbf{b}_k|^2 - l_k^2}{2},
              \\quad k = 1 \\ldots P,

    solved in least squares as s = a + R_t c, then |a + R_t c|^2 = R_t^2 for R_t
    (spherical intersection). A root is consistent when R_t >= 0 and every
    l_k - R_t >= 0; see the module notes for the choice between the two roots.

    Parameters
    ----------
    l : (N, P) or (P,) array_like
        Range sums, metres; P >= D (P = D: a square system with up to two exact
        solutions, e.g. two ellipses in 2D).
    tx : (N, P, D), (P, D) or (D,) array_like
        Transmitter, metres; the same point for every pair of a problem.
    rx : (N, P, D) or (P, D) array_like
        Receivers, metres; D = 2 or 3.
    baseline_tol : float or array_like, optional
        Metres a range sum may fall below its baseline (noise near a baseline crossing);
        see :func:`plotgate.core.multistatic.model.validate_problem`. Default 0.

    Returns
    -------
    solution : ClosedFormSolution
        Shapes (N, D) and (N,); N = 1 when nothing is batched.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`plotgate.core.multistatic.model.validate_problem`; also ParameterError
        (field ``"tx"``) when the pairs of a problem do not share one transmitter.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (1) and the
       sum-range method (Fig. 3, curves 5).

    Examples
    --------
    Two receivers in 2D (square system): both ellipse intersections are exact and the
    data cannot tell them apart; the one nearer the transmitter comes first.

    >>> rx = [[6000.0, 0.0], [0.0, 8000.0], [7000.0, 9000.0]]
    >>> l = range_sums([2000.0, 3000.0], [0.0, 0.0], rx)
    >>> sol = sum_range_solve(l[:2], [0.0, 0.0], rx[:2])
    >>> sol.x.round(1), sol.has_alternative, sol.alternative.round(1)
    (array([[-1257.2,   447.8]]), array([ True]), array([[2000., 3000.]]))

    A third receiver fits only the true point; the other root is still consistent in
    sign but leaves a residual of about 1.5 km.

    >>> sol = sum_range_solve(l, [0.0, 0.0], rx)
    >>> sol.x.round(3), sol.solvable, sol.alternative_residual.round()
    (array([[2000., 3000.]]), array([ True]), array([1463.]))
    """
    ls, tx, rx, _ = validate_problem(l, tx, rx, baseline_tol=baseline_tol)
    _single_transmitter(tx, COINCIDENT_RTOL * coordinate_scale(tx, rx))
    return sum_range_roots(ls, tx, rx)


def sum_range_roots_reference(
    ls: np.ndarray, tx: np.ndarray, rx: np.ndarray
) -> ClosedFormSolution:
    """:func:`sum_range_roots` in numpy (batched SVD): the reference of the kernel."""
    base = tx[:, 0]
    b = rx - base[:, None]
    norm_b = np.linalg.norm(b, axis=-1)
    h = 0.5 * (norm_b - ls) * (norm_b + ls)  # (|b|^2 - l^2) / 2 without cancellation
    return _intersect(
        M=b, g=ls, h=h, ranges=ls, ranges_slope=-np.ones_like(ls), base=base, ls=ls, tx=tx, rx=rx
    )


@kernel("void(float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[::1])", inline=True)
def _svd2(
    M: np.ndarray, U: np.ndarray, V: np.ndarray, S: np.ndarray
) -> None:  # pragma: no cover (compiled)
    """Thin SVD of a P x 2 matrix: the eigen-decomposition of the 2 x 2 Gram matrix
    M^T M = [[alpha, gamma], [gamma, beta]] in closed form (the Jacobi rotation
    t = tan theta, cot 2 theta = (beta - alpha) / (2 gamma), without a trigonometric
    function), applied to M's columns, whose norms are the singular values; no
    allocation. As :func:`_svd`, whose first sweep it is, without the sweeps after it that
    polish the columns' orthogonality at rounding level.
    """
    p = M.shape[0]
    alpha = 0.0
    beta = 0.0
    gamma = 0.0
    for k in range(p):
        alpha += M[k, 0] * M[k, 0]
        beta += M[k, 1] * M[k, 1]
        gamma += M[k, 0] * M[k, 1]
    c = 1.0
    s = 0.0
    if not (gamma == 0.0 or abs(gamma) <= 1e-16 * np.sqrt(alpha * beta)):
        zeta = (beta - alpha) / (2.0 * gamma)
        t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
        c = 1.0 / np.sqrt(1.0 + t * t)
        s = c * t
    n0 = 0.0
    n1 = 0.0
    for k in range(p):
        w0 = c * M[k, 0] - s * M[k, 1]
        w1 = s * M[k, 0] + c * M[k, 1]
        n0 += w0 * w0
        n1 += w1 * w1
    n0, n1 = np.sqrt(n0), np.sqrt(n1)
    first = 0 if n0 >= n1 else 1  # descending; a tie keeps the column order
    for a in range(2):
        i = first if a == 0 else 1 - first
        norm = n0 if i == 0 else n1
        S[a] = norm
        for k in range(p):
            w = c * M[k, 0] - s * M[k, 1] if i == 0 else s * M[k, 0] + c * M[k, 1]
            U[k, a] = w / norm if norm > 0.0 else 0.0
        V[0, a] = c if i == 0 else s
        V[1, a] = -s if i == 0 else c


@kernel("void(float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[::1])")
def _svd(
    M: np.ndarray, U: np.ndarray, V: np.ndarray, S: np.ndarray
) -> None:  # pragma: no cover (compiled)
    """Thin SVD M = U diag(S) V^T of a P x D matrix by one-sided Jacobi rotations.

    Hestenes' method: rotate pairs of columns until they are orthogonal; accurate to
    the rounding of M (its small singular values to their own relative precision).
    S descending; U's column is 0 where S is 0. With D = 2 one rotation, in closed form
    (:func:`_svd2`), orthogonalizes the two columns.
    """
    p, d = M.shape
    if d == 2:
        _svd2(M, U, V, S)
        return
    W = M.copy()
    Q = np.eye(d)
    for _ in range(60):
        rotated = False
        for i in range(d - 1):
            for j in range(i + 1, d):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(p):
                    alpha += W[k, i] * W[k, i]
                    beta += W[k, j] * W[k, j]
                    gamma += W[k, i] * W[k, j]
                if gamma == 0.0 or abs(gamma) <= 1e-16 * np.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                c = 1.0 / np.sqrt(1.0 + t * t)
                s = c * t
                for k in range(p):
                    wi, wj = W[k, i], W[k, j]
                    W[k, i] = c * wi - s * wj
                    W[k, j] = s * wi + c * wj
                for k in range(d):
                    qi, qj = Q[k, i], Q[k, j]
                    Q[k, i] = c * qi - s * qj
                    Q[k, j] = s * qi + c * qj
        if not rotated:
            break
    norms = np.empty(d)
    for i in range(d):
        norms[i] = np.sqrt(np.sum(W[:, i] * W[:, i]))
    order = np.argsort(-norms, kind="mergesort")
    for a in range(d):
        i = order[a]
        S[a] = norms[i]
        for k in range(p):
            U[k, a] = W[k, i] / norms[i] if norms[i] > 0.0 else 0.0
        for k in range(d):
            V[k, a] = Q[k, i]


@kernel("float64(float64[::1], float64[::1], float64[:, ::1], float64[:, ::1])")
def _range_sum_residual(
    x: np.ndarray,
    l: np.ndarray,  # noqa: E741
    tx: np.ndarray,
    rx: np.ndarray,
) -> float:  # pragma: no cover (compiled)
    """|l - h(x)| over the P range sums of one problem."""
    p, d = tx.shape
    total = 0.0
    for k in range(p):
        a = 0.0
        b = 0.0
        for i in range(d):
            a += (x[i] - rx[k, i]) * (x[i] - rx[k, i])
            b += (x[i] - tx[k, i]) * (x[i] - tx[k, i])
        e = l[k] - (np.sqrt(a) + np.sqrt(b))
        total += e * e
    return math.sqrt(total)


class RootWork(NamedTuple):
    """Scratch space of :func:`sum_range_roots_into` for P pairs in D dimensions.

    M, U (P, D) and V (D, D), S (D,) the SVD; h (P,); a, c (D,) the line s = a + R c;
    s, x (2, D) the two roots; R, residual (2,); consistent (2,); fallback (D,).
    """

    M: np.ndarray
    U: np.ndarray
    V: np.ndarray
    S: np.ndarray
    h: np.ndarray
    a: np.ndarray
    c: np.ndarray
    s: np.ndarray
    x: np.ndarray
    R: np.ndarray
    consistent: np.ndarray
    residual: np.ndarray
    fallback: np.ndarray


ROOT_WORK = record(
    RootWork,
    *(ARRAY_2D, ARRAY_2D, ARRAY_2D, ARRAY_1D, ARRAY_1D, ARRAY_1D, ARRAY_1D),
    *(ARRAY_2D, ARRAY_2D, ARRAY_1D, numba.boolean[::1], ARRAY_1D, ARRAY_1D),
)
"""numba type of :class:`RootWork`."""


@kernel(ROOT_WORK(numba.int64, numba.int64))
def root_work(p: int, d: int) -> RootWork:  # pragma: no cover (compiled)
    """:class:`RootWork` for problems of p pairs in d dimensions."""
    return RootWork(
        np.empty((p, d)),
        np.empty((p, d)),
        np.empty((d, d)),
        np.empty(d),
        np.empty(p),
        np.empty(d),
        np.empty(d),
        np.empty((2, d)),
        np.empty((2, d)),
        np.empty(2),
        np.empty(2, dtype=np.bool_),
        np.empty(2),
        np.empty(d),
    )


@kernel(numba.void(ARRAY_1D, ARRAY_2D, ARRAY_2D, ROOT_WORK), inline=True)
def _baselines_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray,
    rx: np.ndarray,
    work: RootWork,
) -> None:  # pragma: no cover (compiled)
    """The linear system of the sum-range equations: the baselines M_k = rx_k - tx (P, D)
    and h_k = (|M_k| - l_k)(|M_k| + l_k) / 2, so that M s = h + R l for s = x - tx and
    R = |s| (the target's range from the transmitter), m and m^2."""
    p, d = tx.shape
    M, h = work.M, work.h
    for k in range(p):
        nb = 0.0
        for i in range(d):
            M[k, i] = rx[k, i] - tx[0, i]
            nb += M[k, i] * M[k, i]
        nb = np.sqrt(nb)
        h[k] = 0.5 * (nb - l[k]) * (nb + l[k])


@kernel(numba.void(ARRAY_1D, ROOT_WORK, numba.int64), inline=True)
def _line_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    work: RootWork,
    rank: int,
) -> None:  # pragma: no cover (compiled)
    """The least-norm line of solutions s = a + R c of M s = h + R l, over the rank's
    singular values of M = U S V^T: a = V S^-1 U^T h, c = V S^-1 U^T l."""
    p, d = l.shape[0], work.V.shape[0]
    U, V, S, h, a, c = work.U, work.V, work.S, work.h, work.a, work.c
    for i in range(d):
        ai = 0.0
        ci = 0.0
        for j in range(rank):
            uh = 0.0
            ug = 0.0
            for k in range(p):
                uh += U[k, j] * h[k]
                ug += U[k, j] * l[k]
            ai += V[i, j] / S[j] * uh
            ci += V[i, j] / S[j] * ug
        a[i] = ai
        c[i] = ci


@kernel(tuple_of(numba.float64, numba.float64, numba.boolean)(ROOT_WORK), inline=True)
def _circle_roots_into(work: RootWork) -> tuple[float, float, bool]:  # pragma: no cover
    """The roots R_j of |a + R c| = R, alpha R^2 + 2 beta R + gamma = 0 with alpha =
    |c|^2 - 1, beta = a.c, gamma = |a|^2 (the stable form q = -(beta + sign(beta) root)),
    into R and the points s_j = a + R_j c; returns alpha, beta and whether the roots are
    real (the discriminant |a|^2 - |a ^ c|^2 not below rounding)."""
    d = work.a.shape[0]
    a, c, s, R = work.a, work.c, work.s, work.R
    alpha = -1.0
    beta = 0.0
    gamma = 0.0
    for i in range(d):
        alpha += c[i] * c[i]
        beta += a[i] * c[i]
        gamma += a[i] * a[i]
    wedge2 = 0.0
    for i in range(d):
        for j in range(d):
            w = a[i] * c[j] - a[j] * c[i]
            wedge2 += w * w
    wedge2 *= 0.5
    norm_a = np.sqrt(gamma)
    norm_w = np.sqrt(wedge2)
    disc = (norm_a - norm_w) * (norm_a + norm_w)
    real = disc >= -1e-12 * (gamma + wedge2)
    root = np.sqrt(max(disc, 0.0))
    q = -(beta + (root if beta >= 0 else -root))
    R[0] = q / alpha
    R[1] = gamma / q
    for j in range(2):
        for i in range(d):
            s[j, i] = a[i] + R[j] * c[i]
    return alpha, beta, real


@kernel(
    tuple_of(numba.boolean, numba.float64, numba.boolean)(ARRAY_1D, ROOT_WORK, numba.int64),
    inline=True,
)
def _mirror_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    work: RootWork,
    rank: int,
) -> tuple[bool, float, bool]:  # pragma: no cover (compiled)
    """Rank D - 1 (receivers on one line with the transmitter, in 2-D): R fixed by the
    part of l outside M's range, R_m = -(h_o . l_o) / |l_o|^2, and the two roots the
    mirror images a + R_m c +- t v along the null direction v, t^2 = R_m^2 - |a + R_m c|^2,
    into R and s. Returns whether it applies, R_m (0 when not) and whether t is real."""
    p, d = l.shape[0], work.V.shape[0]
    U, V, h, a, c, s, R = work.U, work.V, work.h, work.a, work.c, work.s, work.R
    gg = 0.0
    g2 = 0.0
    hg = 0.0
    for k in range(p):
        go = l[k]
        ho = h[k]
        for j in range(rank):
            ug = 0.0
            uh = 0.0
            for m in range(p):
                ug += U[m, j] * l[m]
                uh += U[m, j] * h[m]
            go -= U[k, j] * ug
            ho -= U[k, j] * uh
        gg += go * go
        g2 += l[k] * l[k]
        hg += ho * go
    mirror = rank == d - 1 and gg > 1e-16 * g2
    R_m = -hg / gg if mirror else 0.0
    real = False
    if mirror:
        t2 = R_m * R_m
        for i in range(d):
            sm = a[i] + R_m * c[i]
            t2 -= sm * sm
        t = np.sqrt(max(t2, 0.0))
        for j in range(2):
            sign = 1.0 if j == 0 else -1.0
            for i in range(d):
                s[j, i] = a[i] + R_m * c[i] + sign * t * V[i, d - 1]
            R[j] = R_m
        real = t2 >= -1e-12 * R_m * R_m
    return mirror, R_m, real


@kernel(
    numba.void(ARRAY_1D, ARRAY_2D, ARRAY_2D, ROOT_WORK, numba.float64, numba.boolean),
    inline=True,
)
def _candidates_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray,
    rx: np.ndarray,
    work: RootWork,
    tol: float,
    admissible: bool,
) -> None:  # pragma: no cover (compiled)
    """Each root's target x_j = tx + s_j (0 where not finite) and its residual; it is
    consistent when finite, ``admissible`` (real, of a solvable rank) and R_j >= 0 and
    l_k - R_j >= 0 for every pair (a range sum is at least the transmitter's range), to
    tol, m."""
    p, d = tx.shape
    s, x, R = work.s, work.x, work.R
    consistent, residual = work.consistent, work.residual
    for j in range(2):
        finite = math.isfinite(R[j])
        for i in range(d):
            finite = finite and math.isfinite(s[j, i])
        if not finite:
            R[j] = 0.0
            for i in range(d):
                s[j, i] = 0.0
        for i in range(d):
            x[j, i] = tx[0, i] + s[j, i]
        ok = finite and admissible and R[j] >= -tol
        for k in range(p):
            ok = ok and l[k] - R[j] >= -tol
        consistent[j] = ok
        residual[j] = _range_sum_residual(x[j], l, tx, rx)


@kernel(
    numba.void(
        ARRAY_1D,
        ARRAY_2D,
        ARRAY_2D,
        ROOT_WORK,
        numba.float64,
        numba.float64,
        ARRAY_2D,
        ARRAY_1D,
        numba.boolean[::1],
    ),
    inline=True,
)
def _chosen_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray,
    rx: np.ndarray,
    work: RootWork,
    tol: float,
    vertex: float,
    out: np.ndarray,
    res: np.ndarray,
    flags: np.ndarray,
) -> None:  # pragma: no cover (compiled)
    """The better root (the smaller residual; on a tie the smaller R, then the higher
    last coordinate) and the other as an alternative when it is consistent too and apart
    by more than tol; with no consistent root, the line's point at R = ``vertex`` (at
    least 0) as the fallback."""
    d = tx.shape[1]
    x, R, a, c = work.x, work.R, work.a, work.c
    consistent, residual, fallback = work.consistent, work.residual, work.fallback
    tie = abs(residual[0] - residual[1]) <= tol
    if tie:
        if abs(R[0] - R[1]) <= tol:
            first = x[0, d - 1] >= x[1, d - 1]
        else:
            first = R[0] < R[1]
    else:
        first = residual[0] < residual[1]
    best = 0 if consistent[0] and (first or not consistent[1]) else 1
    other = 1 - best
    solvable = consistent[best]
    dist = 0.0
    for i in range(d):
        dist += (x[best, i] - x[other, i]) ** 2
    has_alt = solvable and consistent[other] and np.sqrt(dist) > tol
    if solvable:
        copy_into(x[best], out[0])
        res[0] = residual[best]
    else:
        if vertex == vertex:  # np.maximum keeps a NaN
            vertex = max(vertex, 0.0)
        if not math.isfinite(vertex):
            vertex = 0.0
        for i in range(d):
            fallback[i] = tx[0, i] + a[i] + vertex * c[i]
        copy_into(fallback, out[0])
        res[0] = _range_sum_residual(fallback, l, tx, rx)
    if has_alt:
        copy_into(x[other], out[1])
        res[1] = residual[other]
    else:
        copy_into(out[0], out[1])
        res[1] = res[0]
    flags[0] = solvable
    flags[1] = has_alt


@kernel(
    numba.void(ARRAY_1D, ARRAY_2D, ARRAY_2D, ROOT_WORK, ARRAY_2D, ARRAY_1D, numba.boolean[::1]),
    inline=True,
)
def sum_range_roots_into(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: np.ndarray,
    rx: np.ndarray,
    work: RootWork,
    out: np.ndarray,
    res: np.ndarray,
    flags: np.ndarray,
) -> None:  # pragma: no cover (compiled)
    """The sum-range roots of one problem (P pairs of one transmitter, tx[0]), compiled.

    Into out (x, alternative) (2, D), res (their residuals) (2,) and flags
    (solvable, has_alternative) (2,): :func:`sum_range_roots_reference`'s arithmetic, in
    its steps: the linear system, its SVD and least-norm line s = a + R c, the roots on the
    circle |s| = R (or the mirror images at rank D - 1), each root checked, the better
    chosen.
    """
    d = tx.shape[1]
    S = work.S
    tol = ROOT_RTOL * scale_of(tx, rx)
    _baselines_into(l, tx, rx, work)
    _svd(work.M, work.U, work.V, S)
    full_rank = S[d - 1] > RANK_RTOL * S[0]
    rank = 0
    for i in range(d):
        if S[i] > RANK_RTOL * S[0]:
            rank += 1
    _line_into(l, work, rank)
    alpha, beta, real = _circle_roots_into(work)
    mirror, R_m, mirror_real = _mirror_into(l, work, rank)
    if mirror:
        real = mirror_real
    _candidates_into(l, tx, rx, work, tol, real and (full_rank or mirror))
    _chosen_into(l, tx, rx, work, tol, R_m if mirror else -beta / alpha, out, res, flags)


@kernel(numba.void(ARRAY_2D, ARRAY_3D, ARRAY_3D, ARRAY_3D, ARRAY_2D, numba.boolean[:, ::1]))
def _sum_range_compiled(
    ls: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    out: np.ndarray,
    res: np.ndarray,
    flags: np.ndarray,
) -> None:  # pragma: no cover (compiled)
    """Per problem: out (x, alternative), res (residuals), flags (solvable, has_alternative)."""
    n, p, d = tx.shape
    work = root_work(p, d)
    for q in range(n):
        sum_range_roots_into(ls[q], tx[q], rx[q], work, out[q], res[q], flags[q])


def sum_range_roots(ls: np.ndarray, tx: np.ndarray, rx: np.ndarray) -> ClosedFormSolution:
    """:func:`sum_range_solve` without its checks (the solvers' start), compiled.

    ls (N, P), tx, rx (N, P, D) already validated, as
    :func:`plotgate.core.multistatic.model.validate_problem` returns them, and one
    transmitter per problem (tx[:, p] = tx[:, 0]). The same arithmetic as
    :func:`sum_range_roots_reference`, one problem at a time, with a Jacobi SVD.
    """
    n, p, d = tx.shape
    out = np.empty((n, 2, d))
    flags = np.empty((n, 2), dtype=np.bool_)
    res = np.empty((n, 2))
    _sum_range_compiled(
        np.ascontiguousarray(ls, dtype=float),
        np.ascontiguousarray(tx, dtype=float),
        np.ascontiguousarray(rx, dtype=float),
        out,
        res,
        flags,
    )
    return ClosedFormSolution(out[:, 0], out[:, 1], flags[:, 1], flags[:, 0], res[:, 0], res[:, 1])


def difference_range_solve(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    *,
    baseline_tol: ArrayLike | None = None,
) -> ClosedFormSolution:
    """Difference-range method: intersect hyperbolae of range-sum differences (curves 6).

    The differences d_k = l_k - l_1 (k = 2 ... P) of one transmitter's range sums do
    not depend on the transmitter: d_k = |x - rx_k| - |x - rx_1|. With u = x - rx_1,
    r_1 = |u|, e_k = rx_k - rx_1, squaring r_k = r_1 + d_k gives (Chan-style)

    .. math:: \\mathbf{e}_k^T \\mathbf{u} + d_k r_1 = \\frac{|\\mathbf{e}_k|^2 - d_k^2}{2},

    solved in least squares as u = a + r_1 c, then |a + r_1 c|^2 = r_1^2. A root is
    consistent when r_1 >= 0 and every r_1 + d_k >= 0. Receiver 1 (the reference) is
    the first pair. The position comes from the differences alone; the range sums
    (with the transmitter) only pick the root: of the consistent roots, the one with
    the smaller range-sum residual wins. With P = D + 1 both roots fit the differences
    exactly, and the transmitter usually tells the true one from the mirror one.

    Parameters
    ----------
    l : (N, P) or (P,) array_like
        Range sums, metres; P >= D + 1 (P - 1 differences for D unknowns).
    tx : (N, P, D), (P, D) or (D,) array_like
        Transmitter, metres; the same point for every pair of a problem.
    rx : (N, P, D) or (P, D) array_like
        Receivers, metres; D = 2 or 3.
    baseline_tol : float or array_like, optional
        As in :func:`sum_range_solve`.

    Returns
    -------
    solution : ClosedFormSolution
        Shapes (N, D) and (N,); residuals are range-sum residuals, as for the sum-range
        method.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`sum_range_solve`; ParameterError (field ``"l"``) also when P < D + 1.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (1) and the
       difference-range method (Fig. 3, curves 6).

    Examples
    --------
    >>> rx = [[6000.0, 0.0], [0.0, 8000.0], [7000.0, 9000.0]]
    >>> l = range_sums([2000.0, 3000.0], [0.0, 0.0], rx)
    >>> sol = difference_range_solve(l, [0.0, 0.0], rx)
    >>> sol.x.round(3), sol.solvable
    (array([[2000., 3000.]]), array([ True]))
    """
    ls, tx, rx, _ = validate_problem(l, tx, rx, baseline_tol=baseline_tol)
    p, d = rx.shape[1], rx.shape[2]
    if p < d + 1:
        raise ParameterError(
            "l",
            f"has {p} measurements, giving {p - 1} differences for {d} unknowns; "
            f"the difference-range method needs at least {d + 1}",
        )
    _single_transmitter(tx, COINCIDENT_RTOL * coordinate_scale(tx, rx))
    base = rx[:, 0]
    e = rx[:, 1:] - base[:, None]
    dk = ls[:, 1:] - ls[:, :1]
    norm_e = np.linalg.norm(e, axis=-1)
    h = 0.5 * (norm_e - dk) * (norm_e + dk)  # (|e|^2 - d^2) / 2 without cancellation
    return _intersect(
        M=e, g=-dk, h=h, ranges=dk, ranges_slope=np.ones_like(dk), base=base, ls=ls, tx=tx, rx=rx
    )
