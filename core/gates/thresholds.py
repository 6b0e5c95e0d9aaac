"""Gate thresholds and coefficients from a gating probability.

Symbols
-------
P_G : gating probability of the chi-square ellipse gate (Konovalov).
n : dimension of the measurement (degrees of freedom); 2 for plane positions.
gamma : chi-square gate threshold, rho <= gamma accepts (dimensionless).
p : probability behind the expansion coefficient of the expanded gate.
K_g : expansion coefficient, the gate grows by K_g sigma per axis (Konovalov).
P : probability held by a rectangular gate |d_i| <= k sigma_i (the secondary-processing
    textbook, Fig. 3.6 b).
k : rectangular gate half-width in standard deviations.

Every function accepts a scalar (returning a float) or an array of probabilities
(returning an array of the same shape). The gate threshold and the expansion coefficient
of a scalar probability are memoized: scipy's ``chi2.ppf`` costs 0.1-0.4 ms a call, more
than a gate test on 10 pairs, and a gate's probability is one scalar per test with few
distinct values in practice. A probability is validated before it is looked up, so an
invalid one never enters the cache.

The quantiles are scipy.special's functions that scipy.stats' ``chi2.ppf`` and
``norm.isf`` call for a probability in (0, 1) (``2 gammaincinv(n/2, P)`` and
``-ndtri(q)``), so the values are the same to the bit; importing scipy.stats would cost
a gate test alone ~0.2 s of imports (it pulls in scipy.optimize, sparse and spatial).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike
from scipy import special

from plotgate.core.validation import as_dof, as_probability

__all__ = ["expansion_coefficient", "gate_threshold", "rectangular_coefficient"]


def _scalar_or_array(x: np.ndarray) -> float | np.ndarray:
    return float(x) if np.ndim(x) == 0 else np.asarray(x)


def _chi2_ppf(P: float | np.ndarray, n: int) -> np.ndarray:
    """F^-1 of chi-square with n degrees of freedom at validated P (scipy.stats' own)."""
    return np.asarray(2.0 * special.gammaincinv(n / 2, P))


@functools.lru_cache(maxsize=256)
def _chi2_quantile(P_G: float, n: int) -> float:
    """F^-1 of chi-square with n degrees of freedom at a validated scalar P_G, memoized."""
    return float(_chi2_ppf(P_G, n))


@functools.lru_cache(maxsize=256)
def _expansion(p: float) -> float:
    """sqrt(-2 ln(1 - p)) at a validated scalar p, memoized."""
    return float(np.sqrt(-2.0 * np.log1p(-p)))


def gate_threshold(P_G: ArrayLike, n: int = 2) -> float | np.ndarray:
    """Chi-square gate threshold gamma for gating probability P_G in n dimensions.

    .. math:: \\gamma = F^{-1}_{\\chi^2_n}(P_G)

    A mark whose innovation has covariance S falls in the gate
    :math:`\\nu^T S^{-1} \\nu \\le \\gamma` with probability P_G.

    Parameters
    ----------
    P_G : float or ndarray
        Gating probability, in the open interval (0, 1).
    n : int, optional
        Measurement dimension (degrees of freedom), >= 1. Default 2.

    Returns
    -------
    gamma : float or ndarray
        Threshold on the squared Mahalanobis distance rho; same shape as P_G.

    Raises
    ------
    ParameterError
        If P_G is not a finite value in (0, 1) (``field="P_G"``), or n is not an
        integer >= 1 (``field="n"``).

    References
    ----------
    .. [1] A. A. Konovalov, gate sizing and shaping for tentative track formation,
       two-stage gating procedure: "for n = 2 and P_G = 0.9 the gating
       threshold gamma = 4.6".

    Examples
    --------
    >>> round(gate_threshold(0.9), 3)
    4.605
    >>> round(gate_threshold(0.99, n=3), 3)
    11.345
    """
    n = as_dof("n", n)
    if type(P_G) is float and 0.0 < P_G < 1.0:  # the common case, without an array
        return _chi2_quantile(P_G, n)
    P = as_probability("P_G", P_G)
    if P.ndim == 0:
        return _chi2_quantile(float(P), n)
    return _scalar_or_array(_chi2_ppf(P, n))


def expansion_coefficient(p: ArrayLike) -> float | np.ndarray:
    """Expansion coefficient K_g of the expanded ellipse gate for probability p.

    .. math:: K_g = \\sqrt{-2 \\ln(1 - p)}

    K_g is the radius that holds probability p of a circular 2-D normal error
    with unit sigmas, so :math:`K_g^2` equals ``gate_threshold(p, 2)``.

    Parameters
    ----------
    p : float or ndarray
        Probability of the mark falling in the gate, in the open interval (0, 1).

    Returns
    -------
    K_g : float or ndarray
        Gate expansion in standard deviations; same shape as p.

    Raises
    ------
    ParameterError
        If p is not a finite value in (0, 1) (``field="p"``).

    References
    ----------
    .. [1] A. A. Konovalov, expanded gate of his ref. [4] (Fig. 3):
       :math:`\\delta X(Y) = K_g \\sigma_{X(Y)}`, :math:`K_g = \\sqrt{-2 \\ln(1-p)}`,
       "for probabilities 0.9...0.95, K_g = 2.15...2.45".

    Examples
    --------
    >>> round(expansion_coefficient(0.9), 3), round(expansion_coefficient(0.95), 3)
    (2.146, 2.448)
    """
    q = as_probability("p", p)
    if q.ndim == 0:
        return _expansion(float(q))
    return _scalar_or_array(np.sqrt(-2.0 * np.log1p(-q)))


def rectangular_coefficient(P: ArrayLike, n: int = 2) -> float | np.ndarray:
    """Half-width k (in sigmas) of a rectangular gate that holds probability P.

    A rectangular gate :math:`|d_i| \\le k \\sigma_i` on n independent normal axes
    holds :math:`(2\\Phi(k) - 1)^n`; setting that to P gives

    .. math:: k = \\Phi^{-1}\\left(\\frac{1 + P^{1/n}}{2}\\right)
              = \\bar\\Phi^{-1}\\left(\\frac{1 - P^{1/n}}{2}\\right),

    evaluated in the second form with :math:`1 - P^{1/n} = -\\mathrm{expm1}(\\ln P / n)`
    to keep precision for P close to 1.

    Parameters
    ----------
    P : float or ndarray
        Probability held by the whole gate, in the open interval (0, 1).
    n : int, optional
        Number of independent axes, >= 1. Default 2.

    Returns
    -------
    k : float or ndarray
        Half-width of the gate per axis in standard deviations; same shape as P.

    Raises
    ------
    ParameterError
        If P is not a finite value in (0, 1) (``field="P"``), or n is not an
        integer >= 1 (``field="n"``).

    References
    ----------
    .. [1] The secondary-processing textbook, rectangular gate (Fig. 3.6 b) and its
       sizing: half-widths of 1, 2 and 3 summed sigmas
       hold about 0.68, 0.92 and 0.997.

    Examples
    --------
    >>> round(rectangular_coefficient(0.9973, n=1), 3)
    3.0
    >>> round(rectangular_coefficient(0.9), 3)
    1.949
    """
    n = as_dof("n", n)
    held = as_probability("P", P)
    tail = -np.expm1(np.log(held) / n)
    return _scalar_or_array(-special.ndtri(0.5 * tail))
