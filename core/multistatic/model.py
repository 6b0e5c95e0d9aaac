"""Range-sum measurement model of Fadeev et al. (multistatic radar, moving platforms).

Fadeev, Myakinkov and Ogurtsov (coordinate accuracy of a multistatic forward-scattering
radar with mobile positions), eq. (1): a transmitter at ``tx`` and a receiver at ``rx``
measure the range sum

.. math:: l = |\\mathbf{x} - \\mathbf{rx}| + |\\mathbf{x} - \\mathbf{tx}|

of a target at ``x``; its level curve is the ellipse (3D: ellipsoid) of equal range sum
with foci ``tx`` and ``rx``. Noise is N(0, sigma^2), independent per measurement.

Symbols and shapes (SI, metres)
-------------------------------
D : 2 (x east, y north) or 3 (x, y, z).
P : measurements per problem; each is a (transmitter, receiver) pair with its own
    positions, so several transmitters are simply pairs with different ``tx``.
N : independent problems (a batch, or the T samples of a trajectory).
x : (N, D) target positions. tx, rx : (N, P, D) or unbatched (P, D), broadcast.
l : (N, P) or (P,) range sums. sigma : scalar, (P,) or (N, P) noise standard deviations.

Platform positions are known at each time; moving platforms are either given per
sample or generated with :func:`platform_positions` (constant velocity, Fadeev et al., Fig. 2).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import ARRAY_1D, ARRAY_2D, ARRAY_3D, kernel
from plotgate.core.errors import GeometryError, ParameterError
from plotgate.core.validation import as_array, first_index

__all__ = [
    "COINCIDENT_RTOL",
    "BASELINE_SIGMAS",
    "Problem",
    "array_shape",
    "coerce_problem",
    "coordinate_scale",
    "copy_into",
    "first_invalid_problem",
    "platform_positions",
    "range_sum_jacobian",
    "range_sum_jacobian_unchecked",
    "range_sums",
    "range_sums_unchecked",
    "scale_of",
    "valid_geometry",
    "validate_problem",
    "validate_problem_reference",
    "validate_track",
    "vector_norm",
    "with_tx_axis",
]

COINCIDENT_RTOL = 1e-9
"""Two platforms closer than COINCIDENT_RTOL times the problem's coordinate scale
(the largest |coordinate| of its platforms, at least 1 m) are coincident."""

BASELINE_SIGMAS = 5.0
"""With a known sigma, a range sum may fall this many sigma below its baseline
|tx - rx| before it is refused: noise alone puts about half the measurements of a
target on a baseline below it (Fadeev et al. study exactly such baseline crossings)."""


class Problem(NamedTuple):
    """Validated multistatic problem from :func:`validate_problem` (a tuple; unpack it).

    Attributes
    ----------
    l : (N, P) ndarray
        Range sums, metres.
    tx, rx : (N, P, D) ndarray
        Transmitter and receiver of each pair, metres (new arrays, broadcast over N).
    sigma : (N, P) ndarray or None
        Noise standard deviations, metres; None when no sigma was given.
    """

    l: np.ndarray  # noqa: E741 (the contract and Fadeev et al. name the range sum l)
    tx: np.ndarray
    rx: np.ndarray
    sigma: np.ndarray | None


def array_shape(name: str, value: ArrayLike) -> tuple[int, ...]:
    """Shape of an array_like without coercing it; ParameterError naming ``name`` when
    the nesting is ragged."""
    try:
        return np.shape(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, f"must be a regular array of real numbers ({exc})") from None


def with_tx_axis(tx: ArrayLike) -> ArrayLike:
    """A single transmitter given as (D,) becomes (1, D), broadcast over the pairs.

    Other shapes pass through unchanged for the solvers' shape checks.
    """
    return np.asarray(tx)[None, :] if len(array_shape("tx", tx)) == 1 else tx


def _platforms(name: str, value: ArrayLike, max_ndim: int | None = 3) -> np.ndarray:
    """Coerce a (..., P, D) finite platform array with D in {2, 3}; index = batch row."""
    shape = array_shape(name, value)
    if len(shape) < 2 or shape[-1] not in (2, 3) or (max_ndim and len(shape) > max_ndim):
        form = "(P, D) or (N, P, D)" if max_ndim == 3 else "(..., P, D)"
        raise ParameterError(name, f"must have shape {form} with D = 2 or 3, got {shape}")
    return as_array(name, value, tuple(shape[-2:]))


def _positions(name: str, value: ArrayLike) -> np.ndarray:
    """Coerce (..., D) finite positions with D in {2, 3}."""
    shape = array_shape(name, value)
    if len(shape) < 1 or shape[-1] not in (2, 3):
        raise ParameterError(name, f"must have shape (..., D) with D = 2 or 3, got {shape}")
    return as_array(name, value, (shape[-1],))


def _model_inputs(
    x: ArrayLike, tx: ArrayLike, rx: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coerce x (..., D), tx/rx (..., P, D) and check that D and P agree."""
    x = _positions("x", x)
    tx = _platforms("tx", with_tx_axis(tx), max_ndim=None)
    rx = _platforms("rx", rx, max_ndim=None)
    d = x.shape[-1]
    for name, arr in (("tx", tx), ("rx", rx)):
        if arr.shape[-1] != d:
            raise ParameterError(name, f"has D = {arr.shape[-1]} but x has D = {d}")
    if tx.shape[-2] not in (1, rx.shape[-2]):
        raise ParameterError(
            "tx", f"has P = {tx.shape[-2]} measurements but rx has {rx.shape[-2]}"
        )
    try:
        np.broadcast_shapes(x.shape[:-1], tx.shape[:-2], rx.shape[:-2])
    except ValueError:
        raise ParameterError(
            "x",
            f"batch shape {x.shape[:-1]} does not broadcast with tx {tx.shape[:-2]} "
            f"and rx {rx.shape[:-2]}",
        ) from None
    return x, tx, rx


def platform_positions(
    initial: ArrayLike, velocity: ArrayLike, t: ArrayLike, t0: float = 0.0
) -> np.ndarray:
    """Positions of platforms moving at constant velocity (Fadeev et al., Fig. 2).

    .. math:: \\mathbf{p}(t) = \\mathbf{p}_0 + \\mathbf{v} (t - t_0)

    Platforms whose positions are known per sample need no model: pass those arrays
    directly as ``tx`` / ``rx``.

    Parameters
    ----------
    initial : (..., D) array_like
        Positions at t = 0, metres (D = 2 or 3).
    velocity : (..., D) array_like
        Velocities, m/s; broadcast against ``initial``.
    t : (T,) array_like or float
        Sample times, seconds (any epoch).
    t0 : float, optional
        The time at which the platforms are at ``initial``, seconds. Default 0; pass
        ``t[0]`` for positions given at the first sample, as the trajectory solve's
        state is.

    Returns
    -------
    positions : (T, ..., D) ndarray
        Position of every platform at every time (no T axis for a scalar t).

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If D is not 2 or 3, the D of the two arrays differ, their batch shapes do not
        broadcast, or t has more than one axis.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, Fig. 2: positions
       move on straight lines at constant speed (10 m/s in the paper's example).

    Examples
    --------
    >>> platform_positions([[0.0, 0.0], [1000.0, 0.0]], [10.0, 0.0], [0.0, 2.0])
    array([[[   0.,    0.],
            [1000.,    0.]],
    <BLANKLINE>
           [[  20.,    0.],
            [1020.,    0.]]])
    >>> platform_positions([0.0, 0.0], [10.0, 0.0], [1.7e9, 1.7e9 + 2.0], t0=1.7e9)
    array([[ 0.,  0.],
           [20.,  0.]])
    """
    initial = _positions("initial", initial)
    velocity = _positions("velocity", velocity)
    if velocity.shape[-1] != initial.shape[-1]:
        raise ParameterError(
            "velocity", f"has D = {velocity.shape[-1]} but initial has D = {initial.shape[-1]}"
        )
    try:
        batch = np.broadcast_shapes(initial.shape, velocity.shape)
    except ValueError:
        raise ParameterError(
            "velocity", f"shape {velocity.shape} does not broadcast with initial {initial.shape}"
        ) from None
    t = as_array("t", t)
    if t.ndim > 1:
        raise ParameterError("t", f"must have shape (T,), got {t.shape}")
    t0 = float(as_array("t0", t0))
    tau = (t - t0).reshape(t.shape + (1,) * len(batch))
    positions: np.ndarray = initial + tau * velocity
    return positions


def range_sums(x: ArrayLike, tx: ArrayLike, rx: ArrayLike) -> np.ndarray:
    """Range sums l_p = |x - rx_p| + |x - tx_p| (Fadeev et al., eq. 1).

    Parameters
    ----------
    x : (N, D) or (D,) array_like
        Target positions, metres (any leading batch shape broadcasting with tx, rx).
    tx, rx : (N, P, D) or (P, D) array_like
        Transmitter and receiver of each of the P pairs, metres. A single transmitter
        may also be given as (D,) (or with P = 1), broadcast over the pairs.

    Returns
    -------
    l : (N, P) ndarray
        Range sums in metres; (P,) when nothing is batched.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity.
    ParameterError
        If D is not 2 or 3, D or P differ between the arguments, or the batch shapes
        do not broadcast.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (1).

    Examples
    --------
    >>> range_sums([3000.0, 4000.0], [[0.0, 0.0]], [[6000.0, 0.0]])
    array([10000.])
    """
    return range_sums_unchecked(*_model_inputs(x, tx, rx))


def vector_norm(v: np.ndarray) -> np.ndarray:
    """Euclidean norm |v| along the last axis of checked arrays (no checks)."""
    norm: np.ndarray = np.sqrt(np.einsum("...i,...i->...", v, v))
    return norm


def range_sums_unchecked(x: np.ndarray, tx: np.ndarray, rx: np.ndarray) -> np.ndarray:
    """:func:`range_sums` without its checks: x (..., D), tx, rx (..., P, D) already
    validated (the solvers' inner loop)."""
    xp = x[..., None, :]
    ls: np.ndarray = vector_norm(xp - rx) + vector_norm(xp - tx)
    return ls


def _unit(v: np.ndarray) -> np.ndarray:
    """v / |v| along the last axis; 0 where v = 0 (the smallest subgradient of |v|)."""
    norm = vector_norm(v)[..., None]
    unit: np.ndarray = np.divide(
        v, norm, out=np.zeros(np.broadcast_shapes(v.shape, norm.shape)), where=norm > 0
    )
    return unit


def range_sum_jacobian(x: ArrayLike, tx: ArrayLike, rx: ArrayLike) -> np.ndarray:
    """Jacobian H of the range sums: dl_p/dx (Fadeev et al., the H_n of eq. 6).

    .. math:: \\frac{\\partial l_p}{\\partial \\mathbf{x}} =
              \\frac{\\mathbf{x} - \\mathbf{rx}_p}{|\\mathbf{x} - \\mathbf{rx}_p|} +
              \\frac{\\mathbf{x} - \\mathbf{tx}_p}{|\\mathbf{x} - \\mathbf{tx}_p|}

    The row is the sum of the unit vectors from the two foci; it vanishes on the
    baseline between them (Fadeev et al.: the ellipse degenerates to the segment and the
    cross-baseline derivative is zero). Where x sits exactly on a platform the
    gradient of that distance is undefined; its term is taken as 0 (the smallest
    subgradient) so the result stays finite.

    Parameters
    ----------
    x : (N, D) or (D,) array_like
        Target positions, metres.
    tx, rx : (N, P, D) or (P, D) array_like
        Transmitter and receiver of each pair, metres.

    Returns
    -------
    H : (N, P, D) ndarray
        Dimensionless; (P, D) when nothing is batched.

    Raises
    ------
    NonFiniteError, ParameterError
        As :func:`range_sums`.

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eqs. (1), (3), (6).

    Examples
    --------
    >>> range_sum_jacobian([3000.0, 4000.0], [[0.0, 0.0]], [[6000.0, 0.0]])
    array([[0. , 1.6]])
    """
    return range_sum_jacobian_unchecked(*_model_inputs(x, tx, rx))


def range_sum_jacobian_unchecked(x: np.ndarray, tx: np.ndarray, rx: np.ndarray) -> np.ndarray:
    """:func:`range_sum_jacobian` without its checks: x (..., D), tx, rx (..., P, D)
    already validated (the solvers' inner loop)."""
    xp = x[..., None, :]
    H: np.ndarray = _unit(xp - rx) + _unit(xp - tx)
    return H


def _batch_length(**shapes: tuple[int, ...]) -> int:
    """Common N of arguments with an optional single batch axis (1 when none has one)."""
    n, owner = None, ""
    for name, batch in shapes.items():
        if batch:
            if n is not None and batch[0] != n:
                raise ParameterError(name, f"has N = {batch[0]} problems but {owner} has {n}")
            n, owner = batch[0], name
    return 1 if n is None else n


def coordinate_scale(tx: np.ndarray, rx: np.ndarray) -> np.ndarray:
    """Coordinate scale (N,) of N problems: the largest |platform coordinate|, >= 1 m.

    Platform tolerances (``COINCIDENT_RTOL``) are relative to it.
    """
    big = np.maximum(np.abs(tx).max(axis=(-2, -1)), np.abs(rx).max(axis=(-2, -1)))
    scale: np.ndarray = np.maximum(big, 1.0)
    return scale


def validate_track(
    x0: ArrayLike, v: ArrayLike, t: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Check and coerce a constant-velocity track: position x0, velocity v, times t.

    Parameters
    ----------
    x0 : (D,) array_like
        Position at the first sample time, metres; D = 2 or 3.
    v : (D,) array_like
        Velocity, m/s.
    t : (T,) array_like
        Sample times, seconds; T >= 1.

    Returns
    -------
    x0, v, t : ndarray
        As float arrays.

    Raises
    ------
    NonFiniteError, ParameterError
        If a value is not finite or a shape is wrong (field ``"x0"``, ``"v"`` or ``"t"``).
    """
    t = as_array("t", t)
    if t.ndim != 1 or t.size < 1:
        raise ParameterError("t", f"must have shape (T,) with T >= 1, got {t.shape}")
    x0 = as_array("x0", x0)
    if x0.shape not in ((2,), (3,)):
        raise ParameterError("x0", f"must have shape (D,) with D = 2 or 3, got {x0.shape}")
    v = as_array("v", v)
    if v.shape != x0.shape:
        raise ParameterError("v", f"must have the shape of x0 {x0.shape}, got {v.shape}")
    return x0, v, t


def validate_problem(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    baseline_tol: ArrayLike | None = None,
) -> Problem:
    """Check and coerce a batch of range-sum problems (shared by every solver).

    Parameters
    ----------
    l : (N, P) or (P,) array_like
        Measured range sums, metres, finite and >= 0.
    tx, rx : (N, P, D) or (P, D) array_like
        Transmitter and receiver of each pair, metres; D = 2 or 3.
    sigma : float, (P,) or (N, P) array_like, optional
        Noise standard deviations, metres, > 0.
    baseline_tol : float, (P,) or (N, P) array_like, optional
        How far (metres) a range sum may fall below its baseline |tx_p - rx_p| before
        it is refused. Default: ``BASELINE_SIGMAS * sigma`` when sigma is given, else
        0. A rounding allowance of ``COINCIDENT_RTOL`` times the coordinate scale is
        always added.

    Returns
    -------
    problem : Problem
        ``(l, tx, rx, sigma)`` as new float arrays of shapes (N, P), (N, P, D),
        (N, P, D) and (N, P) (sigma None when not given); N = 1 when nothing is batched.

    Raises
    ------
    NonFiniteError
        If an input contains NaN or infinity (index: first bad problem).
    ParameterError
        On a wrong shape, D not 2 or 3, N or P that differ between the arguments, fewer
        measurements than unknowns (P < D; field ``"l"``), a negative range sum, or
        sigma <= 0 (or baseline_tol < 0).
    GeometryError
        If a transmitter coincides with its receiver (field ``"rx"``), the same
        (tx, rx) pair appears twice in a problem (``"rx"``; with one transmitter:
        two receivers are equal), or a range sum is shorter than its baseline, which
        no target position can produce (``"l"``).

    Notes
    -----
    Platforms coincide when closer than ``COINCIDENT_RTOL`` times the problem's
    coordinate scale (largest |platform coordinate|, at least 1 m). Error indices
    are the first offending problem n (None when the argument is unbatched).

    References
    ----------
    .. [1] R. S. Fadeev, A. V. Myakinkov, A. G. Ogurtsov, eq. (1):
       l >= |tx - rx| by the triangle inequality.

    Examples
    --------
    >>> p = validate_problem([10000.0, 9000.0], [0.0, 0.0], [[6000.0, 0.0], [0.0, 6000.0]])
    >>> p.l.shape, p.tx.shape, p.rx.shape, p.sigma
    ((1, 2), (1, 2, 2), (1, 2, 2), None)
    """
    problem, allow = coerce_problem(l, tx, rx, sigma, baseline_tol=baseline_tol)
    sig = problem.sigma if problem.sigma is not None else np.ones_like(problem.l)
    if first_invalid_problem(problem.l, sig, problem.tx, problem.rx, allow) >= 0:
        validate_problem_reference(l, tx, rx, sigma, baseline_tol=baseline_tol)  # names it
    return problem


def validate_problem_reference(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    baseline_tol: ArrayLike | None = None,
) -> Problem:
    """:func:`validate_problem` in numpy: the reference of its compiled check.

    The same checks, each a vectorized pass that raises the error naming the field and
    the first bad problem; :func:`validate_problem` runs it only when its compiled
    check (:func:`first_invalid_problem`) has found a bad problem, to name it.
    """
    ls, tx, rx, sig, n = _shaped_problem(l, tx, rx, sigma)
    p = rx.shape[-2]
    negative: np.ndarray = ls < 0
    if negative.any():
        index = first_index(np.asarray(negative.any(axis=-1)))
        row = ls[index] if index is not None else ls
        raise ParameterError("l", f"must be non-negative, got {row.tolist()}", index)
    if sig is not None and not (sig > 0).all():
        bad = ~(sig > 0)
        index = first_index(np.asarray(bad.any(axis=-1))) if sig.ndim == 2 else None
        row = sig[index] if index is not None else sig
        raise ParameterError("sigma", f"must be positive, got {row.tolist()}", index)
    problem = _broadcast_problem(ls, tx, rx, sig, n)
    ls, tx, rx, sig = problem
    tol = COINCIDENT_RTOL * coordinate_scale(tx, rx)  # (N,)

    baseline = np.linalg.norm(rx - tx, axis=-1)  # (N, P)
    coincident = baseline <= tol[:, None]
    if coincident.any():
        index = int(np.argmax(coincident.any(axis=-1)))
        k = int(np.argmax(coincident[index]))
        raise GeometryError(
            "rx", f"receiver {k} coincides with its transmitter at {tx[index, k].tolist()}", index
        )
    if p > 1:
        # (N, P, P) pair distances: a pair repeated has equal tx and equal rx.
        same_rx = np.linalg.norm(rx[:, :, None] - rx[:, None], axis=-1) <= tol[:, None, None]
        same_tx = np.linalg.norm(tx[:, :, None] - tx[:, None], axis=-1) <= tol[:, None, None]
        dup = np.triu(same_rx & same_tx, k=1)
        if dup.any():
            index = int(np.argmax(dup.any(axis=(-2, -1))))
            i, j = np.unravel_index(int(np.argmax(dup[index])), (p, p))
            raise GeometryError(
                "rx",
                f"receivers {i} and {j} are at the same position "
                f"{rx[index, i].tolist()} with the same transmitter",
                index,
            )
    allow = _baseline_allowance(baseline_tol, sig, n, p)
    short = ls < baseline - allow - tol[:, None]
    if short.any():
        index = int(np.argmax(short.any(axis=-1)))
        k = int(np.argmax(short[index]))
        raise GeometryError(
            "l",
            f"range sum {k} = {float(ls[index, k])} m is shorter than its baseline "
            f"|tx - rx| = {float(baseline[index, k])} m; no target position gives it",
            index,
        )
    return problem


def coerce_problem(
    l: ArrayLike,  # noqa: E741 (Fadeev et al. name the range sum l)
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    baseline_tol: ArrayLike | None = None,
) -> tuple[Problem, np.ndarray]:
    """:func:`validate_problem`'s shapes without its value checks: (problem, allowance).

    Shapes, finiteness and the broadcast to (N, P, ...) are checked (their errors name
    the field); the values (signs, platforms, baselines) are not: a solver that fuses
    :func:`valid_geometry` into its kernel runs :func:`validate_problem_reference` when
    that fails. The allowance (N, P) is how far each range sum may fall below its
    baseline (``baseline_tol``'s default: BASELINE_SIGMAS sigma, else 0).
    """
    ls, tx, rx, sig, n = _shaped_problem(l, tx, rx, sigma)
    problem = _broadcast_problem(ls, tx, rx, sig, n)
    return problem, _baseline_allowance(baseline_tol, problem.sigma, n, rx.shape[-2])


def _shaped_problem(
    l: ArrayLike,  # noqa: E741
    tx: ArrayLike,
    rx: ArrayLike,
    sigma: ArrayLike | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, int]:
    """Coerce l, tx, rx and sigma and check their shapes; (l, tx, rx, sigma, N) unbroadcast."""
    tx = _platforms("tx", with_tx_axis(tx))
    rx = _platforms("rx", rx)
    if rx.shape[-1] != tx.shape[-1]:
        raise ParameterError("rx", f"has D = {rx.shape[-1]} but tx has D = {tx.shape[-1]}")
    d = tx.shape[-1]
    p = rx.shape[-2]
    if tx.shape[-2] not in (1, p):
        raise ParameterError("tx", f"has P = {tx.shape[-2]} measurements but rx has {p}")
    l_shape = array_shape("l", l)
    if len(l_shape) not in (1, 2):
        raise ParameterError("l", f"must have shape (P,) or (N, P), got {l_shape}")
    ls = as_array("l", l, (l_shape[-1],))
    if ls.shape[-1] != p:
        raise ParameterError("l", f"has P = {ls.shape[-1]} measurements but rx has {p}")
    shapes = {"l": ls.shape[:-1], "tx": tx.shape[:-2], "rx": rx.shape[:-2]}
    sig = None
    if sigma is not None:
        sig = as_array("sigma", sigma)
        if sig.ndim > 2 or (sig.ndim >= 1 and sig.shape[-1] != p):
            raise ParameterError(
                "sigma",
                f"must be a scalar or have shape (P,) or (N, P) with P = {p}, got {sig.shape}",
            )
        shapes["sigma"] = sig.shape[:-1]
    n = _batch_length(**shapes)
    if p < d:
        raise ParameterError(
            "l", f"has {p} measurements but the position has {d} unknowns; at least {d} are needed"
        )
    return ls, tx, rx, sig, n


def _broadcast_problem(
    ls: np.ndarray, tx: np.ndarray, rx: np.ndarray, sig: np.ndarray | None, n: int
) -> Problem:
    """New C-contiguous arrays of shapes (N, P), (N, P, D), (N, P, D) and (N, P)."""
    p, d = rx.shape[-2:]
    return Problem(  # C order: the compiled checks and solves read C-contiguous arrays
        np.array(np.broadcast_to(ls, (n, p)), order="C"),
        np.array(np.broadcast_to(tx, (n, p, d)), order="C"),
        np.array(np.broadcast_to(rx, (n, p, d)), order="C"),
        None if sig is None else np.array(np.broadcast_to(sig, (n, p)), order="C"),
    )


def _baseline_allowance(
    baseline_tol: ArrayLike | None, sig: np.ndarray | None, n: int, p: int
) -> np.ndarray:
    """(N, P) metres each range sum may fall below its baseline; checks baseline_tol.

    Always a writable C-ordered copy: the compiled check takes writable arrays, and a
    broadcast view of an (N, P) tolerance is read-only though already contiguous."""
    if baseline_tol is None:
        return BASELINE_SIGMAS * sig if sig is not None else np.zeros((n, p))
    allow = as_array("baseline_tol", baseline_tol)
    if not (allow >= 0).all():
        raise ParameterError("baseline_tol", f"must be non-negative, got {allow.tolist()}")
    try:
        return np.array(np.broadcast_to(allow, (n, p)), order="C")
    except ValueError:
        raise ParameterError(
            "baseline_tol", f"shape {allow.shape} does not broadcast with (N, P) = {(n, p)}"
        ) from None


@kernel(numba.void(ARRAY_1D, ARRAY_1D), inline=True)
def copy_into(src: np.ndarray, dst: np.ndarray) -> None:  # pragma: no cover (compiled)
    """dst[:] = src, element by element: numba's slice assignment guards against
    overlap with a copy it allocates, which a kernel compiled without references
    (``refcounts=False``) cannot."""
    for i in range(src.size):
        dst[i] = src[i]


@kernel(numba.float64(ARRAY_2D, ARRAY_2D), inline=True)
def scale_of(tx: np.ndarray, rx: np.ndarray) -> float:  # pragma: no cover (compiled)
    """:func:`coordinate_scale` of one problem's platforms tx, rx (P, D), compiled."""
    p, d = tx.shape
    big = 1.0
    for k in range(p):
        for i in range(d):
            big = max(big, abs(tx[k, i]), abs(rx[k, i]))
    return big


@kernel(numba.boolean(ARRAY_1D, ARRAY_1D, ARRAY_2D, ARRAY_2D, ARRAY_1D), inline=True)
def valid_geometry(
    l: np.ndarray,  # noqa: E741 (Fadeev et al. name the range sum l)
    sigma: np.ndarray,
    tx: np.ndarray,
    rx: np.ndarray,
    allow: np.ndarray,
) -> bool:  # pragma: no cover (compiled)
    """:func:`validate_problem_reference`'s value checks of one problem, compiled: pass/fail.

    l, sigma, allow (P,) and tx, rx (P, D) finite. Fails on a negative range sum, sigma
    <= 0, a receiver on its transmitter, a repeated pair, or a range sum more than its
    allowance (and rounding) below its baseline, with the reference's arithmetic.
    """
    p, d = tx.shape
    tol = COINCIDENT_RTOL * scale_of(tx, rx)
    for k in range(p):
        baseline = 0.0
        for i in range(d):
            baseline += (rx[k, i] - tx[k, i]) * (rx[k, i] - tx[k, i])
        baseline = np.sqrt(baseline)
        if not (l[k] >= 0.0 and sigma[k] > 0.0 and baseline > tol):
            return False
        if l[k] < baseline - allow[k] - tol:
            return False
        for j in range(k):
            same_rx = 0.0
            same_tx = 0.0
            for i in range(d):
                same_rx += (rx[k, i] - rx[j, i]) * (rx[k, i] - rx[j, i])
                same_tx += (tx[k, i] - tx[j, i]) * (tx[k, i] - tx[j, i])
            if np.sqrt(same_rx) <= tol and np.sqrt(same_tx) <= tol:
                return False
    return True


@kernel(numba.int64(ARRAY_2D, ARRAY_2D, ARRAY_3D, ARRAY_3D, ARRAY_2D))
def first_invalid_problem(
    ls: np.ndarray, sigma: np.ndarray, tx: np.ndarray, rx: np.ndarray, allow: np.ndarray
) -> int:  # pragma: no cover (compiled)
    """The first of N problems :func:`valid_geometry` fails, or -1."""
    for n in range(ls.shape[0]):
        if not valid_geometry(ls[n], sigma[n], tx[n], rx[n], allow[n]):
            return n
    return -1
