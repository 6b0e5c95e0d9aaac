"""Gates: does a second mark fall in the gate set around a first mark or a prediction?

Symbols
-------
z1, z2 : first and second mark, (2,) or (N, 2), x east / y north in metres.
P1, P2 : their covariances, (2, 2) or (N, 2, 2), in m^2.
d : z2 - z1; B = P1 + P2, the covariance of d (seed 000, eq. 1).
tau : time between the marks (s); v_min, v_max : speed bounds (m/s).
R_min, R_max : v_min tau and v_max tau, the radii of the ring gate (m).
z, z_pred, S : a mark, its prediction and the innovation covariance; nu = z - z_pred.
rho : squared Mahalanobis distance nu^T S^-1 nu; gamma : its threshold for P_G.
r, az : range (m) and azimuth (rad, clockwise from north) of a polar mark.

Every gate tests N pairs at once. Marks, covariances, sigmas, ranges and azimuths
are per pair: each is either unbatched (shared by all pairs, e.g. one first mark
against N candidates) or has a leading axis of the common length N. Gate
parameters (tau, speeds, probabilities, coefficients) are scalars, so each gate
has one scalar threshold. Results are always (N,) arrays (N = 1 when nothing is
batched). Inputs are never modified.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from core._sym2 import largest_eigenvalue, quadratic_form, sym2
from core._validate import (
    as_array,
    as_covariance,
    as_points,
    as_scalar,
    first_index,
    pair_count,
    require_nonnegative,
    require_positive,
    require_scalar,
    to_pairs,
)
from core.errors import GeometryError, ParameterError
from core.frames import wrap_angle
from core.thresholds import expansion_coefficient, gate_threshold

__all__ = [
    "GateResult",
    "GateStage",
    "combined_gate",
    "ellipse_gate",
    "expanded_gate",
    "first_association_gate",
    "innovation_covariance",
    "rectangular_gate",
    "ring_gate",
    "sector_gate",
]


class GateStage(enum.IntEnum):
    """Stage of the combined gate that accepted a mark (seed 000, Fig. 4)."""

    NONE = 0  # rejected
    RING = 1  # inside the ring R_min <= |d| <= R_max
    INNER_ELLIPSE = 2  # inside the ellipse centred on the inner circle
    OUTER_ELLIPSE = 3  # inside the ellipse centred on the outer circle


@dataclass(frozen=True)
class GateResult:
    """Outcome of a gate test on N pairs.

    Attributes
    ----------
    inside : (N,) ndarray of bool
        The second mark falls in the gate.
    statistic : (N,) ndarray of float
        The tested quantity; its meaning and unit are documented per gate.
    threshold : float
        Acceptance bound on the statistic. For every gate but the ring gate
        ``inside == (statistic <= threshold)``; the ring gate also has the lower
        bound R_min (see :func:`ring_gate`).
    stage : (N,) ndarray of int8 or None
        :class:`GateStage` values, from :func:`combined_gate` only; None otherwise.
    """

    inside: np.ndarray
    statistic: np.ndarray
    threshold: float
    stage: np.ndarray | None = None


def _difference(
    a: np.ndarray, b: np.ndarray, n: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Components of b - a for (..., 2) positions, as (n,) arrays when n is given."""
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    if n is None:
        return dx, dy
    return to_pairs(dx, n), to_pairs(dy, n)


def _ring_radii(tau: float, v_min: float, v_max: float) -> tuple[float, float]:
    """Validate tau, v_min, v_max and return R_min = v_min tau, R_max = v_max tau."""
    tau = as_scalar("tau", tau)
    v_min = as_scalar("v_min", v_min)
    v_max = as_scalar("v_max", v_max)
    require_positive("tau", tau)
    require_nonnegative("v_min", v_min)
    require_nonnegative("v_max", v_max)
    if v_min > v_max:
        raise ParameterError("v_min", f"v_min ({v_min}) exceeds v_max ({v_max})")
    return v_min * tau, v_max * tau


def _gate_threshold(P_G: float) -> float:
    """gamma = gate_threshold(P_G, 2) for a scalar P_G."""
    require_scalar("P_G", P_G)
    return float(gate_threshold(P_G, 2))


def _positive_coefficient(name: str, value: float) -> float:
    k = as_scalar(name, value)
    require_positive(name, k)
    return k


def _sigma(name: str, value: ArrayLike) -> np.ndarray:
    """Validate a standard deviation: finite and > 0, scalar or (N,)."""
    sigma = as_array(name, value)
    require_positive(name, sigma)
    return sigma


def _window_statistic(
    dr: np.ndarray | float,
    daz: np.ndarray | float,
    W_R: np.ndarray | float,
    W_az: np.ndarray | float,
) -> np.ndarray:
    """max(|dr| / W_R, |daz| / W_az): the larger offset as a fraction of its window."""
    return np.maximum(np.abs(dr) / W_R, np.abs(daz) / W_az)


def _result(n: int, inside: np.ndarray, statistic: np.ndarray, threshold: float,
            stage: np.ndarray | None = None) -> GateResult:
    return GateResult(to_pairs(inside, n), to_pairs(statistic, n), float(threshold),
                      None if stage is None else to_pairs(stage, n))


def ring_gate(
    z1: ArrayLike, z2: ArrayLike, tau: float, v_min: float, v_max: float
) -> GateResult:
    """Ring capture gate: the distance travelled must fit the speed bounds.

    .. math:: R_{min} \\le |\\mathbf{z}_2 - \\mathbf{z}_1| \\le R_{max}, \\quad
              R_{min} = v_{min}\\tau, \\; R_{max} = v_{max}\\tau

    Parameters
    ----------
    z1 : (2,) or (N, 2) array_like
        First mark (gate centre), metres.
    z2 : (2,) or (N, 2) array_like
        Second mark, metres.
    tau : float
        Time between the marks in seconds, > 0.
    v_min, v_max : float
        Speed bounds in m/s, 0 <= v_min <= v_max.

    Returns
    -------
    result : GateResult
        ``statistic`` is the distance |d| in metres and ``threshold`` is R_max.
        The lower bound R_min also applies, so here ``inside`` is
        ``(R_min <= statistic) & (statistic <= threshold)``.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If tau <= 0, v_min < 0, v_min > v_max, or the shapes do not fit.

    References
    ----------
    .. [1] A. A. Konovalov, gate sizing and shaping for tentative track formation,
       seed 000, ring gate of Fig. 1: :math:`R_{min} = v_{min}\\tau`,
       :math:`R_{max} = v_{max}\\tau`, area eq. (5).

    Examples
    --------
    >>> res = ring_gate([0.0, 0.0], [[300.0, 400.0], [30.0, 40.0], [3000.0, 4000.0]],
    ...                 tau=5.0, v_min=20.0, v_max=500.0)
    >>> res.inside, res.statistic, res.threshold
    (array([ True, False, False]), array([ 500.,   50., 5000.]), 2500.0)
    """
    z1 = as_points("z1", z1)
    z2 = as_points("z2", z2)
    R_min, R_max = _ring_radii(tau, v_min, v_max)
    n = pair_count(z1=z1.shape[:-1], z2=z2.shape[:-1])
    dx, dy = _difference(z1, z2)
    dist = np.sqrt(dx * dx + dy * dy)
    inside = (dist >= R_min) & (dist <= R_max)
    return _result(n, inside, dist, R_max)


def expanded_gate(
    z1: ArrayLike,
    z2: ArrayLike,
    tau: float,
    v_max: float,
    sigma_r: ArrayLike,
    sigma_az: ArrayLike,
    p: float,
    sensor: ArrayLike = (0.0, 0.0),
) -> GateResult:
    """Expanded ellipse gate: the outer circle grown by K_g sigmas along and across the LOS.

    In the frame of the line of sight from the sensor to z1 (X along it, Y across),

    .. math:: \\left(\\frac{d_X}{a}\\right)^2 + \\left(\\frac{d_Y}{b}\\right)^2 \\le 1,
              \\quad a = R_{max} + K_g\\sigma_X, \\; b = R_{max} + K_g\\sigma_Y,

    with :math:`\\sigma_X = \\sigma_r`, :math:`\\sigma_Y = r_1\\sigma_{az}`,
    :math:`r_1 = |\\mathbf{z}_1 - \\mathbf{s}|` and
    :math:`K_g = \\sqrt{-2\\ln(1-p)}` (:func:`core.thresholds.expansion_coefficient`).

    Parameters
    ----------
    z1 : (2,) or (N, 2) array_like
        First mark (gate centre), metres.
    z2 : (2,) or (N, 2) array_like
        Second mark, metres.
    tau : float
        Time between the marks in seconds, > 0.
    v_max : float
        Largest target speed in m/s, >= 0; R_max = v_max tau.
    sigma_r : float or (N,) array_like
        Range standard deviation of the first mark, metres, > 0.
    sigma_az : float or (N,) array_like
        Azimuth standard deviation of the first mark, radians, > 0.
    p : float
        Probability behind K_g, in (0, 1).
    sensor : (2,) or (N, 2) array_like, optional
        Sensor position in metres. Default the origin.

    Returns
    -------
    result : GateResult
        ``statistic`` is :math:`(d_X/a)^2 + (d_Y/b)^2` (dimensionless) and
        ``threshold`` is 1.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If tau <= 0, v_max < 0, a sigma <= 0, p is not in (0, 1), or the shapes
        do not fit.
    GeometryError
        If z1 is at the sensor, where the line of sight is undefined (``field="z1"``).

    References
    ----------
    .. [1] A. A. Konovalov, seed 000, expanded gate after ref. [4] (Fig. 3):
       :math:`\\delta X(Y) = K_g\\sigma_{X(Y)}` with X along the radar-target
       direction; semi-axes :math:`a = v_{max}\\tau + K_g\\sigma_{1X}`,
       :math:`b = v_{max}\\tau + K_g\\sigma_{1Y}` in the false-mark comparison.

    Examples
    --------
    A first mark 10 km north of the sensor: the gate is longer along the line of
    sight (a = 929 m) than across it (b = 715 m).

    >>> res = expanded_gate([0.0, 10_000.0], [[0.0, 10_900.0], [900.0, 10_000.0]],
    ...                     tau=5.0, v_max=100.0, sigma_r=200.0, sigma_az=0.01, p=0.9)
    >>> res.inside, res.statistic.round(3)
    (array([ True, False]), array([0.938, 1.586]))
    """
    z1 = as_points("z1", z1)
    z2 = as_points("z2", z2)
    sensor = as_points("sensor", sensor)
    _, R_max = _ring_radii(tau, 0.0, v_max)
    sigma_r = _sigma("sigma_r", sigma_r)
    sigma_az = _sigma("sigma_az", sigma_az)
    require_scalar("p", p)
    K_g = float(expansion_coefficient(p))
    n = pair_count(z1=z1.shape[:-1], z2=z2.shape[:-1], sensor=sensor.shape[:-1],
                   sigma_r=sigma_r.shape, sigma_az=sigma_az.shape)
    los_x, los_y = _difference(sensor, z1)
    r1 = np.sqrt(los_x * los_x + los_y * los_y)
    at_sensor = r1 == 0.0
    if at_sensor.any():
        raise GeometryError("z1", "is at the sensor, so the line of sight is undefined",
                            first_index(at_sensor))
    e_x, e_y = los_x / r1, los_y / r1
    dx, dy = _difference(z1, z2)
    d_X = (dx * e_x + dy * e_y) / (R_max + K_g * sigma_r)
    d_Y = (dy * e_x - dx * e_y) / (R_max + K_g * r1 * sigma_az)
    statistic = d_X * d_X + d_Y * d_Y
    return _result(n, statistic <= 1.0, statistic, 1.0)


def combined_gate(
    z1: ArrayLike,
    P1: ArrayLike,
    z2: ArrayLike,
    P2: ArrayLike,
    tau: float,
    v_min: float,
    v_max: float,
    P_G: float,
) -> GateResult:
    """Two-stage combined gate of seed 000: the ring, else an ellipse on its nearest circle.

    A mark in the ring is accepted at once. Otherwise, with
    :math:`\\mathbf{u} = \\mathbf{d}/|\\mathbf{d}|`, the gate centre moves to the
    inner or outer circle along the ray from z1 through z2,

    .. math:: \\mathbf{c} = \\mathbf{z}_1 + R\\,\\mathbf{u}, \\quad
              R = \\begin{cases} R_{min} & |\\mathbf{d}| < R_{min} \\\\
                  R_{max} & |\\mathbf{d}| > R_{max} \\end{cases}, \\quad
              \\boldsymbol{\\nu} = \\mathbf{z}_2 - \\mathbf{c}, \\quad
              \\rho = \\boldsymbol{\\nu}^T \\mathbf{B}^{-1} \\boldsymbol{\\nu} \\le \\gamma,

    with :math:`\\mathbf{B} = \\mathbf{P}_1 + \\mathbf{P}_2` and
    :math:`\\gamma` = ``gate_threshold(P_G, 2)``. Since
    :math:`\\boldsymbol{\\nu} = (|\\mathbf{d}| - R)\\mathbf{u}`, this is computed as
    :math:`\\rho = \\delta^2\\, \\mathbf{d}^T\\mathbf{B}^{-1}\\mathbf{d} / |\\mathbf{d}|^2`
    with :math:`\\delta = \\max(|\\mathbf{d}| - R_{max}, R_{min} - |\\mathbf{d}|, 0)`,
    in closed form for all pairs at once. If d = 0 the direction is undefined and
    the most favourable one is used: :math:`\\rho = R_{min}^2/\\lambda_{max}(\\mathbf{B})`
    (a mark with :math:`|\\mathbf{d}|` below about 1e-154 m counts as d = 0).

    Parameters
    ----------
    z1 : (2,) or (N, 2) array_like
        First mark, metres.
    P1 : (2, 2) or (N, 2, 2) array_like
        Covariance of z1, m^2, symmetric positive definite.
    z2 : (2,) or (N, 2) array_like
        Second mark, metres.
    P2 : (2, 2) or (N, 2, 2) array_like
        Covariance of z2, m^2, symmetric positive definite.
    tau : float
        Time between the marks in seconds, > 0.
    v_min, v_max : float
        Speed bounds in m/s, 0 <= v_min <= v_max.
    P_G : float
        Gating probability of the ellipse stage, in (0, 1).

    Returns
    -------
    result : GateResult
        ``statistic`` is rho (0 for marks in the ring), ``threshold`` is gamma,
        and ``stage`` gives the :class:`GateStage` that accepted each mark
        (``NONE`` for rejected marks).

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    CovarianceError
        If P1 or P2 is not symmetric positive definite.
    ParameterError
        If tau <= 0, v_min < 0, v_min > v_max, P_G is not in (0, 1), or the
        shapes do not fit.

    References
    ----------
    .. [1] A. A. Konovalov, seed 000, the proposed two-stage gating procedure
       (Fig. 4): ring test, :math:`\\mathbf{c}_{min}`, :math:`\\mathbf{c}_{max}`,
       :math:`\\boldsymbol{\\nu}`, :math:`\\rho = \\boldsymbol{\\nu}^T\\mathbf{B}^{-1}
       \\boldsymbol{\\nu}` against :math:`\\gamma`; B = P1 + P2 before eq. (1).

    Examples
    --------
    B = 2e4 I m^2 and a ring from 100 m to 500 m: a mark in the ring, one 100 m
    beyond it, one 60 m short of it, one 400 m beyond it, and one at z1.

    >>> P = np.diag([1e4, 1e4])
    >>> z2 = [[300.0, 0.0], [0.0, 600.0], [40.0, 0.0], [0.0, 900.0], [0.0, 0.0]]
    >>> res = combined_gate([0.0, 0.0], P, z2, P, tau=10.0, v_min=10.0, v_max=50.0,
    ...                     P_G=0.9)
    >>> res.inside
    array([ True,  True,  True, False,  True])
    >>> res.statistic.round(3), round(res.threshold, 3)
    (array([0.  , 0.5 , 0.18, 8.  , 0.5 ]), 4.605)
    >>> [GateStage(s).name for s in res.stage]
    ['RING', 'OUTER_ELLIPSE', 'INNER_ELLIPSE', 'NONE', 'INNER_ELLIPSE']
    """
    z1 = as_points("z1", z1)
    z2 = as_points("z2", z2)
    P1 = as_covariance("P1", P1)
    P2 = as_covariance("P2", P2)
    R_min, R_max = _ring_radii(tau, v_min, v_max)
    gamma = _gate_threshold(P_G)
    n = pair_count(z1=z1.shape[:-1], P1=P1.shape[:-2], z2=z2.shape[:-1], P2=P2.shape[:-2])
    B = sym2(P1 + P2)
    dx, dy = _difference(z1, z2, n)
    dist2 = dx * dx + dy * dy
    dist = np.sqrt(dist2)
    inner = dist < R_min
    outer = dist > R_max
    # delta = |nu|: how far z2 lies outside the ring, 0 inside it
    delta = np.maximum(dist - R_max, R_min - dist)
    np.maximum(delta, 0.0, out=delta)
    delta *= delta
    at_z1 = dist2 == 0.0
    any_at_z1 = bool(at_z1.any())
    if any_at_z1:
        dist2[at_z1] = 1.0
    rho = quadratic_form(dx, dy, B)
    rho *= delta
    rho /= dist2
    if any_at_z1:
        rho = np.where(at_z1, R_min * R_min / largest_eigenvalue(B), rho)
    inside = rho <= gamma
    # RING + inner + 2 outer is RING, INNER_ELLIPSE or OUTER_ELLIPSE; times inside
    # it becomes NONE for rejected marks
    stage = outer.astype(np.int8)
    stage <<= 1
    stage += inner
    stage += GateStage.RING
    stage *= inside
    return _result(n, inside, rho, gamma, stage)


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
    gamma = _gate_threshold(P_G)
    n = pair_count(z=z.shape[:-1], z_pred=z_pred.shape[:-1], S=S.shape[:-2])
    nu_x, nu_y = _difference(z_pred, z)
    rho = quadratic_form(nu_x, nu_y, sym2(S))
    return _result(n, rho <= gamma, rho, gamma)


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
                "H", f"must have shape (..., m, {P_pred.shape[-1]}), got shape {H.shape}")
        H_P_Ht = H @ P_pred @ np.swapaxes(H, -1, -2)
    if H_P_Ht.shape[-1] != R.shape[-1]:
        raise ParameterError(
            "R", f"must be {H_P_Ht.shape[-1]} x {H_P_Ht.shape[-1]}, got shape {R.shape}")
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
        :func:`core.thresholds.rectangular_coefficient`).

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
    sigma_x = _sigma("sigma_x", sigma_x)
    sigma_y = _sigma("sigma_y", sigma_y)
    k = _positive_coefficient("k", k)
    n = pair_count(z=z.shape[:-1], z_pred=z_pred.shape[:-1], sigma_x=sigma_x.shape,
                   sigma_y=sigma_y.shape)
    dx, dy = _difference(z_pred, z)
    statistic = _window_statistic(dx, dy, sigma_x, sigma_y)
    return _result(n, statistic <= k, statistic, k)


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
    sigma_r = _sigma("sigma_r", sigma_r)
    sigma_az = _sigma("sigma_az", sigma_az)
    sigma_r_pred = _sigma("sigma_r_pred", sigma_r_pred)
    sigma_az_pred = _sigma("sigma_az_pred", sigma_az_pred)
    K_R = _positive_coefficient("K_R", K_R)
    K_az = _positive_coefficient("K_az", K_az)
    n = pair_count(r=r.shape, az=az.shape, r_pred=r_pred.shape, az_pred=az_pred.shape,
                   sigma_r=sigma_r.shape, sigma_az=sigma_az.shape,
                   sigma_r_pred=sigma_r_pred.shape, sigma_az_pred=sigma_az_pred.shape)
    W_R = K_R * np.hypot(sigma_r, sigma_r_pred)
    W_az = K_az * np.hypot(sigma_az, sigma_az_pred)
    statistic = _window_statistic(r - r_pred, wrap_angle(az - az_pred), W_R, W_az)
    return _result(n, statistic <= 1.0, statistic, 1.0)


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
    _, R_max = _ring_radii(tau, 0.0, v_max)
    sigma_r1 = _sigma("sigma_r1", sigma_r1)
    sigma_az1 = _sigma("sigma_az1", sigma_az1)
    sigma_r2 = _sigma("sigma_r2", sigma_r2)
    sigma_az2 = _sigma("sigma_az2", sigma_az2)
    K_R = _positive_coefficient("K_R", K_R)
    K_az = _positive_coefficient("K_az", K_az)
    n = pair_count(r1=r1.shape, az1=az1.shape, r2=r2.shape, az2=az2.shape,
                   sigma_r1=sigma_r1.shape, sigma_az1=sigma_az1.shape,
                   sigma_r2=sigma_r2.shape, sigma_az2=sigma_az2.shape)
    W_R = R_max + K_R * np.hypot(sigma_r1, sigma_r2)
    far = r1 > R_max
    sin_turn = np.divide(R_max, r1, out=np.ones(np.shape(r1)), where=far)
    W_az = np.arcsin(sin_turn) + K_az * np.hypot(sigma_az1, sigma_az2)
    statistic = _window_statistic(r2 - r1, wrap_angle(az2 - az1), W_R, W_az)
    return _result(n, statistic <= 1.0, statistic, 1.0)
