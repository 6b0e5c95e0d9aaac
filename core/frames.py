"""Polar and Cartesian radar frames.

Symbols
-------
x, y : Cartesian position, x east and y north (metres); ``xy`` has shape (..., 2).
r : range from the sensor (metres), >= 0.
az : azimuth (radians), clockwise from north: x = r sin(az), y = r cos(az).
sigma_r, sigma_az : standard deviations of range (metres) and azimuth (radians).
J : Jacobian d(x, y)/d(r, az) = [[sin az, r cos az], [cos az, -r sin az]].
P : Cartesian covariance (..., 2, 2) in m^2.

All functions broadcast over leading axes and return new arrays. Angle
differences are wrapped to (-pi, pi].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import GeometryError
from plotgate.core.validation import (
    as_array,
    as_covariance,
    as_points,
    broadcast_batch,
    first_index,
    require_nonnegative,
    require_positive,
)

__all__ = [
    "wrap_finite",
    "cartesian_covariance_to_polar",
    "cartesian_to_polar",
    "polar_covariance_to_cartesian",
    "polar_to_cartesian",
    "wrap_angle",
]

_TWO_PI = 2.0 * np.pi


def wrap_finite(a: np.ndarray) -> np.ndarray:
    """Wrap angles known to be finite to (-pi, pi]: :func:`wrap_angle` without its check."""
    w = np.pi - np.mod(np.pi - a, _TWO_PI)
    # np.mod may round up to exactly 2 pi for arguments just below a multiple of it
    return np.where(w <= -np.pi, w + _TWO_PI, w)[()]  # [()]: 0-d array to scalar


def wrap_angle(a: ArrayLike) -> float | np.ndarray:
    """Wrap angles to the interval (-pi, pi].

    .. math:: \\mathrm{wrap}(a) = \\pi - ((\\pi - a) \\bmod 2\\pi)

    Parameters
    ----------
    a : float or ndarray
        Angles in radians, any shape.

    Returns
    -------
    wrapped : float or ndarray
        The same angles in (-pi, pi]; pi stays pi and -pi maps to pi. A float for
        scalar input.

    Raises
    ------
    NonFiniteError
        If a contains NaN or infinity (``field="a"``).

    References
    ----------
    .. [1] Mu et al., eq. 2 and 4: the sector gates compare azimuth differences, which
       plotgate always wraps to (-pi, pi] (docs/architecture.md, core).

    Examples
    --------
    >>> float(wrap_angle(3 * np.pi / 2)) == -np.pi / 2
    True
    >>> wrap_angle(np.array([np.pi, -np.pi, 0.0])).tolist() == [np.pi, np.pi, 0.0]
    True
    """
    w = wrap_finite(as_array("a", a))
    return float(w) if w.ndim == 0 else w


def polar_to_cartesian(r: ArrayLike, az: ArrayLike) -> np.ndarray:
    """Convert range and azimuth to Cartesian positions.

    .. math:: x = r \\sin(az), \\quad y = r \\cos(az)

    Parameters
    ----------
    r : float or ndarray
        Range in metres, >= 0; broadcasts with az.
    az : float or ndarray
        Azimuth in radians, clockwise from north.

    Returns
    -------
    xy : (..., 2) ndarray
        Positions (x east, y north) in metres.

    Raises
    ------
    NonFiniteError
        If r or az contains NaN or infinity.
    ParameterError
        If a range is negative, or r and az do not broadcast.

    References
    ----------
    .. [1] The frame convention of docs/architecture.md (x east, y north, azimuth
       clockwise from north); Konovalov works in the radar's polar measurements (range
       and azimuth errors Delta R, Delta alpha).

    Examples
    --------
    >>> polar_to_cartesian(1000.0, np.pi / 2).round(9).tolist()
    [1000.0, 0.0]
    """
    r = as_array("r", r)
    az = as_array("az", az)
    require_nonnegative("r", r)
    shape = broadcast_batch(r=r.shape, az=az.shape)
    xy = np.empty((*shape, 2))
    xy[..., 0] = r * np.sin(az)
    xy[..., 1] = r * np.cos(az)
    return xy


def cartesian_to_polar(xy: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Convert Cartesian positions to range and azimuth.

    .. math:: r = \\sqrt{x^2 + y^2}, \\quad az = \\operatorname{atan2}(x, y)

    Parameters
    ----------
    xy : (..., 2) array_like
        Positions (x east, y north) in metres.

    Returns
    -------
    r : (...) ndarray
        Range in metres.
    az : (...) ndarray
        Azimuth in radians, clockwise from north, in (-pi, pi]; 0 at the origin.

    Raises
    ------
    NonFiniteError
        If xy contains NaN or infinity.
    ParameterError
        If the last axis of xy is not of length 2.

    References
    ----------
    .. [1] The frame convention of docs/architecture.md (x east, y north, azimuth
       clockwise from north).

    Examples
    --------
    >>> r, az = cartesian_to_polar(np.array([[0.0, -500.0], [300.0, 400.0]]))
    >>> r.tolist(), bool(az[0] == np.pi)
    ([500.0, 500.0], True)
    """
    xy = as_points("xy", xy)
    x, y = xy[..., 0], xy[..., 1]
    return np.hypot(x, y), wrap_finite(np.arctan2(x, y))


def polar_covariance_to_cartesian(
    r: ArrayLike,
    az: ArrayLike,
    sigma_r: ArrayLike,
    sigma_az: ArrayLike,
) -> np.ndarray:
    """Cartesian covariance of a polar measurement with independent errors.

    .. math:: P = J \\,\\mathrm{diag}(\\sigma_r^2, \\sigma_{az}^2)\\, J^T, \\quad
              J = \\begin{bmatrix} \\sin az & r\\cos az \\\\ \\cos az & -r\\sin az
              \\end{bmatrix}

    Parameters
    ----------
    r : float or ndarray
        Range in metres, >= 0.
    az : float or ndarray
        Azimuth in radians, clockwise from north.
    sigma_r : float or ndarray
        Range standard deviation in metres, > 0.
    sigma_az : float or ndarray
        Azimuth standard deviation in radians, > 0.

    Returns
    -------
    P : (..., 2, 2) ndarray
        Covariance of (x, y) in m^2; the arguments broadcast to its leading shape.

    Raises
    ------
    NonFiniteError
        If an argument contains NaN or infinity.
    ParameterError
        If r < 0, a sigma <= 0, or the arguments do not broadcast.

    References
    ----------
    .. [1] Konovalov: the measurement errors are independent in the frame of the
       line of sight (range and cross-range), which this maps to x, y through the
       Jacobian J above.

    Examples
    --------
    >>> P = polar_covariance_to_cartesian(10_000.0, 0.0, 100.0, 0.001)
    >>> P.round(9).tolist()
    [[100.0, 0.0], [0.0, 10000.0]]
    """
    r = as_array("r", r)
    az = as_array("az", az)
    sigma_r = as_array("sigma_r", sigma_r)
    sigma_az = as_array("sigma_az", sigma_az)
    require_nonnegative("r", r)
    require_positive("sigma_r", sigma_r)
    require_positive("sigma_az", sigma_az)
    shape = broadcast_batch(r=r.shape, az=az.shape, sigma_r=sigma_r.shape, sigma_az=sigma_az.shape)
    s, c = np.sin(az), np.cos(az)
    var_r = sigma_r * sigma_r
    var_t = (r * sigma_az) ** 2  # cross-range variance
    P = np.empty((*shape, 2, 2))
    P[..., 0, 0] = s * s * var_r + c * c * var_t
    P[..., 1, 1] = c * c * var_r + s * s * var_t
    P[..., 0, 1] = P[..., 1, 0] = s * c * (var_r - var_t)
    return P


def cartesian_covariance_to_polar(xy: ArrayLike, P: ArrayLike) -> np.ndarray:
    """Covariance of (r, az) from a Cartesian position and its covariance.

    .. math:: P_{polar} = G P G^T, \\quad G = J^{-1} =
              \\begin{bmatrix} \\sin az & \\cos az \\\\ \\cos az / r & -\\sin az / r
              \\end{bmatrix}

    where r, az are the polar coordinates of xy; G is the Jacobian of
    (r, az) with respect to (x, y), written in closed form.

    Parameters
    ----------
    xy : (..., 2) array_like
        Positions (x east, y north) in metres, not at the origin.
    P : (..., 2, 2) array_like
        Symmetric positive definite covariance of xy in m^2.

    Returns
    -------
    P_polar : (..., 2, 2) ndarray
        Covariance of (r, az): [[m^2, m rad], [m rad, rad^2]].

    Raises
    ------
    NonFiniteError
        If xy or P contains NaN or infinity.
    CovarianceError
        If P is not symmetric positive definite.
    GeometryError
        If a position is at the origin, where azimuth is undefined (``field="xy"``).
    ParameterError
        If the shapes are wrong or do not broadcast.

    References
    ----------
    .. [1] The Jacobian J above; Konovalov states measurement errors in range and
       azimuth (Delta R, Delta alpha).

    Examples
    --------
    >>> P = np.array([[100.0, 0.0], [0.0, 10_000.0]])
    >>> cartesian_covariance_to_polar(np.array([0.0, 10_000.0]), P).round(12).tolist()
    [[10000.0, 0.0], [0.0, 1e-06]]
    """
    xy = as_points("xy", xy)
    P = as_covariance("P", P)
    shape = broadcast_batch(xy=xy.shape[:-1], P=P.shape[:-2])
    x, y = xy[..., 0], xy[..., 1]
    r = np.hypot(x, y)
    at_origin = r == 0.0
    if at_origin.any():
        raise GeometryError(
            "xy", "is at the sensor (r = 0), where azimuth is undefined", first_index(at_origin)
        )
    s, c = x / r, y / r
    sc, ss, cc = s * c, s * s, c * c
    P_polar = np.empty((*shape, 2, 2))
    P11, P12, P22 = P[..., 0, 0], P[..., 0, 1], P[..., 1, 1]
    P_polar[..., 0, 0] = ss * P11 + 2.0 * sc * P12 + cc * P22
    P_polar[..., 1, 1] = (cc * P11 - 2.0 * sc * P12 + ss * P22) / (r * r)
    P_polar[..., 0, 1] = P_polar[..., 1, 0] = (sc * (P11 - P22) + (cc - ss) * P12) / r
    return P_polar
