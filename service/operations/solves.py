"""Multistatic position solves, bounds and noise estimates (Fadeev et al.).

The wire's problems, platforms and series become core's arrays: range sums l (N, P),
transmitters and receivers (N, P, D) and sigmas (N, P). Core solves a batch whose
problems share P, so ``solves.position`` groups the problems by their number of pairs
(and by whether they carry an initial guess) and makes one vectorized core call per
group; error indices are mapped back to the request's problem numbers.

Platforms given as a position plus a velocity are placed with
:func:`plotgate.core.multistatic.platform_positions` with ``t0 = sample_times[0]`` (the wire's
position is the one at the first sample time); per-sample positions are used as given.

Decisions:

- ``solvable`` of a maximum-likelihood solution is the chi-square test of its cost
  with max(P - D, 1) degrees of freedom at the request's alpha. With redundancy
  (P > D) it is core's ``consistent``; with P = D, where ``consistent`` has nothing to
  test, it still says whether the position lines meet within the noise (two ellipses
  that do not intersect leave a large cost at their least-squares point).
- The closed forms accept a range sum up to ``BASELINE_SIGMAS`` sigma below its
  baseline, as the maximum-likelihood solve does, so one request never passes one
  method and fails the other on the same data.
- Core promises finite answers. Should a NaN or infinity ever come back, the handler
  fails as a bug (500) rather than letting the response model's validation error pass
  for bad input (422); JSON cannot carry it either way.
- A problem's ``initial`` goes to core as ``x0`` with the closed form's roots as further
  starts (core's default): with a guess the answer never ends at a higher cost than
  without one, and ``alternative`` reports the best other minimum (see the schema).
- The chi-square quantile is core's one threshold function,
  :func:`plotgate.core.gates.thresholds.gate_threshold` of 1 - alpha.

Core errors name core arguments (``l``, ``tx``, ``rx``, ``sigma``, ``x0``, ``t``, ``x``)
with the batch index of the first bad problem or sample; each operation's ``*_FIELDS``
table (:mod:`plotgate.service.fields`) turns them into request paths such as
``problems[3].receivers`` or ``range_sums[7]``.
"""

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

import numpy as np

import plotgate.core.multistatic as ms
from plotgate.core import PlotgateError
from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.multistatic.model import BASELINE_SIGMAS
from plotgate.service.fields import FieldMap
from plotgate.service.operations.answers import checked
from plotgate.service.schemas import (
    AccumulatedBound,
    ClosedFormResult,
    CrlbRequest,
    CrlbResult,
    FittedState,
    NoiseRequest,
    NoiseResult,
    Platform,
    PositionSolution,
    PositionSolveRequest,
    PositionSolveResult,
    SingleShotBound,
    TrajectorySolveRequest,
    TrajectorySolveResult,
)

__all__ = [
    "CRLB_FIELDS",
    "NOISE_FIELDS",
    "POSITION_FIELDS",
    "TRAJECTORY_FIELDS",
    "crlb",
    "noise",
    "platform_array",
    "position",
    "sample_errors",
    "trajectory",
]


_CLOSED_FORMS = {"sum_range": ms.sum_range_solve, "difference_range": ms.difference_range_solve}

T = TypeVar("T")

_PER_PROBLEM = {"l", "tx", "rx", "sigma", "x0"}
"""Core arguments that belong to one problem (or one sample) of a batch."""


def _per_pair(many: list[T] | None, one: T | None, n: int) -> list[T]:
    """A per-pair field of the wire: ``many`` as sent, or ``one`` repeated for the n pairs.

    The schema sends exactly one of the two (``transmitter`` or ``transmitters``,
    ``sigma`` or ``sigmas``), and ``many`` never empty.
    """
    if many:
        return many
    assert one is not None  # the schema sends exactly one of the two
    return [one] * n


@contextmanager
def _rows(rows: Sequence[int]) -> Iterator[None]:
    """Re-raise a core error of a grouped batch with the request's own problem index.

    A per-problem error without an index (e.g. too few pairs, which a whole group of
    equal P shares) concerns every problem of the group: the first is named.
    """
    try:
        yield
    except PlotgateError as exc:
        if exc.field not in _PER_PROBLEM:
            raise
        index = rows[0] if exc.index is None else rows[exc.index]
        raise type(exc)(exc.field, exc.reason, index) from exc


@contextmanager
def sample_errors(t: np.ndarray | None, moving: bool) -> Iterator[None]:
    """Say at which sample a platform error occurred when the platforms move.

    The field of a platform error (core's ``tx`` or ``rx`` with a sample index) names
    the platform list, not the sample, so the sample number and its time t[index] go
    into the reason of the re-raised error.
    """
    try:
        yield
    except PlotgateError as exc:
        if exc.field in ("tx", "rx") and exc.index is not None and moving:
            when = f"at sample {exc.index}"
            if t is not None:
                when += f" (t = {float(t[exc.index])} s)"
            raise type(exc)(exc.field, f"{when}: {exc.reason}", exc.index) from exc
        raise


# --------------------------------------------------------------------------- solves.position


@checked
def position(request: PositionSolveRequest) -> PositionSolveResult:
    """Maximum-likelihood positions (Fadeev et al., eq. 4, 6), and a closed form on request."""
    problems = request.problems
    d = len(problems[0].receivers[0])
    groups: dict[tuple[int, bool], list[int]] = {}
    for i, p in enumerate(problems):
        groups.setdefault((len(p.range_sums), p.initial is not None), []).append(i)
    solutions: list[PositionSolution | None] = [None] * len(problems)
    for (n_pairs, guessed), rows in groups.items():
        group = [problems[i] for i in rows]
        ls = np.array([p.range_sums for p in group], dtype=float)
        tx = np.array(
            [_per_pair(p.transmitters, p.transmitter, n_pairs) for p in group], dtype=float
        )
        rx = np.array([p.receivers for p in group], dtype=float)
        sigma = np.array([_per_pair(p.sigmas, p.sigma, n_pairs) for p in group], dtype=float)
        x0 = np.array([p.initial for p in group], dtype=float) if guessed else None
        with _rows(rows):
            ml = ms.ml_solve(
                ls, tx, rx, sigma, x0=x0, alpha=request.alpha, max_iter=request.max_iter
            )
            closed = None
            if request.method != "ml":
                solve = _CLOSED_FORMS[request.method]
                closed = solve(ls, tx, rx, baseline_tol=BASELINE_SIGMAS * sigma)
        solvable = ml.cost <= gate_threshold(1.0 - request.alpha, max(n_pairs - d, 1))
        _require_finite(
            ml.x, ml.covariance, ml.residuals, ml.cost, ml.normalized_cost, ml.alternative
        )
        out = _columns(
            ml.x,
            ml.covariance,
            ml.residuals,
            ml.cost,
            ml.normalized_cost,
            ml.consistent,
            solvable,
            ml.iterations,
            ml.converged,
            ml.alternative,
            ml.has_alternative,
        )
        forms = _closed_forms(request.method, closed) if closed is not None else None
        for j, i in enumerate(rows):
            (x, cov, res, cost, norm, consistent, ok, iterations, converged, alt, has_alt) = (
                column[j] for column in out
            )
            # checked above, so built without a second validation (10^4 problems)
            solutions[i] = PositionSolution.model_construct(
                position=x,
                covariance=cov,
                residuals=res,
                cost=cost,
                normalized_cost=norm,
                consistent=consistent,
                solvable=ok,
                iterations=iterations,
                converged=converged,
                alternative=alt if has_alt else None,
                closed_form=None if forms is None else forms[j],
            )
    done = [s for s in solutions if s is not None]
    return PositionSolveResult.model_construct(
        method=request.method,
        dimensions=d,
        solutions=done,
        count_solvable=sum(s.solvable for s in done),
    )


def _columns(*arrays: np.ndarray) -> list[list[Any]]:
    """Each array as a Python list (one entry per problem)."""
    return [np.asarray(a).tolist() for a in arrays]


def _require_finite(*arrays: np.ndarray) -> None:
    """Core promises finite answers; a NaN or infinity here is a bug (a 500), not bad input.

    (Left to the response model, it would fail validation and be mistaken for a 422.)
    """
    for a in arrays:
        if not np.isfinite(a).all():
            raise RuntimeError("core returned a non-finite solution; this is a bug")


def _closed_forms(method: str, sol: Any) -> list[ClosedFormResult]:
    _require_finite(sol.x, sol.alternative, sol.residual, sol.alternative_residual)
    x, alt, has_alt, solvable, res, alt_res = _columns(
        sol.x,
        sol.alternative,
        sol.has_alternative,
        sol.solvable,
        sol.residual,
        sol.alternative_residual,
    )
    return [
        ClosedFormResult.model_construct(
            method=method,
            position=x[j],
            solvable=solvable[j],
            residual=res[j],
            alternative=alt[j] if has_alt[j] else None,
            alternative_residual=alt_res[j] if has_alt[j] else None,
        )
        for j in range(len(x))
    ]


POSITION_FIELDS: FieldMap = {
    "l": "problems[{i}].range_sums",
    "tx": "problems[{i}].transmitter|transmitters",
    "rx": "problems[{i}].receivers",
    "sigma": "problems[{i}].sigma|sigmas",
    "x0": "problems[{i}].initial",
    "alpha": "alpha",
    "max_iter": "max_iter",
    "*": "problems",
}
"""Where core's errors on a ``solves.position`` request point: a problem's own field."""


# --------------------------------------------------------------------------- platforms


def platform_array(platform: Platform, t: np.ndarray | None, n: int | None) -> np.ndarray:
    """A wire platform as core's array: (D,) when no platform moves (n None), else (n, D).

    Per-sample ``positions`` are used as given; a ``position`` with a ``velocity`` is
    placed at the times t by :func:`plotgate.core.multistatic.platform_positions`, the
    wire's position being the one at t[0]; a fixed position is repeated n times.
    """
    if platform.positions is not None:
        return np.asarray(platform.positions, dtype=float)
    position = np.asarray(platform.position, dtype=float)
    if n is None:
        return position
    if platform.velocity is None:
        return np.array(np.broadcast_to(position, (n, position.size)))
    assert t is not None  # the schema requires sample times with a velocity
    return ms.platform_positions(position, platform.velocity, t, t0=t[0])


def _platforms(
    request: TrajectorySolveRequest | CrlbRequest, t: np.ndarray | None, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Transmitters and receivers: (P, D) when no platform moves, else (n, P, D).

    ``t`` are the sample times (None without them); a moving platform's ``position``
    is the one at t[0].
    """
    p = len(request.receivers)
    transmitters = _per_pair(request.transmitters, request.transmitter, p)
    samples = n if _moving(request) else None
    tx = np.stack([platform_array(q, t, samples) for q in transmitters], axis=-2)
    rx = np.stack([platform_array(q, t, samples) for q in request.receivers], axis=-2)
    return tx, rx


def _moving(request: TrajectorySolveRequest | CrlbRequest) -> bool:
    """Some platform's position depends on time."""
    return any(
        q.moving
        for q in (request.transmitter, *(request.transmitters or ()), *request.receivers)
        if q is not None
    )


def _sigma(request: TrajectorySolveRequest | CrlbRequest) -> float | np.ndarray:
    if request.sigmas is not None:
        return np.asarray(request.sigmas, dtype=float)
    assert request.sigma is not None  # the schema sends exactly one of sigma and sigmas
    return request.sigma


# --------------------------------------------------------------------------- solves.trajectory


@checked
def trajectory(request: TrajectorySolveRequest) -> TrajectorySolveResult:
    """Constant-velocity track by maximum likelihood over all samples (Fadeev et al.)."""
    t = np.asarray(request.sample_times, dtype=float)
    tx, rx = _platforms(request, t, t.size)
    x0 = None
    if request.initial is not None:
        x0 = np.concatenate([request.initial.position, request.initial.velocity])
    with sample_errors(t, _moving(request)):
        sol = ms.trajectory_solve(
            np.asarray(request.range_sums, dtype=float),
            t,
            tx,
            rx,
            _sigma(request),
            x0=x0,
            alpha=request.alpha,
            max_iter=request.max_iter,
        )
    times = request.sample_times if request.times is None else request.times
    positions, covariances = sol.at(np.asarray(times, dtype=float))
    return TrajectorySolveResult(
        t_ref=sol.t_ref,
        state=FittedState(position=sol.position.tolist(), velocity=sol.velocity.tolist()),
        covariance=sol.covariance.tolist(),
        residuals=sol.residuals.tolist(),
        cost=float(sol.cost),
        normalized_cost=float(sol.normalized_cost),
        consistent=bool(sol.consistent),
        converged=bool(sol.converged),
        iterations=int(sol.iterations),
        times=list(times),
        positions=positions.tolist(),
        covariances=covariances.tolist(),
    )


TRAJECTORY_FIELDS: FieldMap = {
    "l": "range_sums[{i}]",
    "t": "sample_times",
    "x0": "initial",
    "tx": "transmitter|transmitters",
    "rx": "receivers",
    "sigma": "sigma|sigmas",
}
"""Where core's errors on a ``solves.trajectory`` request point: ``range_sums[i]`` (the
sample), ``sample_times``, ``initial``, the platform lists, ``sigma(s)``."""


# --------------------------------------------------------------------------- solves.crlb


@checked
def crlb(request: CrlbRequest) -> CrlbResult:
    """Cramer-Rao bounds (Fadeev et al., eq. 3): single shot per sample, accumulated on a track."""
    t = None if request.sample_times is None else np.asarray(request.sample_times, dtype=float)
    if request.track is not None:
        assert t is not None  # the schema requires sample times with a track
        x = np.asarray(request.track.position) + np.multiply.outer(
            t - t[0], np.asarray(request.track.velocity, dtype=float)
        )
    else:
        x = np.asarray(request.targets, dtype=float)
    tx, rx = _platforms(request, t, len(x))
    sigma = _sigma(request)
    bound = ms.difference_crlb if request.measurements == "difference" else ms.crlb
    with sample_errors(t, _moving(request)):
        single = bound(x, tx, rx, sigma)
        accumulated = None
        if request.track is not None:
            assert t is not None  # as above: a track has sample times
            acc = ms.trajectory_crlb(
                request.track.position,
                request.track.velocity,
                t,
                tx,
                rx,
                sigma,
                measurements=request.measurements,
            )
            accumulated = AccumulatedBound(
                t_ref=acc.t_ref,
                state_covariance=acc.covariance.tolist(),
                state_sigma=acc.sigma.tolist(),
                sigma=acc.position_sigma.tolist(),
                gdop=acc.gdop.tolist(),
                covariance=acc.position_covariance.tolist(),
                sigma_ref=acc.sigma_ref,
            )
    return CrlbResult(
        measurements=request.measurements,
        positions=x.tolist(),
        single_shot=SingleShotBound(
            sigma=single.sigma.tolist(),
            gdop=single.gdop.tolist(),
            covariance=single.covariance.tolist(),
            sigma_ref=single.sigma_ref.tolist(),
        ),
        accumulated=accumulated,
    )


def _crlb_target(request: CrlbRequest, exc: PlotgateError) -> str:
    """A target position error: ``track`` for a track (any sample), else ``targets[i]``."""
    if request.track is not None:
        return "track"
    return "targets" if exc.index is None else f"targets[{exc.index}]"


CRLB_FIELDS: FieldMap = {
    "x": _crlb_target,
    "x0": "track.position",
    "v": "track.velocity",
    "t": "sample_times",
    "l": "receivers",
    "tx": "transmitter|transmitters",
    "rx": "receivers",
    "sigma": "sigma|sigmas",
}
"""Where core's errors on a ``solves.crlb`` request point: ``targets[i]`` or ``track``
(which of the two a request holds is no template, hence the function), the platform
lists, ``sigma(s)``, ``sample_times``; too few pairs (core's ``l``) at ``receivers``."""


# --------------------------------------------------------------------------- solves.noise


@checked
def noise(request: NoiseRequest) -> NoiseResult:
    """Noise of each range-sum series (Fadeev et al., eq. 5) and smoothed coordinates."""
    t = np.asarray(request.sample_times, dtype=float)
    out: dict[str, Any] = {}
    if request.range_sums is not None:
        est = ms.range_sum_noise(t, np.asarray(request.range_sums, dtype=float), request.degree)
        out.update(
            sigma=est.sigma.tolist(),
            variance=est.variance.tolist(),
            dof=est.dof,
            smoothed_range_sums=est.smoothed.tolist(),
        )
    if request.positions is not None:
        assert request.window is not None  # the schema requires it with positions
        smoothed = ms.smooth_positions(
            t, np.asarray(request.positions, dtype=float), request.window, request.smoothing_degree
        )
        out["smoothed_positions"] = smoothed.tolist()
    return NoiseResult(**out)


NOISE_FIELDS: FieldMap = {
    "t": "sample_times[{i}]",
    "l": "range_sums",
    "x": "positions",
}
"""Where core's errors on a ``solves.noise`` request point: ``sample_times[i]``,
``range_sums``, ``positions``; ``window`` and the degrees by their own names."""
