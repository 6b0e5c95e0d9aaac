"""Polar gates: range and azimuth windows about a sensor.

Seed 002 (C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar coordinates),
section 3.1: the sector gate about a prediction, eq. (1) (range) and eq. (2)
(azimuth), and the first-association windows before any velocity is known, eq. (3)
(range, grown by v_max tau) and eq. (4) (azimuth, grown by the largest bearing
change). Seed 003, the polar gate of Fig. 3.6 a. Azimuth differences are wrapped
to (-pi, pi]. Symbols and batching as in :mod:`plotgate.core.gates.results`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.frames import wrap_angle
from plotgate.core.gates.parameters import positive_coefficient, ring_radii, standard_deviation
from plotgate.core.gates.results import GateResult, gate_result, window_statistic
from plotgate.core.validation import as_array, pair_count, require_nonnegative

__all__ = ["first_association_gate", "sector_gate"]


def sector_gate(
    r: ArrayLike,
    az: ArrayLike,
    r_pred: ArrayLike,
    az_pred: ArrayLike,
    sigma_r: ArrayLike,
    sigma_az: ArrayLike,
    sigma_r_pred: ArrayLike,
    sigma_az_pred: ArrayLike,
    K_R: float,
    K_az: float,
) -> GateResult:
    """Polar sector gate around a predicted range and azimuth.

    .. math:: |r - \\hat r| \\le K_R\\sqrt{\\sigma_r^2 + \\hat\\sigma_r^2}, \\quad
              |\\mathrm{wrap}(az - \\widehat{az})| \\le
              K_{az}\\sqrt{\\sigma_{az}^2 + \\hat\\sigma_{az}^2}

    Parameters
    ----------
    r : float or (N,) array_like
        Measured range, metres, >= 0.
    az : float or (N,) array_like
        Measured azimuth, radians.
    r_pred : float or (N,) array_like
        Predicted range, metres.
    az_pred : float or (N,) array_like
        Predicted azimuth, radians.
    sigma_r, sigma_az : float or (N,) array_like
        Measurement standard deviations of range (m) and azimuth (rad), > 0.
    sigma_r_pred, sigma_az_pred : float or (N,) array_like
        Prediction standard deviations of range (m) and azimuth (rad), > 0.
    K_R, K_az : float
        Window coefficients, > 0.

    Returns
    -------
    result : GateResult
        ``statistic`` is the larger of the two offsets as a fraction of its
        window, :math:`\\max(|\\Delta r|/W_R, |\\Delta az|/W_{az})`, and
        ``threshold`` is 1.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If r < 0, a sigma or coefficient is <= 0, or the shapes do not fit.

    References
    ----------
    .. [1] C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar
       coordinates, seed 002, section 3.1, eq. (1) (range) and eq. (2) (azimuth).
    .. [2] Seed 003, the polar gate of Fig. 3.6 a.

    Examples
    --------
    Windows of 15 m and 0.015 rad; the second mark is 20 m off in range. The third
    sits across the +-pi seam from its prediction, 0.0032 rad away.

    >>> res = sector_gate([10_010.0, 10_020.0, 5_000.0], [0.11, 0.1, -3.14],
    ...                   [10_000.0, 10_000.0, 5_000.0], [0.1, 0.1, 3.14],
    ...                   3.0, 0.003, 4.0, 0.004, K_R=3.0, K_az=3.0)
    >>> res.inside, res.statistic.round(3)
    (array([ True, False,  True]), array([0.667, 1.333, 0.212]))
    """
    r = as_array("r", r)
    az = as_array("az", az)
    r_pred = as_array("r_pred", r_pred)
    az_pred = as_array("az_pred", az_pred)
    require_nonnegative("r", r)
    sigma_r = standard_deviation("sigma_r", sigma_r)
    sigma_az = standard_deviation("sigma_az", sigma_az)
    sigma_r_pred = standard_deviation("sigma_r_pred", sigma_r_pred)
    sigma_az_pred = standard_deviation("sigma_az_pred", sigma_az_pred)
    K_R = positive_coefficient("K_R", K_R)
    K_az = positive_coefficient("K_az", K_az)
    n = pair_count(
        r=r.shape,
        az=az.shape,
        r_pred=r_pred.shape,
        az_pred=az_pred.shape,
        sigma_r=sigma_r.shape,
        sigma_az=sigma_az.shape,
        sigma_r_pred=sigma_r_pred.shape,
        sigma_az_pred=sigma_az_pred.shape,
    )
    W_R = K_R * np.hypot(sigma_r, sigma_r_pred)
    W_az = K_az * np.hypot(sigma_az, sigma_az_pred)
    statistic = window_statistic(r - r_pred, wrap_angle(az - az_pred), W_R, W_az)
    return gate_result(n, statistic <= 1.0, statistic, 1.0)


def first_association_gate(
    r1: ArrayLike,
    az1: ArrayLike,
    r2: ArrayLike,
    az2: ArrayLike,
    tau: float,
    v_max: float,
    sigma_r1: ArrayLike,
    sigma_az1: ArrayLike,
    sigma_r2: ArrayLike,
    sigma_az2: ArrayLike,
    K_R: float,
    K_az: float,
) -> GateResult:
    """Polar windows for the first association, before any velocity is known.

    .. math:: |r_2 - r_1| \\le W_R = v_{max}\\tau + K_R\\sqrt{\\sigma_{r1}^2 + \\sigma_{r2}^2}

    .. math:: |\\mathrm{wrap}(az_2 - az_1)| \\le W_{az} =
              \\arcsin\\left(\\min\\left(1, \\frac{v_{max}\\tau}{r_1}\\right)\\right)
              + K_{az}\\sqrt{\\sigma_{az1}^2 + \\sigma_{az2}^2}

    The arcsine term is the largest bearing change a target at range r1 can make
    in tau; within v_max tau of the sensor it is pi/2.

    Parameters
    ----------
    r1, az1 : float or (N,) array_like
        Range (m, >= 0) and azimuth (rad) of the first mark.
    r2, az2 : float or (N,) array_like
        Range (m, >= 0) and azimuth (rad) of the second mark.
    tau : float
        Time between the marks in seconds, > 0.
    v_max : float
        Largest target speed in m/s, >= 0.
    sigma_r1, sigma_az1, sigma_r2, sigma_az2 : float or (N,) array_like
        Range (m) and azimuth (rad) standard deviations of the two marks, > 0.
    K_R, K_az : float
        Window coefficients, > 0.

    Returns
    -------
    result : GateResult
        ``statistic`` is :math:`\\max(|r_2 - r_1|/W_R, |\\Delta az|/W_{az})` and
        ``threshold`` is 1.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If a range is negative, tau <= 0, v_max < 0, a sigma or coefficient is
        <= 0, or the shapes do not fit.

    References
    ----------
    .. [1] C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar
       coordinates, seed 002, section 3.1, eq. (3) (first range window) and
       eq. (4) (azimuth window with the tangential speed bound).

    Examples
    --------
    A ground target at 10 km, v_max = 25 m/s, tau = 1 s: W_R = 46.2 m and
    W_az = 0.0038 rad, so a mark 40 m further is inside and 0.005 rad off is not.

    >>> res = first_association_gate(10_000.0, 0.5, [10_040.0, 10_000.0], [0.5, 0.505],
    ...                              tau=1.0, v_max=25.0, sigma_r1=5.0, sigma_az1=3e-4,
    ...                              sigma_r2=5.0, sigma_az2=3e-4, K_R=3.0, K_az=3.0)
    >>> res.inside, res.statistic.round(3)
    (array([ True, False]), array([0.866, 1.325]))
    """
    r1 = as_array("r1", r1)
    az1 = as_array("az1", az1)
    r2 = as_array("r2", r2)
    az2 = as_array("az2", az2)
    require_nonnegative("r1", r1)
    require_nonnegative("r2", r2)
    _, R_max = ring_radii(tau, 0.0, v_max)
    sigma_r1 = standard_deviation("sigma_r1", sigma_r1)
    sigma_az1 = standard_deviation("sigma_az1", sigma_az1)
    sigma_r2 = standard_deviation("sigma_r2", sigma_r2)
    sigma_az2 = standard_deviation("sigma_az2", sigma_az2)
    K_R = positive_coefficient("K_R", K_R)
    K_az = positive_coefficient("K_az", K_az)
    n = pair_count(
        r1=r1.shape,
        az1=az1.shape,
        r2=r2.shape,
        az2=az2.shape,
        sigma_r1=sigma_r1.shape,
        sigma_az1=sigma_az1.shape,
        sigma_r2=sigma_r2.shape,
        sigma_az2=sigma_az2.shape,
    )
    W_R = R_max + K_R * np.hypot(sigma_r1, sigma_r2)
    far = r1 > R_max
    sin_turn = np.divide(R_max, r1, out=np.ones(np.shape(r1)), where=far)
    W_az = np.arcsin(sin_turn) + K_az * np.hypot(sigma_az1, sigma_az2)
    statistic = window_statistic(r2 - r1, wrap_angle(az2 - az1), W_R, W_az)
    return gate_result(n, statistic <= 1.0, statistic, 1.0)
