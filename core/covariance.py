"""The check every 2x2 position covariance passes before any use, public for callers.

A caller that adds covariances (B = P1 + P2, S = P_pred + R) should check each term on
its own first: a sum can be positive definite while a term is not, and an error about
the sum names neither input. :func:`check_covariance` is the check core's own functions
apply to every covariance argument.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.validation import MAX_CONDITION, as_covariance

__all__ = ["MAX_CONDITION", "check_covariance"]


def check_covariance(P: ArrayLike, name: str = "P") -> np.ndarray:
    """Check (..., 2, 2) covariances: finite, symmetric, positive definite, well conditioned.

    Symmetric within 1e-9 of the trace (rounding), positive definite (P11 > 0 and
    det P > 0) and lambda_max / lambda_min at most :data:`MAX_CONDITION` (tested as
    det P >= trace(P)^2 / MAX_CONDITION, an error ellipse with an axis ratio below about
    10^6).

    Parameters
    ----------
    P : (..., 2, 2) array_like
        Covariances, m^2.
    name : str
        The argument's name in errors.

    Returns
    -------
    P : (..., 2, 2) ndarray
        The covariances as floats.

    Raises
    ------
    NonFiniteError
        On NaN or infinity (index: the first offending batch row).
    ParameterError
        If the trailing shape is not (2, 2).
    CovarianceError
        If a covariance is not symmetric, not positive definite or numerically singular;
        ``index`` is its flat batch index and ``reason`` prints that matrix.

    Examples
    --------
    >>> check_covariance([[4.0, 1.0], [1.0, 3.0]]).tolist()
    [[4.0, 1.0], [1.0, 3.0]]
    >>> from plotgate.core.errors import CovarianceError
    >>> try:
    ...     check_covariance([[[4.0, 0.0], [0.0, 1.0]], [[1.0, 2.0], [2.0, 1.0]]], "R")
    ... except CovarianceError as exc:
    ...     print(exc.field, exc.index, exc.reason)
    R 1 is not positive definite (det = -3.0): [[1.0, 2.0], [2.0, 1.0]]
    """
    return as_covariance(name, P)
