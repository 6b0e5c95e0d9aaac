"""Graded composite Gauss-Legendre rules, vectorized over problems (private).

An integrand with a thin feature (a Gaussian peak of width w at c, a boundary layer
of width w at c) is integrated exactly enough by panels whose edges sit at
c +- w r^j, j = 0, 1, ... (r = :data:`RATIO`): each panel is no wider than its distance
from the feature, so a fixed low-order Gauss-Legendre rule resolves it, and the number
of panels grows only with log(span / w). Every problem of a batch gets the same
number of breakpoints (unused ones collapse onto the domain edges and make empty
panels), so all problems are integrated in one array expression.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

__all__ = [
    "RATIO",
    "adaptive_panels",
    "angle_breaks",
    "breakpoints",
    "gauss_legendre",
    "panel_rule",
]

RATIO = 3.0
"""Growth factor of the panel widths away from a feature."""
_MAX_LEVELS = 40


@functools.lru_cache(maxsize=16)
def gauss_legendre(m: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the m-point Gauss-Legendre rule on [-1, 1] (cached)."""
    x, w = np.polynomial.legendre.leggauss(m)
    return x, w


def _levels(span: np.ndarray, widths: np.ndarray) -> int:
    """Grading levels needed so that the widest panel about the finest feature reaches span."""
    finite = np.isfinite(widths) & (widths > 0)
    if not finite.any():
        return 0
    ratio = np.max(np.broadcast_to(span, widths.shape)[finite] / widths[finite])
    if ratio <= 1.0:
        return 1
    return int(min(_MAX_LEVELS, np.ceil(np.log(ratio) / np.log(RATIO)) + 1))


def breakpoints(
    lo: np.ndarray,
    hi: np.ndarray,
    centres: np.ndarray,
    widths: np.ndarray,
    fixed: np.ndarray | None = None,
    *,
    periodic: bool = False,
    uniform: int = 1,
) -> np.ndarray:
    """Sorted panel edges on [lo, hi], graded about each centre.

    Parameters
    ----------
    lo, hi : (...) ndarray
        Integration limits per problem.
    centres, widths : (..., C) ndarray
        Feature positions and their widths; a NaN centre or a non-positive or
        infinite width adds no grading (the centre itself stays an edge if finite).
    fixed : (..., K) ndarray, optional
        Extra edges (kinks of the integrand); NaN entries are ignored.
    periodic : bool
        Angles: edges are wrapped into [lo, lo + 2 pi) (then clipped to [lo, hi] when
        the domain is shorter than a turn) and offsets are capped at pi.
    uniform : int
        Number of equal panels the domain is first cut into.

    Returns
    -------
    edges : (..., E) ndarray
        Sorted; consecutive equal edges make empty panels.
    """
    span = hi - lo
    levels = _levels(span[..., None], widths)
    with np.errstate(over="ignore"):  # a width near the largest double: inf, no grading
        offsets = widths[..., None] * RATIO ** np.arange(levels)
    offsets = np.where(np.isfinite(offsets) & (offsets > 0), offsets, 0.0)
    if periodic:
        offsets = np.minimum(offsets, np.pi)
    graded = centres[..., None] + np.concatenate([offsets, -offsets], axis=-1)
    parts = [centres, graded.reshape(*graded.shape[:-2], -1)]
    if fixed is not None:
        parts.append(fixed)
    steps = np.arange(1, uniform) / uniform
    parts.append(lo[..., None] + span[..., None] * steps)
    pts = np.concatenate(parts, axis=-1)
    lo_, hi_ = lo[..., None], hi[..., None]
    pts = np.where(np.isnan(pts), lo_, pts)
    if periodic:
        pts = lo_ + np.mod(pts - lo_, 2.0 * np.pi)
    pts = np.clip(pts, lo_, hi_)
    return _distinct(np.sort(np.concatenate([lo_, pts, hi_], axis=-1), axis=-1))


def angle_breaks(
    start: np.ndarray,
    span: np.ndarray,
    centres: list[np.ndarray],
    widths: list[np.ndarray],
    kinks: np.ndarray | None,
    uniform: int,
) -> np.ndarray:
    """:func:`breakpoints` of angles on [start, start + span], graded about each centre."""
    return breakpoints(
        start,
        start + span,
        np.stack(centres, axis=-1),
        np.stack(widths, axis=-1),
        kinks,
        periodic=True,
        uniform=uniform,
    )


def _distinct(edges: np.ndarray) -> np.ndarray:
    """Drop repeated edges, keeping as many columns as the row with most distinct edges.

    Rows with fewer distinct edges are padded with their last edge (empty panels).
    """
    tol = 1e-12 * (edges[..., -1:] - edges[..., :1])
    repeat = np.diff(edges, axis=-1) <= tol
    keep = np.concatenate([np.ones_like(repeat[..., :1]), ~repeat], axis=-1)
    width = int(keep.sum(axis=-1).max())
    packed = np.sort(np.where(keep, edges, np.inf), axis=-1)[..., :width]
    return np.where(np.isinf(packed), edges[..., -1:], packed)


def panel_rule(edges: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the m-point Gauss-Legendre rule on every panel.

    ``edges`` is (..., E) sorted; the result is two (..., (E - 1) m) arrays.
    """
    x, w = gauss_legendre(m)
    a = edges[..., :-1, None]
    half = 0.5 * (edges[..., 1:, None] - a)
    shape = (*edges.shape[:-1], -1)
    return (a + half * (1.0 + x)).reshape(shape), (half * w).reshape(shape)


def adaptive_panels(
    integrand: Callable[[np.ndarray, np.ndarray], np.ndarray],
    edges: np.ndarray,
    tol: float | np.ndarray,
    orders: tuple[int, int] = (10, 5),
    max_rounds: int = 40,
    max_panels: int = 100_000,
) -> tuple[np.ndarray, np.ndarray]:
    """Integrate N problems over their panels, bisecting every panel that is not yet exact.

    A panel is accepted when its two Gauss-Legendre rules (``orders``) agree within its
    share of ``tol`` (tol times its width over the problem's span); otherwise it is cut
    in two and tried again, all panels of all problems in one array per round. After
    ``max_rounds`` rounds, or when splitting would pass ``max_panels`` open panels, the
    open panels are accepted as they are and their differences count in the error.

    Parameters
    ----------
    integrand : callable
        ``integrand(rows, x)`` with x (P, m) nodes of panels that belong to problems
        ``rows`` (P,); returns the values at x.
    edges : (N, E) ndarray
        Sorted starting panel edges per problem (empty panels are dropped).
    tol : float or (N,) ndarray
        Wanted absolute error per problem.

    Returns
    -------
    integral, error : (N,) ndarray
        The higher-order sums and the sums of the panels' |high - low|.
    """
    n = len(edges)
    share = np.broadcast_to(tol, (n,)) / (edges[:, -1] - edges[:, 0])
    a, b = edges[:, :-1], edges[:, 1:]
    rows = np.broadcast_to(np.arange(n)[:, None], a.shape)
    keep = b > a
    rows, a, b = rows[keep], a[keep], b[keep]
    integral, error = np.zeros(n), np.zeros(n)
    (x_hi, w_hi), (x_lo, w_lo) = (gauss_legendre(m) for m in orders)
    for last in range(max_rounds):
        mid, half = 0.5 * (a + b), 0.5 * (b - a)
        x = mid[:, None] + half[:, None] * np.concatenate([x_hi, x_lo])
        values = integrand(rows, x)
        high = half * (values[:, : len(x_hi)] @ w_hi)
        low = half * (values[:, len(x_hi) :] @ w_lo)
        diff = np.abs(high - low)
        done = diff <= share[rows] * (b - a)
        if last == max_rounds - 1 or 2 * np.count_nonzero(~done) > max_panels:
            done[:] = True
        np.add.at(integral, rows[done], high[done])
        np.add.at(error, rows[done], diff[done])
        if done.all():
            break
        rows, a, b, mid = rows[~done], a[~done], b[~done], mid[~done]
        rows = np.repeat(rows, 2)
        a, b = np.stack([a, mid], -1).ravel(), np.stack([mid, b], -1).ravel()
    return integral, error
