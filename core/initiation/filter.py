"""Constant-velocity track filter: predict and update as pure functions, batched.

In the style of filterpy's ``kalman`` functions: each function takes the state and
returns the new one, nothing is held between calls. Every argument carries a leading
axis of m tracks.

Symbols
-------
x : (m, 4) state [x, y, vx, vy], m and m/s.
P : (m, 4, 4) its covariance.
z : (m, 2) plot position, m; R : (m, 2, 2) its covariance, m^2.
dt : (m,) time since each track's last update, s.
q : white-acceleration spectral density, m^2/s^3.
K : (m, 4, 2) gain.

The measurement is the position, H = [I 0]. The update takes any gain (the Kalman gain,
or the alpha-beta smoother's fixed gains) and propagates the covariance in Joseph form,
which stays right for a gain that is not the optimal one.
"""

from __future__ import annotations

import numpy as np

from plotgate.core.sym2 import inverse_matrix

__all__ = [
    "SPEED_SIGMAS",
    "alpha_beta_gain",
    "kalman_gain",
    "one_point",
    "predict",
    "speed_excess",
    "two_point",
    "update",
]

SPEED_SIGMAS = 6.0
"""How far (in its own velocity sigmas) a track's speed may exceed v_max: for a target
within v_max and a filter that is consistent, the 2-D velocity error passes 6 sigma of its
largest axis with probability at most exp(-6^2 / 2) = 1.5e-8 a scan."""


def predict(
    x: np.ndarray, P: np.ndarray, dt: np.ndarray, q: float
) -> tuple[np.ndarray, np.ndarray]:
    """Constant-velocity prediction over dt with white acceleration q.

    .. math:: \\mathbf{x}^- = F\\mathbf{x}, \\quad P^- = F P F^T + q Q, \\quad
              F = \\begin{bmatrix} I & \\Delta t\\, I \\\\ 0 & I \\end{bmatrix}, \\quad
              Q = \\begin{bmatrix} \\Delta t^3/3\\, I & \\Delta t^2/2\\, I \\\\
              \\Delta t^2/2\\, I & \\Delta t\\, I \\end{bmatrix}

    Parameters
    ----------
    x : (m, 4) ndarray
    P : (m, 4, 4) ndarray
    dt : (m,) ndarray
        Prediction interval of each track, s.
    q : float
        White-acceleration spectral density, m^2/s^3.

    Returns
    -------
    x, P : ndarray
        The predicted state and covariance.

    Examples
    --------
    >>> x, P = predict(np.array([[0.0, 0.0, 10.0, -5.0]]), np.eye(4)[None], np.array([2.0]), 0.0)
    >>> x.tolist(), P[0, 0].tolist()
    ([[20.0, -10.0, 10.0, -5.0]], [5.0, 0.0, 2.0, 0.0])
    """
    d = dt[:, None]
    xp = np.concatenate([x[:, :2] + d * x[:, 2:], x[:, 2:]], axis=1)
    F = np.tile(np.eye(4), (dt.size, 1, 1))
    F[:, 0, 2] = F[:, 1, 3] = dt
    Q = np.zeros_like(F)
    dt2, dt3 = dt * dt / 2.0, dt**3 / 3.0
    for i in (0, 1):
        Q[:, i, i], Q[:, i, i + 2], Q[:, i + 2, i], Q[:, i + 2, i + 2] = dt3, dt2, dt2, dt
    Pp: np.ndarray = F @ P @ np.swapaxes(F, 1, 2) + q * Q
    return xp, Pp


def kalman_gain(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Kalman gain K = P H^T S^-1 of a position measurement, S = H P H^T + R.

    Parameters
    ----------
    P : (m, 4, 4) ndarray
        Predicted covariance.
    R : (m, 2, 2) ndarray
        Plot covariance.

    Returns
    -------
    K : (m, 4, 2) ndarray
    """
    K: np.ndarray = P[:, :, :2] @ inverse_matrix(P[:, :2, :2] + R)
    return K


def alpha_beta_gain(
    n: np.ndarray, dt: np.ndarray, alpha_min: float, beta_min: float
) -> np.ndarray:
    """Gain of the alpha-beta smoother for the n-th plot of each track.

    .. math:: \\alpha_n = \\max\\left(\\frac{2(2n - 1)}{n(n + 1)}, \\alpha_{min}\\right),
              \\quad \\beta_n = \\max\\left(\\frac{6}{n(n + 1)}, \\beta_{min}\\right)

    The position takes alpha_n of the innovation and the velocity beta_n / dt of it
    (0 for dt = 0).

    Parameters
    ----------
    n : (m,) ndarray
        Number of plots of each track, this one included.
    dt : (m,) ndarray
        Time since each track's last update, s.
    alpha_min, beta_min : float
        Floors of the gains.

    Returns
    -------
    K : (m, 4, 2) ndarray

    References
    ----------
    .. [1] The secondary-processing textbook, alpha-beta smoothing coefficients
       (Fig. 3.5).

    Examples
    --------
    >>> K = alpha_beta_gain(np.array([3.0]), np.array([2.0]), 0.2, 0.05)
    >>> float(K[0, 0, 0]), float(K[0, 2, 0])
    (0.8333333333333334, 0.25)
    """
    alpha = np.maximum(2.0 * (2.0 * n - 1.0) / (n * (n + 1.0)), alpha_min)
    beta = np.maximum(6.0 / (n * (n + 1.0)), beta_min)
    rate = np.divide(beta, dt, out=np.zeros_like(dt), where=dt > 0)
    K = np.zeros((n.shape[0], 4, 2))
    K[:, 0, 0] = K[:, 1, 1] = alpha
    K[:, 2, 0] = K[:, 3, 1] = rate
    return K


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray, K: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Update with a position plot and a gain K, the covariance in Joseph form.

    .. math:: \\mathbf{x}^+ = \\mathbf{x} + K(\\mathbf{z} - H\\mathbf{x}), \\quad
              P^+ = (I - KH) P (I - KH)^T + K R K^T

    The result is symmetrized, (P^+ + P^{+T}) / 2.

    Parameters
    ----------
    x : (m, 4) ndarray
    P : (m, 4, 4) ndarray
    z : (m, 2) ndarray
    R : (m, 2, 2) ndarray
    K : (m, 4, 2) ndarray
        Gain (:func:`kalman_gain`, :func:`alpha_beta_gain`).

    Returns
    -------
    x, P : ndarray
        The updated state and covariance.

    Examples
    --------
    >>> x, P = np.zeros((1, 4)), np.eye(4)[None] * 100.0
    >>> R = np.eye(2)[None] * 100.0
    >>> x, P = update(x, P, np.array([[10.0, 0.0]]), R, kalman_gain(P, R))
    >>> x.tolist(), float(P[0, 0, 0])
    ([[5.0, 0.0, 0.0, 0.0]], 50.0)
    """
    nu = z - x[:, :2]
    x = x + np.einsum("mij,mj->mi", K, nu)
    IKH = np.tile(np.eye(4), (x.shape[0], 1, 1))
    IKH[:, :, :2] -= K
    P = IKH @ P @ np.swapaxes(IKH, 1, 2) + K @ R @ np.swapaxes(K, 1, 2)
    return x, 0.5 * (P + np.swapaxes(P, 1, 2))


def two_point(
    z1: np.ndarray, R1: np.ndarray, z2: np.ndarray, R2: np.ndarray, tau: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """State from two plots tau apart and its exact covariance.

    .. math:: \\mathbf{x} = \\begin{bmatrix} \\mathbf{z}_2 \\\\
              (\\mathbf{z}_2 - \\mathbf{z}_1)/\\tau \\end{bmatrix}, \\quad
              P = \\begin{bmatrix} R_2 & R_2/\\tau \\\\ R_2/\\tau &
              (R_1 + R_2)/\\tau^2 \\end{bmatrix}

    Parameters
    ----------
    z1, z2 : (m, 2) ndarray
        The first and second plots, m.
    R1, R2 : (m, 2, 2) ndarray
        Their covariances, m^2.
    tau : (m,) ndarray
        Time from the first to the second, s.

    Returns
    -------
    x, P : ndarray

    Examples
    --------
    >>> R = np.eye(2)[None] * 4.0
    >>> x, P = two_point(np.zeros((1, 2)), R, np.array([[10.0, 0.0]]), R, np.array([2.0]))
    >>> x.tolist(), float(P[0, 2, 2])
    ([[10.0, 0.0, 5.0, 0.0]], 2.0)
    """
    t = tau[:, None, None]
    P = np.zeros((tau.size, 4, 4))
    P[:, :2, :2] = R2
    P[:, :2, 2:] = P[:, 2:, :2] = R2 / t
    P[:, 2:, 2:] = (R1 + R2) / (t * t)
    return np.concatenate([z2, (z2 - z1) / tau[:, None]], axis=1), P


def one_point(z: np.ndarray, R: np.ndarray, v_max: float) -> tuple[np.ndarray, np.ndarray]:
    """State from one plot and a velocity prior: speeds uniform over |v| <= v_max.

    .. math:: \\mathbf{x} = \\begin{bmatrix} \\mathbf{z} \\\\ 0 \\end{bmatrix}, \\quad
              P = \\begin{bmatrix} R & 0 \\\\ 0 & \\tfrac14 v_{max}^2 I \\end{bmatrix}

    The velocity carries the mean and covariance of the uniform disc of speeds (per axis
    v_max^2 / 4): Blackman and Popoli's one-point initiation, ch. 6. Predicted and updated
    with a second plot, it gives the two-point state with the speed bound folded in,
    whose cross-range velocity error is bounded by v_max where :func:`two_point`'s is
    sqrt(2) sigma_cross / tau (54 m/s for 0.2 degrees at 11 km, 1 s apart).

    Parameters
    ----------
    z : (m, 2) ndarray
        The plot, m.
    R : (m, 2, 2) ndarray
        Its covariance, m^2.
    v_max : float
        Largest target speed, m/s.

    Returns
    -------
    x, P : ndarray

    Examples
    --------
    >>> x, P = one_point(np.array([[10.0, 20.0]]), np.eye(2)[None] * 4.0, 30.0)
    >>> x.tolist(), np.diag(P[0]).tolist()
    ([[10.0, 20.0, 0.0, 0.0]], [4.0, 4.0, 225.0, 225.0])
    """
    m = z.shape[0]
    P = np.zeros((m, 4, 4))
    P[:, :2, :2] = R
    P[:, 2, 2] = P[:, 3, 3] = 0.25 * v_max * v_max
    return np.concatenate([z, np.zeros((m, 2))], axis=1), P


def speed_excess(x: np.ndarray, P: np.ndarray, v_max: float) -> np.ndarray:
    """How far each track's speed lies beyond v_max, in sigmas of its velocity estimate.

    .. math:: \\frac{|\\mathbf{v}| - v_{max}}{\\sqrt{\\lambda_{max}(P_{vv})}}

    Negative within v_max. A track above :data:`SPEED_SIGMAS` is faster than any target
    the settings describe, estimation noise allowed for: initiation drops it (reason
    ``"speed"``) and a state that carries one is refused.

    Parameters
    ----------
    x : (m, 4) ndarray
    P : (m, 4, 4) ndarray
        Track states and their covariances (positive definite).
    v_max : float
        Largest target speed, m/s.

    Returns
    -------
    excess : (m,) ndarray

    Examples
    --------
    >>> P = np.eye(4)[None] * 4.0
    >>> speed_excess(np.array([[0.0, 0.0, 30.0, 40.0]]), P, 40.0).tolist()
    [5.0]
    """
    Pvv = P[:, 2:, 2:]
    a, b, d = Pvv[:, 0, 0], 0.5 * (Pvv[:, 0, 1] + Pvv[:, 1, 0]), Pvv[:, 1, 1]
    largest = 0.5 * (a + d) + np.hypot(0.5 * (a - d), b)  # the 2 x 2 closed form
    excess: np.ndarray = (np.hypot(x[:, 2], x[:, 3]) - v_max) / np.sqrt(largest)
    return excess
