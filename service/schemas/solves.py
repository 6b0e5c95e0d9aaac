"""Wire models of the multistatic position solves (seed 001; DESIGN section 6).

A transmitter and a receiver form a *pair*; a pair measures the range sum
``l = |x - rx| + |x - tx|`` (m) of a target at ``x``, with Gaussian noise of standard
deviation ``sigma``. Positions are arrays ``[x, y]`` (2D, x east, y north) or
``[x, y, z]`` (3D), metres; every position and velocity of one request has the same
length. No angles are involved.

Operations:

- ``solves.position``: a batch of independent single-shot problems, each solved by
  maximum likelihood (weighted Gauss-Newton, seed 001 eq. 6), optionally with the
  sum-range or difference-range closed form alongside (``method``);
- ``solves.trajectory``: one constant-velocity target fitted to range sums at several
  sample times, the state (x0, v) and positions with covariances at requested times;
- ``solves.crlb``: the Cramer-Rao bound (seed 001 eq. 3), single shot for target
  positions or accumulated along a track, for the range-sum or the range-difference
  measurement set;
- ``solves.noise``: range-sum noise from a quadratic fit of each series (eq. 5), and
  sliding-window polynomial smoothing of solved coordinates.

Platforms of the trajectory, CRLB and noise operations are :class:`Platform` objects:
a fixed ``position``, a ``position`` plus a constant ``velocity`` (the position is that
at the first sample time), or one position per sample (``positions``). One transmitter
for every pair is given as ``transmitter``; one per pair as ``transmitters``. One sigma
for every measurement is ``sigma``; one per pair (per measurement) is ``sigmas``.

Rules over several fields (exactly one of two alternatives, matching lengths, one
dimension per request, the size limits) are model validators that answer 422 naming
the offending field. The mathematics (fewer measurements than unknowns, coincident
platforms, a range sum shorter than its baseline) is checked by core and mapped to the
field by :mod:`plotgate.service.operations.solves`.
"""

from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from plotgate.service.schemas.common import MAX_DISTANCE, Loc, Schema, invalid

__all__ = [
    "MAX_MEASUREMENTS",
    "MAX_PROBLEMS",
    "MAX_RANGE_SUMS",
    "MAX_SAMPLES",
    "AccumulatedBound",
    "ClosedFormResult",
    "CrlbRequest",
    "CrlbResult",
    "FittedState",
    "NoiseRequest",
    "NoiseResult",
    "Platform",
    "PositionProblem",
    "PositionSolution",
    "PositionSolveRequest",
    "PositionSolveResult",
    "SingleShotBound",
    "TargetState",
    "TrajectorySolveRequest",
    "TrajectorySolveResult",
]

MAX_PROBLEMS = 10_000
"""Most problems of one ``solves.position`` request, or targets of one ``solves.crlb``."""
MAX_SAMPLES = 10_000
"""Most sample times of one trajectory, CRLB track or noise series; also most requested
``times`` of a trajectory solve."""
MAX_MEASUREMENTS = 64
"""Most (transmitter, receiver) pairs of one problem or one sample."""
MAX_RANGE_SUMS = 100_000
"""Most range sums in one request (problems x pairs, or samples x pairs)."""
MAX_RANGE_SUM = 1e10
"""Largest range sum, m (two distances across the 10^9 m coordinate box)."""
MAX_TIME = 1e10
"""Largest |time|, s (any epoch: Unix seconds fit)."""
MAX_SPEED = 1e6
"""Largest |velocity component|, m/s."""
MIN_SIGMA = 1e-6
"""Smallest range-sum sigma, m (1 um; keeps 1/sigma^2 well inside double precision)."""
MAX_DEGREE = 10
"""Largest polynomial degree of a fit."""

Coordinate = Annotated[float, Field(ge=-MAX_DISTANCE, le=MAX_DISTANCE)]
Point = Annotated[
    list[Coordinate],
    Field(
        min_length=2,
        max_length=3,
        description="Position [x, y] (2D) or [x, y, z] (3D), m; |coordinate| <= 1e9.",
    ),
]
VelocityVector = Annotated[
    list[Annotated[float, Field(ge=-MAX_SPEED, le=MAX_SPEED)]],
    Field(
        min_length=2,
        max_length=3,
        description="Velocity [vx, vy] or [vx, vy, vz], m/s; |component| <= 1e6.",
    ),
]
RangeSum = Annotated[
    float,
    Field(
        ge=0,
        le=MAX_RANGE_SUM,
        description="Range sum |x - rx| + |x - tx|, m; finite, 0 <= l <= 1e10.",
    ),
]
Sigma = Annotated[
    float,
    Field(
        ge=MIN_SIGMA,
        le=MAX_DISTANCE,
        description="Range-sum noise standard deviation, m; 1e-6 <= sigma <= 1e9.",
    ),
]
Row = Annotated[
    list[RangeSum],
    Field(
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="The range sums of one sample, m, one per pair.",
    ),
]
Time = Annotated[
    float, Field(ge=-MAX_TIME, le=MAX_TIME, description="Time, s (any epoch); |t| <= 1e10.")
]
Alpha = Annotated[
    float,
    Field(
        ge=1e-12,
        le=0.5,
        description="False-alarm probability of the chi-square residual test, in [1e-12, 0.5].",
    ),
]
MaxIter = Annotated[
    int, Field(ge=1, le=1000, description="Largest number of Gauss-Newton iterations.")
]


def _one_of(obj: Any, a: str, b: str, what: str) -> list[tuple[Loc, str, Any]]:
    """Errors unless exactly one of the fields ``a`` and ``b`` is given."""
    if (getattr(obj, a) is None) == (getattr(obj, b) is None):
        reason = f"give exactly one of {a} and {b} ({what})"
        return [((a,), reason, getattr(obj, a)), ((b,), reason, getattr(obj, b))]
    return []


def _length(loc: Loc, value: Sequence[Any] | None, n: int, of: str) -> list[tuple[Loc, str, Any]]:
    """An error unless ``value`` (when given) has ``n`` entries, one per ``of``."""
    if value is not None and len(value) != n:
        return [(loc, f"must have {n} entries, one per {of}; got {len(value)}", len(value))]
    return []


def _dimension(
    sizes: Iterable[set[int]], points: Callable[[], Iterator[tuple[Loc, Sequence[float]]]]
) -> list[tuple[Loc, str, Any]]:
    """An error at the first vector whose length differs from most vectors' length.

    ``sizes`` are the vector lengths found in each part of the request (a cheap pass);
    only when they differ are the vectors walked with their locations (``points``). The
    request's dimension is that of most of its positions and velocities (of the first
    one on a tie), so the odd one out is the field named.
    """
    if len(set().union(*sizes)) < 2:
        return []
    vectors = list(points())
    lengths = [len(v) for _, v in vectors]
    d = max(dict.fromkeys(lengths), key=lengths.count)
    example = next(loc for loc, v in vectors if len(v) == d)
    loc, point = next((loc, v) for loc, v in vectors if len(v) != d)
    return [
        (
            loc,
            f"has {len(point)} coordinates, but the request is {d}D (as "
            f"{_dotted(example)}): every position and velocity of a request must be 2D, "
            f"or every one 3D",
            list(point),
        )
    ]


def _dotted(loc: Loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _raise(model: Any, errors: list[tuple[Loc, str, Any]]) -> None:
    if errors:
        raise invalid(type(model).__name__, errors)


# --------------------------------------------------------------------------- platforms


class Platform(Schema):
    """A transmitter or receiver: fixed, moving at constant velocity, or given per sample.

    Give ``position`` (with an optional ``velocity``: the platform is at ``position`` at
    the first sample time and moves in a straight line), or ``positions`` (one per
    sample; in a ``solves.crlb`` request for targets, one per target). A velocity needs
    sample times.
    """

    position: Point | None = Field(
        default=None,
        description="Position at the first sample time (or always, with no velocity), m.",
    )
    velocity: VelocityVector | None = Field(
        default=None,
        description="Constant velocity, m/s; only with position. Null: a fixed platform.",
    )
    positions: list[Point] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Position at each sample, m, one per sample; instead of position.",
    )

    @model_validator(mode="after")
    def _rules(self) -> "Platform":
        errors = _one_of(
            self,
            "position",
            "positions",
            "a platform is fixed or moving from position, or given per sample by positions",
        )
        if self.velocity is not None and self.positions is not None:
            errors.append(
                (
                    ("velocity",),
                    "must be absent with positions (the platform is given per sample)",
                    self.velocity,
                )
            )
        _raise(self, errors)
        return self

    @property
    def moving(self) -> bool:
        """The platform's position depends on time (a velocity or per-sample positions)."""
        return self.velocity is not None or self.positions is not None

    def sizes(self) -> set[int]:
        """The lengths of the platform's positions and velocity."""
        vectors = [self.position, self.velocity, *(self.positions or ())]
        return {len(v) for v in vectors if v is not None}

    def vectors(self, loc: Loc) -> Iterator[tuple[Loc, Sequence[float]]]:
        """Every position and velocity in the platform, with its location."""
        if self.position is not None:
            yield (*loc, "position"), self.position
        if self.velocity is not None:
            yield (*loc, "velocity"), self.velocity
        for i, p in enumerate(self.positions or ()):
            yield (*loc, "positions", i), p


class TargetState(Schema):
    """A constant-velocity target: position at the reference time and velocity."""

    position: Point = Field(description="Position at the reference time, m.")
    velocity: VelocityVector = Field(description="Velocity, m/s.")


class FittedState(Schema):
    """A fitted constant-velocity state, as found: a fit to inconsistent range sums may lie
    outside the bounds a request's :class:`TargetState` keeps (it is still finite)."""

    position: list[float] = Field(description="Position at the reference time, m.")
    velocity: list[float] = Field(description="Velocity, m/s.")


def _platform_rules(
    request: Any, n_pairs: int, n_samples: int | None, samples: str, timed: bool = True
) -> list[tuple[Loc, str, Any]]:
    """Pair counts and per-sample position counts of a request's transmitter(s), receivers.

    ``n_samples`` is the number of samples (None when unknown: the request is refused
    for another reason) and ``samples`` says what they are, for messages; without
    sample times (``timed`` False) no platform may have a velocity.
    """
    errors = _one_of(
        request, "transmitter", "transmitters", "one transmitter for every pair, or one per pair"
    )
    errors += _length(("transmitters",), request.transmitters, n_pairs, "pair")
    platforms: list[tuple[Loc, Platform]] = [
        (("receivers", k), p) for k, p in enumerate(request.receivers)
    ]
    if request.transmitter is not None:
        platforms.insert(0, (("transmitter",), request.transmitter))
    platforms[:0] = [(("transmitters", k), p) for k, p in enumerate(request.transmitters or ())]
    for loc, platform in platforms:
        if platform.velocity is not None and not timed:
            errors.append(
                ((*loc, "velocity"), "a moving platform needs sample_times", platform.velocity)
            )
        if platform.positions is not None and n_samples is not None:
            errors += _length((*loc, "positions"), platform.positions, n_samples, samples)
    return errors


def _platform_sizes(request: Any) -> Iterator[set[int]]:
    for platform in (request.transmitter, *(request.transmitters or ()), *request.receivers):
        if platform is not None:
            yield platform.sizes()


def _platform_vectors(request: Any) -> Iterator[tuple[Loc, Sequence[float]]]:
    if request.transmitter is not None:
        yield from request.transmitter.vectors(("transmitter",))
    for k, p in enumerate(request.transmitters or ()):
        yield from p.vectors(("transmitters", k))
    for k, p in enumerate(request.receivers):
        yield from p.vectors(("receivers", k))


# --------------------------------------------------------------------------- solves.position


class PositionProblem(Schema):
    """One single-shot problem: P range sums, each with its transmitter and receiver.

    At least as many pairs as the position has coordinates (2 in 2D, 3 in 3D); core
    answers 422 otherwise. The difference-range method needs one pair more.
    """

    range_sums: list[RangeSum] = Field(
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Measured range sums l_p = |x - rx_p| + |x - tx_p|, m, one per pair.",
    )
    transmitter: Point | None = Field(
        default=None, description="The one transmitter of every pair, m."
    )
    transmitters: list[Point] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Transmitter of each pair, m, one per range sum (several transmitters).",
    )
    receivers: list[Point] = Field(
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Receiver of each pair, m, one per range sum.",
    )
    sigma: Sigma | None = Field(
        default=None, description="One noise standard deviation for every range sum, m."
    )
    sigmas: list[Sigma] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Noise standard deviation of each range sum, m, one per range sum.",
    )
    initial: Point | None = Field(
        default=None,
        description="Initial guess of the position, m: a start besides the sum-range "
        "closed form's roots (not instead of them); the lowest cost wins, this guess's "
        "minimum on a tie (so with two exact solutions it picks one). A guess that "
        "ends in a false minimum (e.g. at the transmitter near a baseline crossing) "
        "loses to the closed form's answer. Null: the closed form's roots only.",
    )

    @model_validator(mode="after")
    def _rules(self) -> "PositionProblem":
        p = len(self.range_sums)
        errors = _one_of(
            self,
            "transmitter",
            "transmitters",
            "one transmitter for every pair, or one per range sum",
        )
        errors += _one_of(self, "sigma", "sigmas", "one sigma, or one per range sum")
        errors += _length(("receivers",), self.receivers, p, "range sum")
        errors += _length(("transmitters",), self.transmitters, p, "range sum")
        errors += _length(("sigmas",), self.sigmas, p, "range sum")
        _raise(self, errors)
        return self

    def sizes(self) -> set[int]:
        """The lengths of the problem's positions."""
        vectors = [self.transmitter, self.initial, *(self.transmitters or ()), *self.receivers]
        return {len(v) for v in vectors if v is not None}

    def vectors(self, loc: Loc) -> Iterator[tuple[Loc, Sequence[float]]]:
        """Every position in the problem, with its location."""
        if self.transmitter is not None:
            yield (*loc, "transmitter"), self.transmitter
        for k, p in enumerate(self.transmitters or ()):
            yield (*loc, "transmitters", k), p
        for k, p in enumerate(self.receivers):
            yield (*loc, "receivers", k), p
        if self.initial is not None:
            yield (*loc, "initial"), self.initial


class PositionSolveRequest(Schema):
    """A batch of independent single-shot position problems (seed 001, eq. 4 and 6).

    Every problem is solved by maximum likelihood. ``method`` = ``sum_range`` or
    ``difference_range`` also gives that closed-form solution of each problem (those
    need every pair of a problem to share one transmitter; difference_range also needs
    P >= D + 1 pairs).
    """

    problems: list[PositionProblem] = Field(
        min_length=1,
        max_length=MAX_PROBLEMS,
        description=f"The problems, solved independently; at most {MAX_PROBLEMS}, with at "
        f"most {MAX_RANGE_SUMS} range sums in all.",
    )
    method: Literal["ml", "sum_range", "difference_range"] = Field(
        default="ml",
        description="ml: maximum likelihood only. sum_range / difference_range: also the "
        "closed-form solution of that method (seed 001 Fig. 3 curves 5 / 6) in closed_form.",
    )
    alpha: Alpha = 0.01
    max_iter: MaxIter = 50

    @model_validator(mode="after")
    def _rules(self) -> "PositionSolveRequest":
        total = sum(len(p.range_sums) for p in self.problems)
        errors: list[tuple[Loc, str, Any]] = []
        if total > MAX_RANGE_SUMS:
            errors.append(
                (
                    ("problems",),
                    f"carry {total} range sums in all; at most {MAX_RANGE_SUMS} per request",
                    total,
                )
            )
        errors += _dimension(
            (p.sizes() for p in self.problems),
            lambda: (v for i, p in enumerate(self.problems) for v in p.vectors(("problems", i))),
        )
        _raise(self, errors)
        return self


class ClosedFormResult(Schema):
    """The closed-form solution of one problem (sum-range or difference-range method)."""

    method: Literal["sum_range", "difference_range"] = Field(description="The method.")
    position: list[float] = Field(
        description="Chosen root, m; where solvable is false only a finite best-effort "
        "point (the vertex of the quadratic), not a solution."
    )
    solvable: bool = Field(
        description="A real root consistent with the measurements exists (the position "
        "lines meet) and the geometry has full rank."
    )
    residual: float = Field(description="Range-sum residual norm |l - h(position)|, m.")
    alternative: list[float] | None = Field(
        default=None, description="The other consistent root, m, when there is one."
    )
    alternative_residual: float | None = Field(
        default=None, description="Its range-sum residual norm, m."
    )


class PositionSolution(Schema):
    """The maximum-likelihood solution of one problem (index i answers problems[i])."""

    position: list[float] = Field(description="Estimated position, m.")
    covariance: list[list[float]] = Field(
        description="Its covariance (H^T G H)^-1, m^2 (D x D); huge but finite in an "
        "unobservable direction."
    )
    residuals: list[float] = Field(description="l - h(position) per range sum, m.")
    cost: float = Field(description="Chi-square cost sum (r_p / sigma_p)^2.")
    normalized_cost: float = Field(description="cost / (P - D) (cost itself when P = D).")
    consistent: bool = Field(
        description="cost <= chi2.ppf(1 - alpha, P - D): the residual test finds no false "
        "minimum; always true when P = D (nothing to test)."
    )
    solvable: bool = Field(
        description="A position fits the range sums within the noise: cost <= "
        "chi2.ppf(1 - alpha, max(P - D, 1)). False: the geometry has no real solution "
        "(e.g. two ellipses that do not meet) and position is only the least-squares point."
    )
    iterations: int = Field(description="Gauss-Newton iterations taken.")
    converged: bool = Field(description="The iteration met its convergence test.")
    alternative: list[float] | None = Field(
        default=None,
        description="Another distinct local minimum (more than one standard deviation "
        "from position) that also converged and passes the residual test, m; null when "
        "none. Without initial: from the closed form's second root (e.g. the second "
        "ellipse intersection). With initial: the lowest-cost other start's minimum, "
        "the guess's own when a closed-form root fit better, or a root's (e.g. the "
        "other intersection when the guess picked one); a guess trapped in a minimum "
        "that fails the residual test is never offered.",
    )
    closed_form: ClosedFormResult | None = Field(
        default=None, description="The closed-form solution, when method asks for it."
    )


class PositionSolveResult(Schema):
    """Solutions of a position batch, index i answering problems[i]."""

    method: Literal["ml", "sum_range", "difference_range"] = Field(
        description="The method requested."
    )
    dimensions: Literal[2, 3] = Field(description="2 or 3: the length of every position.")
    solutions: list[PositionSolution] = Field(description="One solution per problem.")
    count_solvable: int = Field(description="How many problems are solvable.")


# --------------------------------------------------------------------------- solves.trajectory


class TrajectorySolveRequest(Schema):
    """One constant-velocity target observed through P pairs at T sample times (seed 001).

    The state is (x0, v) with x(t) = x0 + v (t - t_ref), t_ref = sample_times[0]; it is
    fitted by maximum likelihood to all T x P range sums (eq. 2, 4, 6).
    """

    sample_times: list[Time] = Field(
        min_length=2,
        max_length=MAX_SAMPLES,
        description="Time of each sample, s (any epoch); at least two distinct times.",
    )
    range_sums: list[Row] = Field(
        min_length=2,
        max_length=MAX_SAMPLES,
        description="Range sums, m: one row per sample, one column per pair (T x P).",
    )
    transmitter: Platform | None = Field(
        default=None, description="The one transmitter of every pair."
    )
    transmitters: list[Platform] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Transmitter of each pair (several transmitters), one per column.",
    )
    receivers: list[Platform] = Field(
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Receiver of each pair, one per column of range_sums.",
    )
    sigma: Sigma | None = Field(
        default=None, description="One noise standard deviation for every range sum, m."
    )
    sigmas: list[Sigma] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Noise standard deviation of each pair's range sums, m, one per pair.",
    )
    initial: TargetState | None = Field(
        default=None,
        description="Initial guess of the state at sample_times[0]. Null: a line fitted to "
        "the single-shot solutions.",
    )
    times: list[Time] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Times at which to report the position and its covariance, s. Null: "
        "the sample times.",
    )
    alpha: Alpha = 0.01
    max_iter: MaxIter = 50

    @model_validator(mode="after")
    def _rules(self) -> "TrajectorySolveRequest":
        t = len(self.sample_times)
        p = len(self.receivers)
        errors = _length(("range_sums",), self.range_sums, t, "sample time")
        errors += [
            (
                ("range_sums", i),
                f"must have {p} entries, one per receiver; got {len(row)}",
                len(row),
            )
            for i, row in enumerate(self.range_sums)
            if len(row) != p
        ][:1]
        if t * p > MAX_RANGE_SUMS:
            errors.append(
                (
                    ("range_sums",),
                    f"carry {t * p} range sums; at most {MAX_RANGE_SUMS} per request",
                    t * p,
                )
            )
        errors += _platform_rules(self, p, t, "sample time")
        errors += _one_of(self, "sigma", "sigmas", "one sigma, or one per pair")
        errors += _length(("sigmas",), self.sigmas, p, "pair")
        if not errors:
            own = []
            if self.initial is not None:
                own = [
                    (("initial", "position"), self.initial.position),
                    (("initial", "velocity"), self.initial.velocity),
                ]
            errors += _dimension(
                [*_platform_sizes(self), {len(v) for _, v in own}],
                lambda: iter([*_platform_vectors(self), *own]),
            )
        _raise(self, errors)
        return self


class TrajectorySolveResult(Schema):
    """The fitted track and the position (with covariance) at the requested times."""

    t_ref: float = Field(description="Reference time of the state: sample_times[0], s.")
    state: FittedState = Field(description="Position at t_ref (m) and velocity (m/s).")
    covariance: list[list[float]] = Field(
        description="Covariance of (x0, v), 2D x 2D: m^2, m^2/s and m^2/s^2 blocks."
    )
    residuals: list[list[float]] = Field(description="l - h(x(t)) per sample and pair, m.")
    cost: float = Field(description="Chi-square cost over all T x P range sums.")
    normalized_cost: float = Field(description="cost / (T P - 2D).")
    consistent: bool = Field(
        description="cost <= chi2.ppf(1 - alpha, T P - 2D): the track fits the data."
    )
    converged: bool = Field(description="The iteration met its convergence test.")
    iterations: int = Field(description="Gauss-Newton iterations taken.")
    times: list[float] = Field(description="The requested times (or the sample times), s.")
    positions: list[list[float]] = Field(description="x0 + v (t - t_ref) at each time, m.")
    covariances: list[list[list[float]]] = Field(
        description="Covariance of each position, m^2 (D x D)."
    )


# --------------------------------------------------------------------------- solves.crlb


class CrlbRequest(Schema):
    """Cramer-Rao bound of the position error (seed 001, eq. 3).

    Single shot for given ``targets`` (sample i is target i: per-sample platform
    positions give one position per target, and moving platforms are taken at
    ``sample_times[i]``), or along a constant-velocity ``track`` observed at
    ``sample_times``: the single-shot bound at each sample and the bound accumulated
    over all samples (Fig. 3 curves 1 and 2), for either measurement set.
    """

    measurements: Literal["sum", "difference"] = Field(
        default="sum",
        description="sum: the P range sums. difference: the P - 1 differences l_k - l_1 "
        "(transmitter cancels, correlated noise); needs P >= D + 1.",
    )
    targets: list[Point] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_PROBLEMS,
        description="True target positions, m: single-shot bounds, one per target.",
    )
    track: TargetState | None = Field(
        default=None,
        description="A constant-velocity target (position at sample_times[0]): the bound "
        "at each sample and accumulated over the track.",
    )
    sample_times: list[Time] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Sample times, s: required with track or moving platforms; with "
        "targets one per target.",
    )
    transmitter: Platform | None = Field(
        default=None, description="The one transmitter of every pair."
    )
    transmitters: list[Platform] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Transmitter of each pair (several transmitters).",
    )
    receivers: list[Platform] = Field(
        min_length=1, max_length=MAX_MEASUREMENTS, description="Receiver of each pair."
    )
    sigma: Sigma | None = Field(
        default=None, description="One noise standard deviation for every range sum, m."
    )
    sigmas: list[Sigma] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_MEASUREMENTS,
        description="Noise standard deviation of each pair's range sum, m, one per pair.",
    )

    @model_validator(mode="after")
    def _rules(self) -> "CrlbRequest":
        p = len(self.receivers)
        errors = _one_of(self, "targets", "track", "single-shot targets, or a track")
        n = None
        if self.track is not None:
            if self.sample_times is None:
                errors.append((("sample_times",), "is required with track", None))
            n = None if self.sample_times is None else len(self.sample_times)
        elif self.targets is not None:
            errors += _length(("sample_times",), self.sample_times, len(self.targets), "target")
            n = len(self.targets)
        if n is not None and n * p > MAX_RANGE_SUMS:
            errors.append(
                (
                    ("receivers",),
                    f"{n} samples x {p} pairs is {n * p} range "
                    f"sums; at most {MAX_RANGE_SUMS} per request",
                    n * p,
                )
            )
        errors += _platform_rules(self, p, n, "sample", timed=self.sample_times is not None)
        errors += _one_of(self, "sigma", "sigmas", "one sigma, or one per pair")
        errors += _length(("sigmas",), self.sigmas, p, "pair")
        if not errors:
            own = [(("targets", i), x) for i, x in enumerate(self.targets or ())]
            if self.track is not None:
                own += [
                    (("track", "position"), self.track.position),
                    (("track", "velocity"), self.track.velocity),
                ]
            errors += _dimension(
                [{len(v) for _, v in own}, *_platform_sizes(self)],
                lambda: iter([*own, *_platform_vectors(self)]),
            )
        _raise(self, errors)
        return self


class SingleShotBound(Schema):
    """Single-shot bounds, index i answering sample (target) i."""

    sigma: list[list[float]] = Field(
        description="Standard-deviation bound per axis sqrt(diag J^-1), m (N x D)."
    )
    gdop: list[float] = Field(
        description="sqrt(trace J^-1) / sigma_ref: the geometry factor, dimensionless."
    )
    covariance: list[list[list[float]]] = Field(description="The bound J^-1, m^2 (D x D).")
    sigma_ref: list[float] = Field(
        description="Reference sigma of the GDOP, (mean_p 1/sigma_p^2)^(-1/2), m."
    )


class AccumulatedBound(Schema):
    """The bound accumulated over all samples of a track (range-sum set)."""

    t_ref: float = Field(description="Reference time of the state: sample_times[0], s.")
    state_covariance: list[list[float]] = Field(
        description="Bound on (x0, v), 2D x 2D: m^2, m^2/s, m^2/s^2 blocks."
    )
    state_sigma: list[float] = Field(description="sqrt of its diagonal: m for x0, m/s for v.")
    sigma: list[list[float]] = Field(
        description="Per-axis bound on the position at each sample time, m (T x D)."
    )
    gdop: list[float] = Field(description="sqrt(trace) / sigma_ref at each sample.")
    covariance: list[list[list[float]]] = Field(
        description="Bound on the position at each sample time, m^2 (D x D)."
    )
    sigma_ref: float = Field(description="(mean over all T P range sums of 1/sigma^2)^(-1/2), m.")


class CrlbResult(Schema):
    """Cramer-Rao bounds: single shot at every sample, and accumulated along a track."""

    measurements: Literal["sum", "difference"] = Field(description="The measurement set.")
    positions: list[list[float]] = Field(
        description="Target position of each sample (the targets, or the track's), m."
    )
    single_shot: SingleShotBound = Field(description="Single-shot bound at every sample.")
    accumulated: AccumulatedBound | None = Field(
        default=None, description="Track only: the bound accumulated over the samples."
    )


# --------------------------------------------------------------------------- solves.noise


class NoiseRequest(Schema):
    """Range-sum noise from polynomial fits (seed 001, eq. 5) and coordinate smoothing.

    Give ``range_sums`` (noise estimate), ``positions`` (smoothing), or both.
    """

    sample_times: list[Time] = Field(
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Time of each sample, s; strictly increasing.",
    )
    range_sums: list[Row] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Range-sum series, m: one row per sample, one column per pair (T x P).",
    )
    degree: int = Field(
        default=2,
        ge=0,
        le=MAX_DEGREE,
        description="Degree of the polynomial fitted to each range-sum series (2: the "
        "quadratic of eq. 5); needs T >= degree + 2.",
    )
    positions: list[Point] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_SAMPLES,
        description="Solved coordinates to smooth, m, one per sample.",
    )
    window: int | None = Field(
        default=None,
        ge=1,
        le=MAX_SAMPLES,
        description="Samples per smoothing window, smoothing_degree + 1 <= window <= T; "
        "required with positions.",
    )
    smoothing_degree: int = Field(
        default=2,
        ge=0,
        le=MAX_DEGREE,
        description="Degree of the sliding-window polynomial.",
    )

    @model_validator(mode="after")
    def _rules(self) -> "NoiseRequest":
        t = len(self.sample_times)
        errors: list[tuple[Loc, str, Any]] = []
        if self.range_sums is None and self.positions is None:
            reason = "give range_sums, positions or both"
            errors += [(("range_sums",), reason, None), (("positions",), reason, None)]
        if self.range_sums is not None:
            errors += _length(("range_sums",), self.range_sums, t, "sample time")
            width = len(self.range_sums[0])
            errors += [
                (
                    ("range_sums", i),
                    f"must have {width} entries, as range_sums[0]; got {len(row)}",
                    len(row),
                )
                for i, row in enumerate(self.range_sums)
                if len(row) != width
            ][:1]
            if t * width > MAX_RANGE_SUMS:
                errors.append(
                    (
                        ("range_sums",),
                        f"carry {t * width} range sums; at most {MAX_RANGE_SUMS} per request",
                        t * width,
                    )
                )
        if self.positions is not None:
            errors += _length(("positions",), self.positions, t, "sample time")
            positions = self.positions
            errors += _dimension(
                [{len(x) for x in positions}],
                lambda: ((("positions", i), x) for i, x in enumerate(positions)),
            )
            if self.window is None:
                errors.append((("window",), "is required with positions", None))
            elif not self.smoothing_degree + 1 <= self.window <= t:
                errors.append(
                    (
                        ("window",),
                        f"must be between smoothing_degree + 1 = "
                        f"{self.smoothing_degree + 1} and the {t} samples, got "
                        f"{self.window}",
                        self.window,
                    )
                )
        elif self.window is not None:
            errors.append((("window",), "must be absent without positions", self.window))
        _raise(self, errors)
        return self


class NoiseResult(Schema):
    """Noise per range-sum series and the smoothed coordinates."""

    sigma: list[float] | None = Field(
        default=None, description="Estimated noise sigma of each series (column), m."
    )
    variance: list[float] | None = Field(
        default=None, description="sigma^2 = RSS / dof of each series, m^2."
    )
    dof: int | None = Field(
        default=None, description="Residual degrees of freedom T - (degree + 1)."
    )
    smoothed_range_sums: list[list[float]] | None = Field(
        default=None, description="The fitted polynomials at the sample times, m (T x P)."
    )
    smoothed_positions: list[list[float]] | None = Field(
        default=None, description="The smoothed coordinates at the sample times, m (T x D)."
    )
