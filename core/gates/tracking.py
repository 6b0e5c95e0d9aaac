"""Tracking gates: does a mark fall in the gate around a prediction?

The chi-square ellipse gate rho = nu^T S^-1 nu <= gamma "used for gating during
tracking" (Konovalov, his ref. [6]; gamma from P_G as in his two-stage procedure),
the innovation covariance S = H P H^T + R it needs (Konovalov, refs. [6]/[7]), and
the rectangular gate |d_i| <= k sigma_i of the secondary-processing textbook
(Fig. 3.6 b). Each gate kind is a frozen dataclass of its parameters with its
vectorized ``test``, its ``region`` and ``contains`` on a gating problem (as in
:mod:`plotgate.core.gates.capture`). The ellipse gate's ``test`` is a compiled kernel
(:mod:`plotgate.core.gates.kernels`) beside its numpy ``test_reference``. Symbols and
batching as in :mod:`plotgate.core.gates` and :mod:`plotgate.core.gates.results`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError, PlotgateError
from plotgate.core.gates.kernels import as_rows, ellipse_test
from plotgate.core.gates.parameters import positive_coefficient, standard_deviation
from plotgate.core.gates.regions import (
    ALL_ROWS,
    MarkGeometry,
    Rows,
    StarRegion,
    full_turn,
    no_kinks,
    radial_form,
    radial_region,
)
from plotgate.core.gates.results import GateResult, difference, gate_result, window_statistic
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.sym2 import Sym2, quadratic_form, sym2
from plotgate.core.validation import (
    as_array,
    as_covariance,
    as_float_array,
    as_points,
    pair_count,
    require_scalar,
    to_pairs,
)

__all__ = ["EllipseGate", "RectangularGate", "innovation_covariance"]


@dataclass(frozen=True)
class EllipseGate:
    """Chi-square ellipse gate around a predicted mark.

    .. math:: \\boldsymbol{\\nu} = \\mathbf{z} - \\hat{\\mathbf{z}}, \\quad
              \\rho = \\boldsymbol{\\nu}^T \\mathbf{S}^{-1} \\boldsymbol{\\nu} \\le \\gamma

    rho is evaluated in closed form (LDL^T of the 2x2 S), with no inverse or solve.

    Attributes
    ----------
    P_G : float
        Gating probability, in (0, 1); gamma = ``gate_threshold(P_G, 2)``.
    offset : (2,) tuple of float
        In a gating problem (``region``, ``contains``): the predicted displacement
        z_pred - z1, m. Default none.
    S : (2, 2) or (N, 2, 2) ndarray or None
        In a gating problem: the innovation covariance, m^2; default B = P1 + P2.

    References
    ----------
    .. [1] A. A. Konovalov, two-stage procedure, ellipse test "in the known way used
       for gating during tracking" (his ref. [6]): residual, its covariance,
       :math:`\\rho = \\nu^T B^{-1} \\nu` compared with gamma.
    """

    P_G: float
    offset: tuple[float, float] = (0.0, 0.0)
    S: np.ndarray | None = None

    def test(self, z: ArrayLike, z_pred: ArrayLike, S: ArrayLike) -> GateResult:
        """Test marks z against predictions z_pred with innovation covariance S.

        Parameters
        ----------
        z : (2,) or (N, 2) array_like
            Mark, metres.
        z_pred : (2,) or (N, 2) array_like
            Predicted mark (gate centre), metres.
        S : (2, 2) or (N, 2, 2) array_like
            Innovation covariance in m^2, symmetric positive definite
            (see :func:`innovation_covariance`).

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

        Examples
        --------
        >>> res = EllipseGate(0.9).test([[2.0, 1.0], [4.0, 2.0]], [0.0, 0.0], np.diag([4.0, 1.0]))
        >>> res.inside, res.statistic
        (array([ True, False]), array([2., 8.]))
        """
        try:
            z_k = as_float_array("z", z, (2,))
            z_pred_k = as_float_array("z_pred", z_pred, (2,))
            S_k = as_float_array("S", S, (2, 2))
            gamma = self.threshold
            n = pair_count(z=z_k.shape[:-1], z_pred=z_pred_k.shape[:-1], S=S_k.shape[:-2])
        except PlotgateError:
            return self.test_reference(z, z_pred, S)  # raises the reference's error
        rho, inside = np.empty(n), np.empty(n, dtype=bool)
        args = (as_rows(z_k, 2), as_rows(z_pred_k, 2), as_rows(S_k, 4))
        if ellipse_test(*args, gamma, rho, inside) >= 0:
            return self.test_reference(z, z_pred, S)  # raises the reference's error
        return GateResult(inside, rho, gamma)

    def test_reference(self, z: ArrayLike, z_pred: ArrayLike, S: ArrayLike) -> GateResult:
        """:meth:`test` in numpy: the reference its compiled kernel is tested against.

        Same parameters, result and errors as :meth:`test`; each check and each step of
        rho is one vectorized pass.
        """
        z = as_points("z", z)
        z_pred = as_points("z_pred", z_pred)
        S = as_covariance("S", S)
        gamma = self.threshold
        n = pair_count(z=z.shape[:-1], z_pred=z_pred.shape[:-1], S=S.shape[:-2])
        nu_x, nu_y = difference(z_pred, z)
        rho = self.statistic(nu_x, nu_y, sym2(S))
        return gate_result(n, rho <= gamma, rho, gamma)

    @property
    def threshold(self) -> float:
        """gamma = ``gate_threshold(P_G, 2)``, the bound on rho (P_G checked)."""
        require_scalar("P_G", self.P_G)
        return float(gate_threshold(self.P_G))

    @staticmethod
    def statistic(nu_x: np.ndarray, nu_y: np.ndarray, S: Sym2) -> np.ndarray:
        """rho = nu^T S^-1 nu of innovations (nu_x, nu_y), m, and covariances S, m^2.

        The gate's statistic without its input checks, in closed form
        (:func:`~plotgate.core.sym2.quadratic_form`): for callers whose innovations and
        positive definite S are already checked or built, such as initiation's track
        gates, whose session state may carry covariances far beyond the condition number
        :meth:`test` accepts.
        """
        return quadratic_form(nu_x, nu_y, S)

    def _S(self, g: MarkGeometry) -> np.ndarray:
        """The innovation covariance of each problem of g, (N, 2, 2)."""
        if self.S is None:
            B: np.ndarray = g.P1 + g.P2
            return B
        return np.broadcast_to(as_covariance("S", self.S), (g.n, 2, 2))

    def region(self, g: MarkGeometry) -> StarRegion:
        """Direction u from z1 + offset: [0, sqrt(gamma / u^T S^-1 u)]."""
        require_scalar("P_G", self.P_G)
        gamma = float(gate_threshold(self.P_G))
        form = radial_form(g.n, (0.0, 0.0), (0.0, 1.0), (sym2(self._S(g)), gamma))
        return radial_region(g.n, as_points("offset", self.offset), no_kinks(g.n), form)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        z_pred = g.z1[i] + as_points("offset", self.offset)
        return self.test(z2, z_pred, self._S(g)[i]).inside


@dataclass(frozen=True)
class RectangularGate:
    """Rectangular gate: each Cartesian coordinate within k sigmas of the prediction.

    .. math:: |z_x - \\hat z_x| \\le k\\sigma_x \\;\\wedge\\; |z_y - \\hat z_y| \\le k\\sigma_y
              \\iff \\max\\left(\\frac{|d_x|}{\\sigma_x}, \\frac{|d_y|}{\\sigma_y}\\right) \\le k

    Attributes
    ----------
    k : float
        Half-width in sigmas, > 0 (see
        :func:`plotgate.core.gates.thresholds.rectangular_coefficient`).
    offset : (2,) tuple of float
        In a gating problem (``region``, ``contains``): the predicted displacement
        z_pred - z1, m. Default none.
    sigma_x, sigma_y : float or None
        In a gating problem: the sigmas, m; default sqrt(B_xx), sqrt(B_yy).

    References
    ----------
    .. [1] The secondary-processing textbook, the rectangular gate of Fig. 3.6 b:
       centre x, y and half-sizes :math:`\\Delta x_{str}, \\Delta y_{str}`, sized in
       summed sigmas.
    """

    k: float
    offset: tuple[float, float] = (0.0, 0.0)
    sigma_x: float | None = None
    sigma_y: float | None = None

    def test(
        self, z: ArrayLike, z_pred: ArrayLike, sigma_x: ArrayLike, sigma_y: ArrayLike
    ) -> GateResult:
        """Test marks z against predictions z_pred, k sigmas wide per axis.

        Parameters
        ----------
        z : (2,) or (N, 2) array_like
            Mark, metres.
        z_pred : (2,) or (N, 2) array_like
            Gate centre (prediction), metres.
        sigma_x, sigma_y : float or (N,) array_like
            Standard deviations of the summed deviation of a true mark from the
            prediction along x and y, metres, > 0.

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

        Examples
        --------
        >>> res = RectangularGate(k=3.0).test([[25.0, 50.0], [31.0, 0.0]], [0.0, 0.0], 10.0, 20.0)
        >>> res.inside, res.statistic
        (array([ True, False]), array([2.5, 3.1]))
        """
        k = self.k
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

    def half_sizes(self, g: MarkGeometry) -> tuple[np.ndarray, np.ndarray]:
        """k sigma_x and k sigma_y of each problem of g, m."""
        k = positive_coefficient("k", self.k)
        s_x = (
            np.sqrt(g.B.xx)
            if self.sigma_x is None
            else standard_deviation("sigma_x", self.sigma_x)
        )
        s_y = (
            np.sqrt(g.B.yy)
            if self.sigma_y is None
            else standard_deviation("sigma_y", self.sigma_y)
        )
        return to_pairs(k * s_x, g.n), to_pairs(k * s_y, g.n)

    def region(self, g: MarkGeometry) -> StarRegion:
        """Direction u from z1 + offset: [0, the distance to the rectangle's edge]."""
        hx, hy = self.half_sizes(g)
        corner = np.arctan2(hy, hx)[:, None]
        hx, hy = hx[:, None], hy[:, None]

        def radii(theta: np.ndarray, rows: Rows = ALL_ROWS) -> tuple[np.ndarray, np.ndarray]:
            c, s = np.abs(np.cos(theta)), np.abs(np.sin(theta))
            with np.errstate(divide="ignore"):
                hi = np.minimum(hx[rows] / c, hy[rows] / s)
            return np.zeros(theta.shape), hi

        kinks = np.concatenate([corner, np.pi - corner, np.pi + corner, -corner], axis=-1)
        return full_turn(g.n, as_points("offset", self.offset), kinks, radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        hx, hy = self.half_sizes(g)
        z_pred = g.z1[i] + as_points("offset", self.offset)
        return self.test(z2, z_pred, hx[i] / self.k, hy[i] / self.k).inside


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
    .. [1] A. A. Konovalov, his refs. [6]/[7]: the residual covariance of
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
