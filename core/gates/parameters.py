"""Validation of the gate parameters shared by several gate kinds.

Each function checks one kind of parameter, raising
:class:`plotgate.core.ParameterError` or :class:`plotgate.core.NonFiniteError` that
names the argument, and returns it coerced.

Symbols
-------
tau : time between the marks (s); v_min, v_max : speed bounds (m/s).
R_min, R_max : v_min tau and v_max tau, the radii of the ring gate (m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import ParameterError
from plotgate.core.validation import (
    as_array,
    as_scalar,
    require_nonnegative,
    require_positive,
)

__all__ = ["positive_coefficient", "ring_radii", "standard_deviation"]


def ring_radii(tau: float, v_min: float, v_max: float) -> tuple[float, float]:
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


def positive_coefficient(name: str, value: float) -> float:
    """Validate a window coefficient (k, K_R, K_az): a finite scalar > 0."""
    k = as_scalar(name, value)
    require_positive(name, k)
    return k


def standard_deviation(name: str, value: ArrayLike) -> np.ndarray:
    """Validate a standard deviation: finite and > 0, scalar or (N,)."""
    sigma = as_array(name, value)
    require_positive(name, sigma)
    return sigma
