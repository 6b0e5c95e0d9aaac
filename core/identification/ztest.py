"""Fisher's Z-test identifying a passive (ESM) track with an active radar track (Kvasnov).

Kvasnov (A. V. Kvasnov, identifying radar target marks from active and passive stations
by Fisher's Z-test) treats the n bearings of the passive station as the population and
the m << n bearings of the active station as a sample, and tests H0 "one object"
against H1 "two objects" by (eq. 5)

.. math:: Z = \\frac{\\bar\\theta_{act} - \\bar\\theta_{pas}}{\\sigma / \\sqrt{m}},

two-sided at level alpha: |Z| <= z_{1 - alpha/2} identifies the marks. Bearings are
angles: the means are circular (atan2 of the mean sine and cosine) and the difference is
wrapped to (-pi, pi], so 359 and 1 degree are 2 degrees apart.

Beyond the paper:

* sigma is the passive bearings' standard deviation, known or estimated from the passive
  sample (deviations from its circular mean, wrapped, with n - 1 degrees of freedom);
* the type II error (false identification) for a true separation delta,
  beta = Phi(z - delta sqrt(m) / sigma) - Phi(-z - delta sqrt(m) / sigma), and the
  smallest m with beta <= beta_max; the pair test evaluates both with the passive mean's
  own error included (Z ~ N(delta sqrt(m) / sigma, 1 + m / n)), which the paper's n >> m
  neglects and a Monte Carlo confirms (bench/HISTORY.md);
* the paper's conditions as numbers: n / m against a wanted ratio, and the Shapiro-Wilk
  test of the passive deviations (``scipy.stats.shapiro``) with its p-value;
* elevations, optionally: each coordinate is tested at alpha / k (Bonferroni, k = 1 or 2
  coordinates) and the marks are identified when every coordinate is, so the test keeps
  its level alpha.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from plotgate.core.errors import ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.validation import as_array, as_probability

__all__ = [
    "MIN_ESTIMATED_SIGMA",
    "ZTest",
    "bearing_sigma",
    "circular_mean",
    "circular_sigma",
    "required_samples",
    "type_two_error",
    "z_test",
]


MIN_ESTIMATED_SIGMA = 1e-15
"""Smallest sigma (rad) estimated from angles: below it the angles differ by rounding
only (a double near 2 pi is resolved to 9e-16), and Z = d sqrt(m) / sigma could overflow."""


def circular_mean(theta: ArrayLike, axis: int = -1) -> np.ndarray:
    """Circular mean atan2(mean sin, mean cos) of angles (rad) along ``axis``.

    Examples
    --------
    >>> round(abs(float(np.degrees(circular_mean(np.radians([359.0, 1.0]))))), 9)
    0.0
    """
    theta = np.asarray(theta, dtype=float)
    mean: np.ndarray = np.arctan2(np.sin(theta).mean(axis=axis), np.cos(theta).mean(axis=axis))
    return mean


def circular_sigma(theta: ArrayLike, axis: int = -1) -> np.ndarray:
    """Sample standard deviation (n - 1) of angles about their circular mean, wrapped (rad).

    Examples
    --------
    >>> float(np.degrees(circular_sigma(np.radians([359.0, 1.0]))).round(9))
    1.414213562
    """
    theta = np.asarray(theta, dtype=float)
    dev = wrap_finite(theta - np.expand_dims(circular_mean(theta, axis), axis))
    sigma: np.ndarray = np.sqrt((dev * dev).sum(axis=axis) / (theta.shape[axis] - 1))
    return sigma


def type_two_error(
    delta: ArrayLike, sigma: ArrayLike, m: ArrayLike, alpha: float, n: ArrayLike | None = None
) -> np.ndarray:
    """Probability of identifying two objects delta apart (rad): beta of the two-sided test.

    .. math:: \\beta = \\Phi\\left(\\frac{z - \\delta\\sqrt{m}/\\sigma}{c}\\right)
              - \\Phi\\left(\\frac{-z - \\delta\\sqrt{m}/\\sigma}{c}\\right),
              \\quad z = z_{1-\\alpha/2}, \\quad c = \\sqrt{1 + m/n}

    With n None, c = 1: the passive mean is the population's (Kvasnov's assumption).
    With n passive samples their mean has its own error, and Z ~ N(delta sqrt(m)/sigma,
    1 + m/n) (the active and passive bearings normal with the same sigma).

    Examples
    --------
    >>> round(float(type_two_error(np.radians(0.5), np.radians(1.0), 50, 0.05)), 6)
    0.057562
    >>> round(float(type_two_error(0.0, 1.0, 10, 0.05)), 6)  # no separation: 1 - alpha
    0.95
    >>> round(float(type_two_error(np.radians(1.0), np.radians(1.0), 20, 0.05, n=50)), 4)
    0.0169
    """
    alpha = float(as_probability("alpha", alpha))
    z = stats.norm.ppf(1.0 - alpha / 2.0)
    m = np.asarray(m, dtype=float)
    c = 1.0 if n is None else np.sqrt(1.0 + m / np.asarray(n, dtype=float))
    shift = np.abs(np.asarray(delta, dtype=float)) * np.sqrt(m) / np.asarray(sigma, float)
    beta: np.ndarray = stats.norm.cdf((z - shift) / c) - stats.norm.cdf((-z - shift) / c)
    return beta


def required_samples(
    delta: float,
    sigma: float,
    alpha: float,
    beta_max: float,
    n: int | None = None,
    m_max: int = 10**7,
) -> int:
    """Smallest m with type_two_error(delta, sigma, m, alpha, n) <= beta_max.

    Starts from the known-mean approximation m = ((z_{1-a/2} + z_{1-b}) sigma / delta)^2
    and steps to the exact smallest m (beta falls with m).

    Raises
    ------
    ParameterError
        If delta is 0 (no m separates identical bearings), or no m <= m_max suffices.

    Examples
    --------
    >>> required_samples(np.radians(0.5), np.radians(1.0), 0.05, 0.05)
    52
    >>> required_samples(np.radians(0.5), np.radians(1.0), 0.05, 0.05, n=500)
    55
    """
    alpha = float(as_probability("alpha", alpha))
    beta_max = float(as_probability("beta_max", beta_max))
    if not delta != 0:
        raise ParameterError(
            "delta",
            "must be non-zero: identical bearings cannot be told apart by any number of samples",
        )
    k = (stats.norm.ppf(1 - alpha / 2) + stats.norm.ppf(1 - beta_max)) * sigma / abs(delta)
    if not abs(k) <= np.sqrt(m_max):  # the approximation alone needs too many (k may be inf)
        raise ParameterError(
            "beta_max", f"needs more than {m_max} active samples for this delta, sigma and alpha"
        )
    m = max(1, int(np.floor(k * k)) - 2)
    step = 64
    while m <= m_max:  # bracket by doubling, then the exact smallest m in the bracket
        trial = m + np.arange(step)
        ok = type_two_error(delta, sigma, trial, alpha, n) <= beta_max
        if ok.any():
            return int(trial[np.argmax(ok)])
        m, step = m + step, 2 * step
    raise ParameterError("beta_max", f"needs more than {m_max} active samples")


@dataclass(frozen=True)
class ZTest:
    """The Z-test of one passive and one active track (angles in radians).

    Attributes
    ----------
    z : (k,) ndarray
        Z per coordinate (bearing; elevation when given).
    p_value : (k,) ndarray
        Two-sided p-values 2 (1 - Phi(|Z|)).
    critical : float
        z_{1 - alpha / (2k)}: |Z| beyond it rejects "one object".
    identified : bool
        Every |Z| <= critical.
    difference : (k,) ndarray
        Wrapped difference of the circular means, active minus passive.
    sigma : (k,) ndarray
        The sigma used per coordinate (known or estimated from the passive sample).
    n, m : int
        Passive and active sample sizes.
    n_over_m : float
        n / m; ``large_population`` says whether it reaches the wanted ratio.
    large_population : bool
    normality_p : (k,) ndarray
        Shapiro-Wilk p-value of the passive deviations per coordinate (NaN when n < 3).
    normal : bool
        Every normality_p >= normality_alpha (or NaN).
    beta : float or None
        Type II error for the stated separation delta (bearing), at the used level, the
        passive mean's error of these n samples included.
    m_required : int or None
        Smallest m keeping beta <= beta_max with these n passive samples, when asked.
    """

    z: np.ndarray
    p_value: np.ndarray
    critical: float
    identified: bool
    difference: np.ndarray
    sigma: np.ndarray
    n: int
    m: int
    n_over_m: float
    large_population: bool
    normality_p: np.ndarray
    normal: bool
    beta: float | None
    m_required: int | None


def _samples(name: str, value: ArrayLike) -> np.ndarray:
    a = as_array(name, value)
    if a.ndim != 1 or a.size < 2:
        raise ParameterError(name, f"must be a list of at least 2 angles, got shape {a.shape}")
    return a


def bearing_sigma(name: str, value: ArrayLike | None, passive: np.ndarray) -> np.ndarray:
    """The passive track's bearing sigma (rad): ``value`` checked, or estimated when None.

    Parameters
    ----------
    name : str
        The argument's name, for the error.
    value : float or None
        A given sigma, rad, > 0; None estimates it from ``passive``
        (:func:`circular_sigma`).
    passive : (n,) ndarray
        The passive track's bearings, rad.

    Raises
    ------
    ParameterError
        ``name`` for a sigma that is not a positive scalar, or that cannot be estimated
        (all bearings equal to rounding, below :data:`MIN_ESTIMATED_SIGMA`).

    Examples
    --------
    >>> float(bearing_sigma("sigma", 0.01, np.zeros(3)))
    0.01
    """
    if value is None:
        s = circular_sigma(passive)
        if not s >= MIN_ESTIMATED_SIGMA:
            raise ParameterError(
                name,
                "cannot be estimated: the passive angles are all equal "
                f"(to rounding: {float(s):.3g} rad)",
            )
        return s
    s = as_array(name, value)
    if s.ndim or not s > 0:
        raise ParameterError(name, f"must be a positive angle, got {value!r}")
    return s


_Axis = tuple[str, str, str, ArrayLike, ArrayLike, float | None]
"""One coordinate tested: the passive and active fields' names, the sigma's, their values."""


def _axes(
    passive: ArrayLike,
    active: ArrayLike,
    sigma: float | None,
    passive_elevation: ArrayLike | None,
    active_elevation: ArrayLike | None,
    sigma_elevation: float | None,
) -> list[_Axis]:
    """The coordinates tested: the bearings, and the elevations when both sides give them."""
    axes: list[_Axis] = [("passive", "active", "sigma", passive, active, sigma)]
    if (passive_elevation is None) != (active_elevation is None):
        raise ParameterError(
            "active_elevation" if active_elevation is None else "passive_elevation",
            "give elevations on both sides or none",
        )
    if passive_elevation is not None and active_elevation is not None:
        axes.append(
            (
                "passive_elevation",
                "active_elevation",
                "sigma_elevation",
                passive_elevation,
                active_elevation,
                sigma_elevation,
            )
        )
    return axes


def _axis_statistics(
    axes: list[_Axis],
) -> tuple[int, int, list[Any], list[Any], list[Any], list[Any]]:
    """Per coordinate, Kvasnov's eq. (5): the circular means' difference d, the population
    sigma s and Z = d sqrt(m) / s; and the Shapiro-Wilk p-value of the passive sample's
    deviations (NaN for fewer than 3 samples or no spread). Returns n, m and those lists."""
    zs, diff, sig, normality = [], [], [], []
    n = m = 0
    for p_name, a_name, s_name, p_val, a_val, s_val in axes:
        p, a = _samples(p_name, p_val), _samples(a_name, a_val)
        if n and (p.size != n or a.size != m):
            raise ParameterError(
                p_name if p.size != n else a_name,
                f"must have as many samples as the bearings ({n}, {m})",
            )
        n, m = p.size, a.size
        s = bearing_sigma(s_name, s_val, p)
        d = wrap_finite(circular_mean(a) - circular_mean(p))
        zs.append(d * np.sqrt(m) / s)
        diff.append(d)
        sig.append(s)
        dev = wrap_finite(p - circular_mean(p))
        normality.append(stats.shapiro(dev).pvalue if n >= 3 and np.ptp(dev) > 0 else np.nan)
    return n, m, zs, diff, sig, normality


def _power(
    delta: float | None, beta_max: float | None, sigma: float, m: int, alpha: float, n: int
) -> tuple[float | None, int | None]:
    """The type II error at the separation delta, and the samples beta_max needs
    (:func:`type_two_error`, :func:`required_samples`, at the per-coordinate level)."""
    if beta_max is not None and delta is None:
        raise ParameterError("beta_max", "needs delta, the separation to detect")
    if delta is None:
        return None, None
    delta = float(as_array("delta", delta))
    beta = float(type_two_error(delta, sigma, m, alpha, n))
    if beta_max is None:
        return beta, None
    return beta, required_samples(delta, sigma, alpha, beta_max, n)


def z_test(
    passive: ArrayLike,
    active: ArrayLike,
    sigma: float | None = None,
    alpha: float = 0.05,
    *,
    passive_elevation: ArrayLike | None = None,
    active_elevation: ArrayLike | None = None,
    sigma_elevation: float | None = None,
    delta: float | None = None,
    beta_max: float | None = None,
    ratio: float = 10.0,
    normality_alpha: float = 0.05,
) -> ZTest:
    """Fisher's Z-test of Kvasnov (eq. 5): are a passive and an active track one object?

    Parameters
    ----------
    passive : (n,) array_like
        Passive bearings, rad (n >= 2; the population).
    active : (m,) array_like
        Active bearings, rad (m >= 2; the sample).
    sigma : float, optional
        Bearing standard deviation of the population, rad (> 0). Default: estimated from
        the passive bearings.
    alpha : float, optional
        Level of the two-sided test, in (0, 1). Default 0.05.
    passive_elevation, active_elevation : (n,), (m,) array_like, optional
        Elevations, rad, tested the same way (both or neither).
    sigma_elevation : float, optional
        Their sigma, rad; default estimated from the passive elevations.
    delta : float, optional
        Smallest bearing separation of two distinct objects, rad: gives ``beta``.
    beta_max : float, optional
        Wanted type II error: gives ``m_required`` (needs delta).
    ratio : float, optional
        The n / m that counts as "n much larger than m" (> 1). Default 10.
    normality_alpha : float, optional
        Level of the Shapiro-Wilk normality check of the passive sample. Default 0.05.

    Returns
    -------
    test : ZTest

    Raises
    ------
    NonFiniteError, ParameterError
        On non-finite angles, fewer than 2 samples, sigma <= 0, alpha (or beta_max)
        outside (0, 1), elevations given on one side only or of another length than the
        bearings, ratio <= 1, or beta_max without delta.

    References
    ----------
    .. [1] A. V. Kvasnov, eq. (5) and the conditions of the Z-test (n >> m,
       a normal population, repeated identification every 2-20 s).

    Examples
    --------
    Bearings around 359.9 and 0.1 degrees are one object:

    >>> rng = np.random.default_rng(0)
    >>> passive = np.radians(359.9 + rng.normal(0.0, 0.3, 50))
    >>> active = np.radians(0.1 + rng.normal(0.0, 0.3, 5))
    >>> t = z_test(passive, active, sigma=np.radians(0.3))
    >>> t.identified, round(float(t.critical), 4), t.n_over_m
    (True, 1.96, 10.0)
    """
    alpha = float(as_probability("alpha", alpha))
    normality_alpha = float(as_probability("normality_alpha", normality_alpha))
    if not ratio > 1:
        raise ParameterError("ratio", f"must be > 1, got {ratio!r}")
    axes = _axes(passive, active, sigma, passive_elevation, active_elevation, sigma_elevation)
    k = len(axes)
    z_crit = float(stats.norm.ppf(1.0 - alpha / (2 * k)))
    n, m, zs, diff, sig, normality = _axis_statistics(axes)
    z, normal_p = np.array(zs, dtype=float), np.array(normality, dtype=float)
    beta, m_req = _power(delta, beta_max, float(sig[0]), m, alpha / k, n)
    return ZTest(
        z=z,
        p_value=2.0 * stats.norm.sf(np.abs(z)),
        critical=z_crit,
        identified=bool(np.all(np.abs(z) <= z_crit)),
        difference=np.array(diff, float),
        sigma=np.array(sig, float),
        n=n,
        m=m,
        n_over_m=n / m,
        large_population=n / m >= ratio,
        normality_p=normal_p,
        normal=bool(np.all(np.isnan(normal_p) | (normal_p >= normality_alpha))),
        beta=beta,
        m_required=m_req,
    )
