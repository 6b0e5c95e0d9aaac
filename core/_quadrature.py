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

import numpy as np

__all__ = ["RATIO", "breakpoints", "panel_rule"]

RATIO = 3.0
"""Growth factor of the panel widths away from a feature."""
_MAX_LEVELS = 40


@functools.lru_cache(maxsize=16)
def _gauss_legendre(m: int) -> tuple[np.ndarray, np.ndarray]:
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
    x, w = _gauss_legendre(m)
    a = edges[..., :-1, None]
    half = 0.5 * (edges[..., 1:, None] - a)
    shape = (*edges.shape[:-1], -1)
    return (a + half * (1.0 + x)).reshape(shape), (half * w).reshape(shape)
