"""Closed-form algebra of symmetric 2x2 matrices, shared by the gates and initiation.

A symmetric matrix :math:`S = [[S_{11}, S_{12}], [S_{12}, S_{22}]]` is carried as its
three distinct components plus its determinant, each a scalar or an (N,) array, so
that N matrices cost a handful of elementwise operations and no per-matrix solve.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Sym2", "inverse", "inverse_matrix", "largest_eigenvalue", "quadratic_form", "sym2"]


class Sym2(NamedTuple):
    """Components of N symmetric 2x2 matrices, each a scalar or an (N,) array."""

    xx: np.ndarray  # S11
    xy: np.ndarray  # S12 = S21
    yy: np.ndarray  # S22
    det: np.ndarray  # S11 S22 - S12^2


def sym2(P: np.ndarray) -> Sym2:
    """Components of (..., 2, 2) symmetric matrices, reading the upper off-diagonal."""
    xx, xy, yy = P[..., 0, 0], P[..., 0, 1], P[..., 1, 1]
    return Sym2(xx, xy, yy, xx * yy - xy * xy)


def quadratic_form(nu_x: np.ndarray, nu_y: np.ndarray, S: Sym2) -> np.ndarray:
    """Return rho = nu^T S^-1 nu for positive definite S, in LDL^T form.

    With :math:`S = L D L^T`, :math:`L = [[1, 0], [S_{12}/S_{11}, 1]]` and
    :math:`D = \\mathrm{diag}(S_{11}, |S|/S_{11})`,

    .. math:: \\rho = \\frac{\\nu_x^2}{S_{11}}
              + \\frac{(S_{11}\\nu_y - S_{12}\\nu_x)^2}{S_{11}\\,|S|},

    a sum of two squares, so rounding can never make rho negative.
    """
    t = S.xx * nu_y
    t -= S.xy * nu_x
    t *= t
    t /= S.xx * S.det
    rho: np.ndarray = nu_x * nu_x
    rho /= S.xx
    rho += t
    return rho


def largest_eigenvalue(S: Sym2) -> np.ndarray:
    """Return lambda_max(S) = (S11 + S22)/2 + sqrt(((S11 - S22)/2)^2 + S12^2)."""
    half_diff = 0.5 * (S.xx - S.yy)
    lambda_max: np.ndarray = 0.5 * (S.xx + S.yy) + np.sqrt(half_diff * half_diff + S.xy * S.xy)
    return lambda_max


def inverse(S: Sym2) -> Sym2:
    """Return S^-1 = [[S22, -S12], [-S12, S11]] / |S|, with determinant 1 / |S|."""
    return Sym2(S.yy / S.det, -S.xy / S.det, S.xx / S.det, 1.0 / S.det)


def inverse_matrix(S: np.ndarray) -> np.ndarray:
    """Return the inverses of (..., 2, 2) symmetric positive definite matrices.

    >>> inverse_matrix(np.array([[4.0, 1.0], [1.0, 2.0]])) @ np.array([[4.0, 1.0], [1.0, 2.0]])
    array([[1., 0.],
           [0., 1.]])
    """
    a, b, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    det = a * d - b * b
    adjugate = np.stack([np.stack([d, -b], -1), np.stack([-b, a], -1)], -2)
    result: np.ndarray = adjugate / det[..., None, None]
    return result
