"""Range-sum noise estimation and polynomial smoothing of solved positions (Fadeev et al.).

Fadeev, Myakinkov and Ogurtsov (accuracy of target positioning in a multistatic
forward-scatter radar with moving platforms) estimate the unknown range-sum noise from the
measurements themselves (eq. 5): for a target on a straight line, each range-sum series
l_p(t) is close to a quadratic in time, so the residuals of a quadratic least-squares
fit measure sigma_p. They also smooth the solved coordinates with a polynomial in a
sliding window (the remark after eq. 7, curves 5 and 6 of Fig. 3).

Symbols
-------
t : (T,) sample times in seconds, strictly increasing (any epoch).
l : (T,) or (T, P) range-sum series in metres, one column per measurement pair.
x : (T, D) solved positions in metres (or any (T, ...) series).
degree : degree of the fitted polynomial (2, a quadratic, in the paper).

Decisions (not in the paper)
----------------------------
* eq. 5 divides the residual sum of squares by n; here it is divided by the
  residual degrees of freedom T - (degree + 1), the unbiased estimate (T - 3 for the
  quadratic), which matters for short series.
* The polynomials are fitted in time centred on the window (or series) and scaled to
  [-1, 1], so absolute epochs such as Unix time do not spoil the conditioning.
* ``smooth_positions`` evaluates, at each sample, the polynomial fitted to the
  ``window`` samples centred on it; near the ends, where a centred window would run
  off the series, the nearest full window is used instead (so no sample is smoothed
  with fewer than ``window`` points). An even window has one more sample before the
  centre than after it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError
from plotgate.core.validation import as_array

__all__ = ["SMOOTHING_CELLS", "NoiseEstimate", "range_sum_noise", "smooth_positions"]


@dataclass(frozen=True)
class NoiseEstimate:
    """Range-sum noise estimated from the residuals of a polynomial fit (Fadeev et al., eq. 5).

    Attributes
    ----------
    sigma : (P,) ndarray, or a 0-d array for a single (T,) series
        Estimated standard deviation of each series, metres.
    variance : same shape as sigma
        sigma^2 = RSS / dof, m^2.
    smoothed : ndarray, the shape of ``l``
        The fitted polynomial at the sample times (the smoothed range sums of eq. 5).
    residuals : ndarray, the shape of ``l``
        l - smoothed, metres.
    dof : int
        Residual degrees of freedom T - (degree + 1).
    """

    sigma: np.ndarray
    variance: np.ndarray
    smoothed: np.ndarray
    residuals: np.ndarray
    dof: int


SMOOTHING_CELLS = 2**20
"""Most window x (degree + 1) Vandermonde entries :func:`smooth_positions` builds at once
(8 MB, about 40 MB with the pseudo-inverse's work arrays): the samples are smoothed in
blocks, so memory stays bounded at any window (one window of a whole 10,000-sample series
at degree 10 would otherwise take 8 GB at once)."""


def _as_degree(degree: object) -> int:
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 0:
        raise ParameterError("degree", f"must be an integer >= 0, got {degree!r}")
    return int(degree)


def _as_times(t: ArrayLike, n_needed: int, what: str) -> np.ndarray:
    """Coerce strictly increasing finite (T,) times with T >= n_needed."""
    t = as_array("t", t)
    if t.ndim != 1:
        raise ParameterError("t", f"must have shape (T,), got shape {t.shape}")
    if t.size < n_needed:
        raise ParameterError("t", f"needs at least {n_needed} samples {what}, got {t.size}")
    step = np.diff(t)
    if not (step > 0.0).all():
        index = int(np.argmax(~(step > 0.0))) + 1
        raise ParameterError(
            "t", f"must be strictly increasing, got {t[index - 1]} then {t[index]}", index
        )
    return t


def _as_series(name: str, value: ArrayLike, n_samples: int) -> np.ndarray:
    x = as_array(name, value)
    if x.ndim == 0 or x.shape[0] != n_samples:
        raise ParameterError(
            name,
            f"must have shape (T, ...) with T = {n_samples} samples as t, got shape {x.shape}",
        )
    return x


def _centred_fits(
    t: np.ndarray, y: np.ndarray, samples: np.ndarray, start: np.ndarray, degree: int, window: int
) -> np.ndarray:
    """The polynomial of each of ``samples`` fitted to its window (the ``window`` samples
    from its ``start``) and evaluated at the sample: (len(samples), columns)."""
    rows = start[:, None] + np.arange(window)  # (B, window)
    tw = t[rows]
    half = 0.5 * (tw[:, -1] - tw[:, 0]) if window > 1 else np.ones(samples.size)
    # local time centred on the evaluated sample: the fit there is coefficient 0
    tau = (tw - t[samples, None]) / half[:, None]
    V = _vandermonde(tau, degree)  # (B, window, q + 1)
    coef = np.linalg.pinv(V) @ y[rows]  # (B, q + 1, columns)
    fitted: np.ndarray = coef[:, 0, :]
    return fitted


def _vandermonde(tau: np.ndarray, degree: int) -> np.ndarray:
    """Columns tau^0 .. tau^degree along a new last axis."""
    return tau[..., None] ** np.arange(degree + 1)


def range_sum_noise(
    t: ArrayLike,
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name it l)
    degree: int = 2,
) -> NoiseEstimate:
    """Noise of each range-sum series from its polynomial (quadratic) fit.

    .. math:: \\hat\\sigma_p^2 = \\frac{1}{T - (q + 1)}
              \\sum_{i=1}^{T} \\left(\\hat l_{p,i} - \\tilde l_p(t_i)\\right)^2

    with :math:`\\tilde l_p` the least-squares polynomial of degree q (q = 2: the
    range sum of a target on a straight line is nearly quadratic in time).

    Parameters
    ----------
    t : (T,) array_like
        Sample times in seconds, strictly increasing, T >= degree + 2.
    l : (T,) or (T, P) array_like
        Range-sum series in metres (any trailing shape: one series per column).
    degree : int, optional
        Degree q of the fitted polynomial, >= 0. Default 2.

    Returns
    -------
    estimate : NoiseEstimate
        ``sigma`` per series and the fit behind it.

    Raises
    ------
    NonFiniteError
        If t or l contains NaN or infinity.
    ParameterError
        If the shapes do not fit, t is not strictly increasing, degree is not an
        integer >= 0, or T < degree + 2 (no residual degree of freedom).

    Notes
    -----
    The divisor is the residual degrees of freedom T - q - 1 (unbiased), not the n of
    the paper's eq. 5. The estimate is biased upwards when a series departs from the
    polynomial over the window (a long series of a fast target near a platform):
    keep the span short enough for the quadratic to hold.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (5):
       :math:`\\hat\\sigma_{lk,n}^2 = \\frac{1}{n}\\sum_i (\\hat l_{k,i} -
       \\tilde l_{k,i}(t_i))^2` with quadratic smoothing :math:`\\tilde l`.

    Examples
    --------
    >>> t = np.arange(6.0)
    >>> l = np.stack([1e4 + 50 * t + 2 * t**2, 2e4 - 30 * t]).T
    >>> l[:, 0] += [0.5, -0.5, 0.5, -0.5, 0.5, -0.5]
    >>> est = range_sum_noise(t, l)
    >>> est.dof, est.sigma.round(3)
    (3, array([0.676, 0.   ]))
    """
    degree = _as_degree(degree)
    t = _as_times(t, degree + 2, f"for a degree-{degree} fit with a residual")
    ls = _as_series("l", l, t.size)
    y = ls.reshape(t.size, -1)
    centre = 0.5 * (t[0] + t[-1])
    half = 0.5 * (t[-1] - t[0])
    V = _vandermonde((t - centre) / half, degree)
    coef = np.linalg.lstsq(V, y, rcond=None)[0]
    smoothed = V @ coef
    residuals = y - smoothed
    dof = t.size - degree - 1
    variance = np.einsum("tp,tp->p", residuals, residuals) / dof
    trailing = ls.shape[1:]
    return NoiseEstimate(
        sigma=np.sqrt(variance).reshape(trailing),
        variance=variance.reshape(trailing),
        smoothed=smoothed.reshape(ls.shape),
        residuals=residuals.reshape(ls.shape),
        dof=dof,
    )


def smooth_positions(t: ArrayLike, x: ArrayLike, window: int, degree: int = 2) -> np.ndarray:
    """Sliding-window polynomial smoothing of solved coordinates (Fadeev et al., Fig. 3).

    At each sample i the polynomial of degree q is fitted by least squares to the
    ``window`` samples around it and evaluated at t_i. The window is centred on i
    (samples i - window//2 .. i - window//2 + window - 1); near the ends it is the
    nearest full window of the series.

    Parameters
    ----------
    t : (T,) array_like
        Sample times in seconds, strictly increasing.
    x : (T,) or (T, D) array_like
        Solved coordinates in metres (any trailing shape: each column is smoothed).
    window : int
        Samples per window, degree + 1 <= window <= T.
    degree : int, optional
        Degree q of the local polynomial, >= 0. Default 2.

    Returns
    -------
    smoothed : ndarray, the shape of ``x``
        The smoothed coordinates at the sample times.

    Raises
    ------
    NonFiniteError
        If t or x contains NaN or infinity.
    ParameterError
        If the shapes do not fit, t is not strictly increasing, degree is not an
        integer >= 0, or window is not an integer in [degree + 1, T].

    Notes
    -----
    With window = degree + 1 the polynomial interpolates and nothing is smoothed.
    A polynomial track of degree <= q is reproduced exactly, ends included. For
    equally spaced samples and q = 2 the centred estimate of white noise keeps
    a fraction 3(3w^2 - 7) / (4w(w^2 - 4)) of its variance (0.11 for w = 21).

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, section 2 and the
       conclusion: polynomial smoothing of the coordinate estimates in a sliding
       window (improves the sum-range and difference-range methods, Fig. 3).

    Examples
    --------
    A straight track (a degree-1 series) is reproduced exactly:

    >>> t = np.arange(7.0)
    >>> x = np.stack([100.0 + 80.0 * t, 50.0 - 10.0 * t]).T
    >>> np.allclose(smooth_positions(t, x, window=5), x)
    True
    """
    degree = _as_degree(degree)
    if (
        isinstance(window, bool)
        or not isinstance(window, (int, np.integer))
        or window < degree + 1
    ):
        raise ParameterError(
            "window", f"must be an integer >= degree + 1 = {degree + 1}, got {window!r}"
        )
    window = int(window)
    t = _as_times(t, window, f"for a window of {window}")
    x = _as_series("x", x, t.size)
    y = x.reshape(t.size, -1)
    n = t.size
    start = np.clip(np.arange(n) - window // 2, 0, n - window)
    block = max(1, SMOOTHING_CELLS // (window * (degree + 1)))
    fits = [
        _centred_fits(t, y, np.arange(i, min(i + block, n)), start[i : i + block], degree, window)
        for i in range(0, n, block)
    ]
    smoothed: np.ndarray = np.concatenate(fits).reshape(x.shape)
    return smoothed
