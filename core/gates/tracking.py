"""Tracking gates: does a mark fall in the gate around a prediction?

The chi-square ellipse gate rho = nu^T S^-1 nu <= gamma "used for gating during
tracking" (seed 000, its ref. [6]; gamma from P_G, seed 000's two-stage procedure),
the innovation covariance S = H P H^T + R it needs (seed 000, refs. [6]/[7]), and
the rectangular gate |d_i| <= k sigma_i of seed 003 (Fig. 3.6 b). Symbols and
batching as in :mod:`plotgate.core.gates.results`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError
from plotgate.core.gates.parameters import positive_coefficient, standard_deviation
from plotgate.core.gates.results import GateResult, difference, gate_result, window_statistic
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.sym2 import quadratic_form, sym2
from plotgate.core.validation import as_array, as_covariance, as_points, pair_count, require_scalar

__all__ = ["ellipse_gate", "innovation_covariance", "rectangular_gate"]


def ellipse_gate(z: ArrayLike, z_pred: ArrayLike, S: ArrayLike, P_G: float) -> GateResult:
    """Chi-square ellipse gate around a predicted mark.

    .. math:: \\boldsymbol{\\nu} = \\mathbf{z} - \\hat{\\mathbf{z}}, \\quad
              \\rho = \\boldsymbol{\\nu}^T \\mathbf{S}^{-1} \\boldsymbol{\\nu} \\le \\gamma

    rho is evaluated in closed form (LDL^T of the 2x2 S), with no inverse or solve.

    Parameters
    ----------
    z : (2,) or (N, 2) array_like
        Mark, metres.
    z_pred : (2,) or (N, 2) array_like
        Predicted mark (gate centre), metres.
    S : (2, 2) or (N, 2, 2) array_like
        Innovation covariance in m^2, symmetric positive definite
        (see :func:`innovation_covariance`).
    P_G : float
        Gating probability, in (0, 1); gamma = ``gate_threshold(P_G, 2)``.

    Returns
    -------
    result : GateResult
        ``statistic`` is rho (dimensionless) and ``threshold`` is gamma.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    CovarianceError
        If S is not symmetric positive definite.
    ParameterError
        If P_G is not in (0, 1) or the shapes do not fit.

    References
    ----------
    .. [1] A. A. Konovalov, seed 000, two-stage procedure, ellipse test "in the
       known way used for gating during tracking" (its ref. [6]): residual, its
       covariance, :math:`\\rho = \\nu^T B^{-1} \\nu` compared with gamma.

    Examples
    --------
    >>> res = ellipse_gate([[2.0, 1.0], [4.0, 2.0]], [0.0, 0.0], np.diag([4.0, 1.0]), 0.9)
    >>> res.inside, res.statistic
    (array([ True, False]), array([2., 8.]))
    """
    z = as_points("z", z)
    z_pred = as_points("z_pred", z_pred)
    S = as_covariance("S", S)
    require_scalar("P_G", P_G)
    gamma = float(gate_threshold(P_G))
    n = pair_count(z=z.shape[:-1], z_pred=z_pred.shape[:-1], S=S.shape[:-2])
    nu_x, nu_y = difference(z_pred, z)
    rho = quadratic_form(nu_x, nu_y, sym2(S))
    return gate_result(n, rho <= gamma, rho, gamma)


def innovation_covariance(
    P_pred: ArrayLike, R: ArrayLike, H: ArrayLike | None = None
) -> np.ndarray:
    """Innovation covariance of a linear measurement.

    .. math:: \\mathbf{S} = \\mathbf{H}\\mathbf{P}\\mathbf{H}^T + \\mathbf{R}

    Parameters
    ----------
    P_pred : (..., n, n) array_like
        Covariance of the predicted state.
    R : (..., m, m) array_like
        Measurement noise covariance.
    H : (..., m, n) array_like, optional
        Measurement matrix. Default the identity (m = n, S = P_pred + R).

    Returns
    -------
    S : (..., m, m) ndarray
        Innovation covariance; leading axes broadcast.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If a matrix is not square or the dimensions do not match.

    References
    ----------
    .. [1] A. A. Konovalov, seed 000, its ref. [6]/[7]: the residual covariance of
       the ellipse gate; for two marks it is B = P1 + P2 (before eq. 1).

    Examples
    --------
    State [x, vx, y, vy], position measured:

    >>> H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    >>> innovation_covariance(np.diag([100.0, 4.0, 100.0, 4.0]), np.diag([25.0, 25.0]), H)
    array([[125.,   0.],
           [  0., 125.]])
    """
    P_pred = as_array("P_pred", P_pred)
    R = as_array("R", R)
    for name, M in (("P_pred", P_pred), ("R", R)):
        if M.ndim < 2 or M.shape[-1] != M.shape[-2]:
            raise ParameterError(name, f"must be square (..., n, n), got shape {M.shape}")
    if H is None:
        H_P_Ht = P_pred
    else:
        H = as_array("H", H)
        if H.ndim < 2 or H.shape[-1] != P_pred.shape[-1]:
            raise ParameterError(
                "H", f"must have shape (..., m, {P_pred.shape[-1]}), got shape {H.shape}"
            )
        H_P_Ht = H @ P_pred @ np.swapaxes(H, -1, -2)
    if H_P_Ht.shape[-1] != R.shape[-1]:
        raise ParameterError(
            "R", f"must be {H_P_Ht.shape[-1]} x {H_P_Ht.shape[-1]}, got shape {R.shape}"
        )
    try:
        S: np.ndarray = H_P_Ht + R
    except ValueError:
        raise ParameterError(
            "R", f"batch shape {R.shape[:-2]} does not broadcast with {H_P_Ht.shape[:-2]}"
        ) from None
    return S


def rectangular_gate(
    z: ArrayLike,
    z_pred: ArrayLike,
    sigma_x: ArrayLike,
    sigma_y: ArrayLike,
    k: float,
) -> GateResult:
    """Rectangular gate: each Cartesian coordinate within k sigmas of the prediction.

    .. math:: |z_x - \\hat z_x| \\le k\\sigma_x \\;\\wedge\\; |z_y - \\hat z_y| \\le k\\sigma_y
              \\iff \\max\\left(\\frac{|d_x|}{\\sigma_x}, \\frac{|d_y|}{\\sigma_y}\\right) \\le k

    Parameters
    ----------
    z : (2,) or (N, 2) array_like
        Mark, metres.
    z_pred : (2,) or (N, 2) array_like
        Gate centre (prediction), metres.
    sigma_x, sigma_y : float or (N,) array_like
        Standard deviations of the summed deviation of a true mark from the
        prediction along x and y, metres, > 0.
    k : float
        Half-width in sigmas, > 0 (see
        :func:`plotgate.core.gates.thresholds.rectangular_coefficient`).

    Returns
    -------
    result : GateResult
        ``statistic`` is :math:`\\max(|d_x|/\\sigma_x, |d_y|/\\sigma_y)` (sigmas)
        and ``threshold`` is k.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If a sigma or k is <= 0, or the shapes do not fit.

    References
    ----------
    .. [1] Seed 003 (textbook chapter on secondary radar processing), the
       rectangular gate of Fig. 3.6 b: centre x, y and half-sizes
       :math:`\\Delta x_{str}, \\Delta y_{str}`, sized in summed sigmas.

    Examples
    --------
    >>> res = rectangular_gate([[25.0, 50.0], [31.0, 0.0]], [0.0, 0.0], 10.0, 20.0, k=3.0)
    >>> res.inside, res.statistic
    (array([ True, False]), array([2.5, 3.1]))
    """
    z = as_points("z", z)
    z_pred = as_points("z_pred", z_pred)
    sigma_x = standard_deviation("sigma_x", sigma_x)
    sigma_y = standard_deviation("sigma_y", sigma_y)
    k = positive_coefficient("k", k)
    n = pair_count(
        z=z.shape[:-1], z_pred=z_pred.shape[:-1], sigma_x=sigma_x.shape, sigma_y=sigma_y.shape
    )
    dx, dy = difference(z_pred, z)
    statistic = window_statistic(dx, dy, sigma_x, sigma_y)
    return gate_result(n, statistic <= k, statistic, k)
