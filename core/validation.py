"""Input coercion and checks shared by the core modules (private).

Every public core function passes its inputs through these helpers before doing
any math. Each check is one vectorized pass; the first offending row is located
only on the error path. Batch indices in errors are flat (C order) over the
leading batch axes, i.e. the row number for an (N, ...) batch.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import kernel
from plotgate.core.errors import CovarianceError, NonFiniteError, ParameterError

__all__ = [
    "as_array",
    "as_covariance",
    "as_dof",
    "as_float_array",
    "as_points",
    "as_probability",
    "as_scalar",
    "broadcast_batch",
    "first_index",
    "first_invalid_covariance",
    "is_valid_covariance",
    "pair_count",
    "require",
    "require_nonnegative",
    "require_positive",
    "require_scalar",
    "to_pairs",
    "valid_covariances",
]

SYMMETRY_RTOL = 1e-9
MAX_CONDITION = 1e12
"""Largest lambda_max / lambda_min of a covariance: an error ellipse with an axis ratio
above 10^6 cannot be rotated in double precision (rounding of the large axis swamps the
small one), so it is refused as numerically singular."""
"""Largest accepted |P12 - P21| relative to |P11| + |P22|."""


def first_index(bad: np.ndarray) -> int | None:
    """Flat index of the first True of a batch mask; None for a 0-d mask."""
    if bad.ndim == 0:
        return None
    return int(np.argmax(bad.ravel()))


def _row(x: np.ndarray, index: int | None, core_ndim: int) -> np.ndarray:
    """The batch row at a flat index (the whole array when index is None)."""
    if index is None:
        return x
    row: np.ndarray = x.reshape((-1, *x.shape[x.ndim - core_ndim :]))[index]
    return row


def as_float_array(name: str, value: ArrayLike, core_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Coerce to a float array whose trailing shape is core_shape, not yet checked finite.

    :func:`as_array` without its finiteness pass, for a compiled kernel that checks every
    value in the pass that uses it. Raises ParameterError when value is not real-valued
    or has the wrong trailing shape.
    """
    try:
        x = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, f"must be real numbers ({exc})") from None
    core_ndim = len(core_shape)
    if x.ndim < core_ndim or x.shape[x.ndim - core_ndim :] != core_shape:
        inner = ", ".join(str(k) for k in core_shape)
        raise ParameterError(name, f"must have shape (..., {inner}), got shape {x.shape}")
    return x


def as_array(name: str, value: ArrayLike, core_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Coerce to a float array whose trailing shape is core_shape and whose values are finite.

    Raises ParameterError when value is not real-valued or has the wrong trailing
    shape, and NonFiniteError (with the first offending batch row) on NaN or infinity.
    """
    x = as_float_array(name, value, core_shape)
    core_ndim = len(core_shape)
    finite = np.isfinite(x)
    if not finite.all():
        bad = ~finite.all(axis=tuple(range(x.ndim - core_ndim, x.ndim)))
        index = first_index(bad)
        raise NonFiniteError(
            name, f"must be finite, got {_row(x, index, core_ndim).tolist()}", index
        )
    return x


def as_points(name: str, value: ArrayLike) -> np.ndarray:
    """Coerce 2-D positions: an (..., 2) finite float array (x east, y north; metres)."""
    return as_array(name, value, (2,))


def valid_covariances(P: np.ndarray) -> np.ndarray:
    """Which finite (..., 2, 2) covariances pass :func:`as_covariance`'s checks: a bool mask.

    Symmetric within SYMMETRY_RTOL, P11 > 0, and det P >= trace(P)^2 / MAX_CONDITION
    (so det P > 0), each one vectorized pass: the numpy reference of
    :func:`first_invalid_covariance`.
    """
    P11, P12, P21, P22 = P[..., 0, 0], P[..., 0, 1], P[..., 1, 0], P[..., 1, 1]
    symmetric = P12 == P21
    if not symmetric.all():
        symmetric = np.abs(P12 - P21) <= SYMMETRY_RTOL * (np.abs(P11) + np.abs(P22))
    det = P11 * P22 - P12 * P12  # as the math downstream computes it
    trace = P11 + P22
    # lambda_min / lambda_max = det / lambda_max^2 >= det / trace^2, so this refuses every
    # condition number above MAX_CONDITION (and some within a factor 4 below it) cheaply.
    valid: np.ndarray = symmetric & (P11 > 0) & (det * MAX_CONDITION >= trace * trace)
    return valid


@kernel("boolean(float64, float64, float64, float64)")
def is_valid_covariance(P11: float, P12: float, P21: float, P22: float) -> bool:
    """One matrix [[P11, P12], [P21, P22]] is finite and passes :func:`valid_covariances`.

    The same comparisons on the same rounded values, for compiled kernels that check
    their covariances in the pass that uses them.
    """
    if not (
        math.isfinite(P11) and math.isfinite(P12) and math.isfinite(P21) and math.isfinite(P22)
    ):
        return False
    if P12 != P21 and not abs(P12 - P21) <= SYMMETRY_RTOL * (abs(P11) + abs(P22)):
        return False
    det = P11 * P22 - P12 * P12
    trace = P11 + P22
    return P11 > 0.0 and det * MAX_CONDITION >= trace * trace


@kernel("int64(Array(float64, 2, 'C', readonly=True))")
def first_invalid_covariance(P: np.ndarray) -> int:
    """First row of (M, 4) covariances [P11, P12, P21, P22] failing :func:`is_valid_covariance`.

    -1 when every row passes: the one pass :func:`as_covariance` makes over a valid batch.
    """
    for i in range(P.shape[0]):
        if not is_valid_covariance(P[i, 0], P[i, 1], P[i, 2], P[i, 3]):
            return i
    return -1


def as_covariance(name: str, value: ArrayLike) -> np.ndarray:
    """Coerce (..., 2, 2) covariances and check they are symmetric positive definite.

    Symmetry allows |P12 - P21| <= SYMMETRY_RTOL (|P11| + |P22|) for rounding;
    the math downstream reads the upper element P12. Positive definiteness uses
    the 2x2 closed form P11 > 0 and det P > 0, and the condition number must not exceed
    MAX_CONDITION, checked as det P >= trace(P)^2 / MAX_CONDITION.
    Raises NonFiniteError with the first non-finite batch row, then CovarianceError with
    the first offending batch row. A valid batch costs one compiled pass
    (:func:`first_invalid_covariance`); an invalid one is diagnosed in numpy.
    """
    P = as_float_array(name, value, (2, 2))
    if first_invalid_covariance(np.ascontiguousarray(P.reshape(-1, 4))) < 0:
        return P
    P = as_array(name, P, (2, 2))
    valid = valid_covariances(P)
    if not valid.all():
        index = first_index(~valid)
        row = _row(P, index, 2)
        (P11, P12), (P21, P22) = row
        det = P11 * P22 - P12 * P12
        if not (P12 == P21 or np.abs(P12 - P21) <= SYMMETRY_RTOL * (np.abs(P11) + np.abs(P22))):
            reason = "is not symmetric"
        elif not (P11 > 0 and det > 0):
            reason = f"is not positive definite (det = {det.tolist()})"
        else:
            low, high = np.linalg.eigvalsh(row)
            reason = (
                f"is numerically singular: eigenvalues {low:.3g} and {high:.3g}; "
                f"the error ellipse's axis ratio must stay below about "
                f"{np.sqrt(MAX_CONDITION):.0e}"
            )
        raise CovarianceError(name, f"{reason}: {row.tolist()}", index)
    return P


def require_scalar(name: str, value: ArrayLike) -> None:
    """Raise ParameterError unless value is a scalar (0-d)."""
    if np.ndim(value) != 0:
        raise ParameterError(name, f"must be a scalar, got shape {np.shape(value)}")


def as_scalar(name: str, value: ArrayLike) -> float:
    """Coerce a finite real scalar (a gate parameter such as tau or v_max).

    A finite Python float (what a request carries) is returned as it is, without the
    array round trip: the checks below accept it unchanged.
    """
    if type(value) is float and math.isfinite(value):
        return value
    require_scalar(name, value)
    return float(as_array(name, value))


def as_probability(name: str, value: ArrayLike) -> np.ndarray:
    """Coerce probabilities in the open interval (0, 1); NaN and infinity are refused."""
    try:
        p = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, f"must be real numbers ({exc})") from None
    valid = (p > 0.0) & (p < 1.0)
    if not valid.all():
        index = first_index(~valid)
        raise ParameterError(
            name, f"must lie in the open interval (0, 1), got {_row(p, index, 0).tolist()}", index
        )
    return p


def as_dof(name: str, value: object) -> int:
    """Check a dimension (degrees of freedom): an int >= 1."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ParameterError(name, f"must be an integer >= 1, got {value!r}")
    return int(value)


def _require(name: str, x: np.ndarray | float, valid: np.ndarray | np.bool_, what: str) -> None:
    if not np.all(valid):
        bad = ~np.asarray(valid)
        index = first_index(bad)
        value = _row(np.asarray(x), index, 0).tolist()
        raise ParameterError(name, f"must be {what}, got {value}", index)


def require_positive(name: str, x: np.ndarray | float) -> None:
    """Raise ParameterError unless every value of x is > 0."""
    if type(x) is float and x > 0.0:  # a checked scalar: no array pass
        return
    _require(name, x, np.greater(x, 0.0), "positive")


def require_nonnegative(name: str, x: np.ndarray | float) -> None:
    """Raise ParameterError unless every value of x is >= 0."""
    if type(x) is float and x >= 0.0:
        return
    _require(name, x, np.greater_equal(x, 0.0), "non-negative")


def broadcast_batch(**batch_shapes: tuple[int, ...]) -> tuple[int, ...]:
    """Broadcast the batch shapes of named arguments (numpy rules).

    Raises ParameterError naming the first argument that does not broadcast with
    the ones before it.
    """
    shape: tuple[int, ...] = ()
    for name, batch_shape in batch_shapes.items():
        try:
            shape = np.broadcast_shapes(shape, batch_shape)
        except ValueError:
            raise ParameterError(
                name, f"batch shape {batch_shape} does not broadcast with {shape}"
            ) from None
    return shape


def pair_count(**batch_shapes: tuple[int, ...]) -> int:
    """Number N of pairs from the batch shapes of named arguments.

    Each argument is either unbatched (shape ``()``) or has one batch axis of the
    common length N; with no batched argument N = 1. Raises ParameterError on a
    second batch axis or a length that differs from the others.
    """
    n = None
    owner = ""
    for name, batch_shape in batch_shapes.items():
        if len(batch_shape) > 1:
            raise ParameterError(
                name, f"has batch shape {batch_shape}; gates take one leading batch axis (N,)"
            )
        if batch_shape:
            if n is not None and batch_shape[0] != n:
                raise ParameterError(
                    name, f"has batch length {batch_shape[0]} but {owner} has {n}"
                )
            n, owner = batch_shape[0], name
    return 1 if n is None else n


def to_pairs(x: np.ndarray | float, n: int) -> np.ndarray:
    """Return x as an (n,) array; an unbatched value is broadcast into a new array."""
    x = np.asarray(x)
    if x.shape == (n,):
        return x
    return np.full(n, x)


def require(
    field: str,
    ok: np.ndarray | np.bool_,
    reason: Callable[[int], str],
    error: type[ParameterError] | type[CovarianceError] = ParameterError,
) -> None:
    """Raise ``error(field, reason(i), i)`` at the first row i where ``ok`` is False."""
    if not ok.all():
        i = first_index(np.asarray(~ok))
        assert i is not None
        raise error(field, reason(i), i)
