"""Cramer-Rao lower bounds of multistatic range-sum positioning (Fadeev et al., eq. 3).

Fadeev, Myakinkov and Ogurtsov bound the position error of a target seen by range sums
l_p = |x - rx_p| + |x - tx_p| with independent N(0, sigma_p^2) noise by the inverse of
the Fisher information

.. math:: \\mathbf{J} = \\sum_{i}\\sum_{p} \\frac{1}{\\sigma_p^2}
          \\nabla l_{p,i} \\, \\nabla l_{p,i}^T = \\mathbf{H}^T \\mathbf{G} \\mathbf{H},
          \\quad \\mathbf{G} = \\mathrm{diag}(1/\\sigma_p^2)

(eq. 3; H the Jacobian of :func:`plotgate.core.multistatic.model.range_sum_jacobian`), single
shot (one sample, Fig. 3 curves 1) or accumulated over the samples of a
constant-velocity track (curves 2).

Conventions and decisions
-------------------------
* Shapes as :mod:`plotgate.core.multistatic.model`: x (N, D) or (D,), tx / rx (N, P, D) or
  (P, D), sigma scalar, (P,) or (N, P); results are batched (N, ...).
* GDOP = sqrt(trace J^-1) / sigma_ref with the reference sigma
  sigma_ref = (mean_p 1 / sigma_p^2)^(-1/2), the sigma that carries the average
  information of one measurement. With equal sigmas sigma_ref = sigma and the GDOP is
  the pure geometry factor sqrt(trace (H^T H)^-1); scaling every sigma by c leaves
  the GDOP unchanged.
* Where the target sits on a baseline the row of that pair vanishes (Fadeev et al.: the
  ellipse degenerates to the segment). With too few other pairs J is then singular;
  its eigenvalues are floored at ``INFORMATION_RTOL`` times the largest
  (:mod:`plotgate.core.multistatic.information`), so the bound in the unobservable
  direction is huge (about 1e7 times the best sigma) but finite, never NaN or an
  exception.
* Trajectories: x0 is the position at the first sample time t_ref = t[0] and
  x(t) = x0 + v (t - t_ref).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import GeometryError, ParameterError
from plotgate.core.multistatic.information import inverse_information, position_covariance
from plotgate.core.multistatic.model import (
    COINCIDENT_RTOL,
    coordinate_scale,
    range_sum_jacobian,
    range_sums,
    validate_problem,
    validate_track,
)
from plotgate.core.validation import as_array, first_index

__all__ = [
    "CRLB",
    "TrajectoryCRLB",
    "crlb",
    "difference_crlb",
    "trajectory_crlb",
]


@dataclass(frozen=True)
class CRLB:
    """Single-shot Cramer-Rao bound of N position problems.

    Attributes
    ----------
    information : (N, D, D) ndarray
        Fisher information J, m^-2.
    covariance : (N, D, D) ndarray
        The bound J^-1, m^2.
    sigma : (N, D) ndarray
        Standard deviation bound per axis, sqrt(diag J^-1), metres.
    gdop : (N,) ndarray
        sqrt(trace J^-1) / sigma_ref, dimensionless.
    sigma_ref : (N,) ndarray
        Reference sigma of the GDOP, (mean_p 1/sigma_p^2)^(-1/2), metres.
    """

    information: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray
    gdop: np.ndarray
    sigma_ref: np.ndarray


@dataclass(frozen=True)
class TrajectoryCRLB:
    """Cramer-Rao bound of a constant-velocity track from T samples (Fadeev et al., eq. 3).

    Attributes
    ----------
    t_ref : float
        Time (s) at which the state position applies: the first sample time.
    information : (2D, 2D) ndarray
        Fisher information of the state (x0, v), accumulated over all samples.
    covariance : (2D, 2D) ndarray
        The bound on the state, J^-1 (m^2, m^2/s, m^2/s^2 blocks).
    sigma : (2D,) ndarray
        sqrt of its diagonal: metres for x0, m/s for v.
    position_covariance : (T, D, D) ndarray
        Bound on the position at each sample time, A_i J^-1 A_i^T with
        A_i = [I, (t_i - t_ref) I], m^2 (Fadeev et al., Fig. 3 curves 2).
    position_sigma : (T, D) ndarray
        sqrt of its diagonal, metres.
    gdop : (T,) ndarray
        sqrt(trace position_covariance) / sigma_ref at each sample.
    sigma_ref : float
        (mean over all T P measurements of 1/sigma^2)^(-1/2), metres.
    """

    t_ref: float
    information: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray
    position_covariance: np.ndarray
    position_sigma: np.ndarray
    gdop: np.ndarray
    sigma_ref: float


def _diag_sqrt(cov: np.ndarray) -> np.ndarray:
    sigma: np.ndarray = np.sqrt(np.maximum(np.diagonal(cov, axis1=-2, axis2=-1), 0.0))
    return sigma


def _sigma_ref(sigma: np.ndarray, axis: int | tuple[int, ...] = -1) -> np.ndarray:
    ref: np.ndarray = 1.0 / np.sqrt(np.mean(1.0 / (sigma * sigma), axis=axis))
    return ref


def _single_tx(tx: ArrayLike) -> ArrayLike:
    """Let a single transmitter be given as (D,), as validate_problem does."""
    try:
        return np.asarray(tx, dtype=float)[None, :] if np.ndim(tx) == 1 else tx
    except (TypeError, ValueError):
        return tx  # as_array words the error


def _geometry(
    x: ArrayLike, tx: ArrayLike, rx: ArrayLike, sigma: ArrayLike, extra_pairs: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coerce and check a bound's inputs; (x (N, D), tx, rx (N, P, D), sigma (N, P)).

    Each problem needs at least D + extra_pairs measurement pairs.
    """
    tx = _single_tx(tx)
    x = as_array("x", x)
    try:
        d = np.shape(rx)[-1]
    except (TypeError, ValueError, IndexError):
        d = None  # range_sums words the error on rx
    if x.ndim not in (1, 2) or (d is not None and x.shape[-1] != d):
        raise ParameterError(
            "x", f"must have shape (D,) or (N, D) with the D = {d} of rx, got {x.shape}"
        )
    ls = range_sums(x, tx, rx)  # shape, D, P and broadcast checks, field-named
    batched = x.ndim == 2
    d = x.shape[-1]
    p = ls.shape[-1]
    min_pairs = d + extra_pairs
    if p < min_pairs:
        raise ParameterError(
            "rx",
            f"has {p} measurement pairs; this bound of {d} coordinates needs at least {min_pairs}",
        )
    _, tx, rx, checked_sigma = validate_problem(ls, tx, rx, sigma)
    n = tx.shape[0]
    x = np.array(np.broadcast_to(x, (n, d)))
    # the gradient of |x - platform| is undefined on the platform
    tol = COINCIDENT_RTOL * coordinate_scale(tx, rx)
    gap = np.minimum(
        np.linalg.norm(x[:, None] - tx, axis=-1), np.linalg.norm(x[:, None] - rx, axis=-1)
    ).min(axis=-1)
    on_platform = gap <= tol
    if on_platform.any():
        index = first_index(on_platform)
        raise GeometryError(
            "x",
            f"{x[index].tolist()} is at a platform, where the range-sum gradient is undefined",
            index if batched else None,
        )
    return x, tx, rx, cast(np.ndarray, checked_sigma)  # given, so checked: never None


def crlb(x: ArrayLike, tx: ArrayLike, rx: ArrayLike, sigma: ArrayLike) -> CRLB:
    """Single-shot Cramer-Rao bound of the position from P range sums (Fadeev et al., eq. 3).

    .. math:: \\mathbf{J} = \\mathbf{H}^T \\mathrm{diag}(1/\\sigma_p^2) \\mathbf{H},
              \\quad \\mathbf{H}_{p} = \\frac{\\mathbf{x} - \\mathbf{rx}_p}
              {|\\mathbf{x} - \\mathbf{rx}_p|} + \\frac{\\mathbf{x} - \\mathbf{tx}_p}
              {|\\mathbf{x} - \\mathbf{tx}_p|}, \\quad
              \\mathrm{GDOP} = \\sqrt{\\mathrm{tr}\\,\\mathbf{J}^{-1}} / \\sigma_{ref}

    Parameters
    ----------
    x : (D,) or (N, D) array_like
        True target positions, metres (D = 2 or 3).
    tx : (D,), (P, D) or (N, P, D) array_like
        Transmitter of each pair (or one transmitter for all), metres.
    rx : (P, D) or (N, P, D) array_like
        Receiver of each pair, metres; P >= D.
    sigma : float, (P,) or (N, P) array_like
        Range-sum noise standard deviations, metres, > 0.

    Returns
    -------
    bound : CRLB
        Information, covariance bound, per-axis sigma and GDOP, batched (N, ...).

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        On wrong shapes, P < D (field ``"rx"``) or sigma <= 0.
    GeometryError
        On coincident platforms, or x at a platform.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (3): the Fisher
       information of the range sums, one sample (Fig. 3, curves 1).

    Examples
    --------
    A transmitter at the origin and receivers 10 km east and north; the target at
    (3, 4) km, sigma 0.5 m:

    >>> b = crlb([3000.0, 4000.0], [0.0, 0.0], [[10000.0, 0.0], [0.0, 10000.0]], 0.5)
    >>> b.sigma.round(3), b.gdop.round(3)
    (array([[0.488, 0.406]]), array([1.269]))
    """
    x, tx, rx, sigma = _geometry(x, tx, rx, sigma)
    H = range_sum_jacobian(x, tx, rx)  # (N, P, D)
    Hw = H / sigma[..., None]
    J = np.einsum("npi,npj->nij", Hw, Hw)
    return _bound(J, _sigma_ref(sigma))


def _bound(J: np.ndarray, sigma_ref: np.ndarray) -> CRLB:
    cov = inverse_information(J)
    return CRLB(
        information=J,
        covariance=cov,
        sigma=_diag_sqrt(cov),
        gdop=np.sqrt(np.trace(cov, axis1=-2, axis2=-1)) / sigma_ref,
        sigma_ref=sigma_ref,
    )


def difference_crlb(x: ArrayLike, tx: ArrayLike, rx: ArrayLike, sigma: ArrayLike) -> CRLB:
    """Cramer-Rao bound of the position from the range-sum differences d_k = l_k - l_1.

    The P - 1 differences d = A l (A the (P-1, P) differencing matrix against the
    first pair) have correlated noise, C = A diag(sigma^2) A^T (the first pair's
    noise enters every difference), so

    .. math:: \\mathbf{J}_d = (\\mathbf{A}\\mathbf{H})^T \\mathbf{C}^{-1}
              (\\mathbf{A}\\mathbf{H}), \\quad
              \\mathbf{C} = \\mathbf{A}\\,\\mathrm{diag}(\\sigma_p^2)\\,\\mathbf{A}^T.

    With one transmitter the rows of AH are (x - rx_k)/|x - rx_k| - (x - rx_1)/|x -
    rx_1|: the transmitter cancels (the hyperbolae of the difference-range method).
    J_d <= J of :func:`crlb` (differencing drops one measurement's worth of
    information), so this bound is never below the sum-range one.

    Parameters
    ----------
    x : (D,) or (N, D) array_like
        True target positions, metres.
    tx, rx : (P, D) or (N, P, D) array_like
        Transmitter and receiver of each pair, metres; P >= D + 1. The first pair is
        the reference (as in :func:`plotgate.core.multistatic.closed_form.difference_range_solve`).
    sigma : float, (P,) or (N, P) array_like
        Range-sum noise standard deviations, metres, > 0.

    Returns
    -------
    bound : CRLB
        As :func:`crlb`; sigma_ref is that of the P range sums, so the two GDOPs
        compare directly.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`crlb`; ParameterError (field ``"rx"``) when P < D + 1.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (3) applied to
       the difference-range method's measurements (Fig. 3, curves 6).

    Examples
    --------
    >>> rx = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
    >>> s = crlb([3000.0, 4000.0], [0.0, 0.0], rx, 0.5).sigma
    >>> sd = difference_crlb([3000.0, 4000.0], [0.0, 0.0], rx, 0.5).sigma
    >>> bool((sd >= s).all())
    True
    """
    x, tx, rx, sigma = _geometry(x, tx, rx, sigma, extra_pairs=1)
    J = _difference_information(range_sum_jacobian(x, tx, rx), sigma)
    return _bound(J, _sigma_ref(sigma))


def _difference_information(H: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(A H)^T C^-1 (A H) of (..., P, K) Jacobians H and (..., P) sigmas: (..., K, K)."""
    Hd = H[..., 1:, :] - H[..., :1, :]  # A H
    var = sigma * sigma
    # C = A diag(sigma^2) A^T: sigma_k^2 + sigma_1^2 on the diagonal, sigma_1^2 off it
    C = np.eye(var.shape[-1] - 1) * var[..., 1:, None] + var[..., :1, None]
    J: np.ndarray = np.einsum("...ki,...kj->...ij", Hd, np.linalg.solve(C, Hd))
    return J


def trajectory_crlb(
    x0: ArrayLike,
    v: ArrayLike,
    t: ArrayLike,
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike,
    measurements: str = "sum",
) -> TrajectoryCRLB:
    """Accumulated Cramer-Rao bound of a constant-velocity track (Fadeev et al., eq. 3, curves 2).

    The state theta = (x0, v) gives x_i = x0 + v (t_i - t_ref); the Jacobian of
    l_{p,i} is [H_{p,i}, (t_i - t_ref) H_{p,i}], and the information is summed over the
    T samples and P pairs:

    .. math:: \\mathbf{J} = \\sum_{i=1}^{T}\\sum_{p=1}^{P} \\frac{1}{\\sigma_{p,i}^2}
              \\begin{bmatrix} 1 & \\tau_i \\\\ \\tau_i & \\tau_i^2 \\end{bmatrix}
              \\otimes \\mathbf{H}_{p,i}^T \\mathbf{H}_{p,i}, \\quad
              \\tau_i = t_i - t_{ref}.

    With ``measurements="difference"`` each sample contributes the information of its
    P - 1 range-sum differences instead, (A H_i)^T C_i^-1 (A H_i) with the state
    Jacobian H_i = [H, tau_i H] and C_i as in :func:`difference_crlb` (the samples'
    noise is independent, so the information still adds over the samples).

    Parameters
    ----------
    x0 : (D,) array_like
        Target position at the first sample time t[0], metres.
    v : (D,) array_like
        Target velocity, m/s.
    t : (T,) array_like
        Sample times, seconds (any epoch).
    tx, rx : (P, D) or (T, P, D) array_like
        Platforms of each pair, fixed or per sample (e.g. from
        :func:`plotgate.core.multistatic.model.platform_positions`), metres; P >= D.
    sigma : float, (P,) or (T, P) array_like
        Range-sum noise standard deviations, metres, > 0.
    measurements : ``"sum"`` or ``"difference"``, optional
        The range sums (default) or their differences against the first pair (P >= D + 1).

    Returns
    -------
    bound : TrajectoryCRLB
        The state bound and the position bound at every sample time.

    Raises
    ------
    NonFiniteError, ParameterError, GeometryError
        As :func:`crlb` (the index is the sample), and ParameterError when x0, v or t
        have the wrong shape.

    Notes
    -----
    One sample (T = 1), or samples at a single time, leave v unobservable: the
    information is singular and the floored bound is huge, not an error.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (3) with the sum
       over the n accumulated samples (Fig. 3, curves 2).

    Examples
    --------
    Three samples a second apart give a bound below the single-shot one:

    >>> rx = [[10000.0, 0.0], [0.0, 10000.0]]
    >>> b = trajectory_crlb([3000.0, 4000.0], [0.0, 80.0], [0.0, 1.0, 2.0], [0.0, 0.0], rx, 0.5)
    >>> bool((b.position_sigma[0] < crlb([3000.0, 4000.0], [0.0, 0.0], rx, 0.5).sigma).all())
    True
    """
    if measurements not in ("sum", "difference"):
        raise ParameterError(
            "measurements", f"must be 'sum' or 'difference', got {measurements!r}"
        )
    x0, v, t = validate_track(x0, v, t)
    tau = t - t[0]
    x = x0 + tau[:, None] * v  # (T, D)
    x, tx, rx, sigma = _geometry(x, tx, rx, sigma, extra_pairs=int(measurements != "sum"))
    H = range_sum_jacobian(x, tx, rx)  # (T, P, D)
    Hs = np.concatenate([H, tau[:, None, None] * H], axis=-1)  # (T, P, 2D)
    if measurements == "sum":
        Hs = Hs / sigma[..., None]  # whitened
        J = np.einsum("tpi,tpj->ij", Hs, Hs)
    else:
        J = _difference_information(Hs, sigma).sum(axis=0)
    cov = inverse_information(J)
    return _track_bound(J, cov, tau, float(t[0]), float(_sigma_ref(sigma, axis=(0, 1))))


def _track_bound(
    J: np.ndarray, cov: np.ndarray, tau: np.ndarray, t_ref: float, sigma_ref: float
) -> TrajectoryCRLB:
    pos = position_covariance(cov, tau)
    return TrajectoryCRLB(
        t_ref=t_ref,
        information=J,
        covariance=cov,
        sigma=_diag_sqrt(cov),
        position_covariance=pos,
        position_sigma=_diag_sqrt(pos),
        gdop=np.sqrt(np.trace(pos, axis1=-2, axis2=-1)) / sigma_ref,
        sigma_ref=sigma_ref,
    )
