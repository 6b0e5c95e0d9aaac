"""Wire models of ``solves.trajectory``: one constant-velocity target fitted to range sums.

The state (x0, v) is fitted by maximum likelihood to range sums at several sample
times (Fadeev et al., eqs. 2, 4 and 6); the shared limits, field types and platforms
are in :mod:`plotgate.service.schemas.solves`.
"""

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Schema
from plotgate.service.schemas.solves import (
    MAX_RANGE_SUMS,
    MAX_SAMPLES,
    ONE_SIGMA,
    Alpha,
    FittedState,
    MaxIter,
    Platform,
    Row,
    Sigma,
    TargetState,
    Time,
    per_pair,
    platform_rules,
    platform_sizes,
    platform_vectors,
    shared,
)
from plotgate.service.schemas.validation import dimension, length, one_of, raise_errors

__all__ = [
    "TrajectorySolveRequest",
    "TrajectorySolveResult",
]


class TrajectorySolveRequest(Schema):
    """One constant-velocity target observed through P pairs at T sample times (Fadeev et al.).

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
    transmitter: Platform | None = shared("The one transmitter of every pair.")
    transmitters: list[Platform] | None = per_pair(
        "Transmitter of each pair (several transmitters), one per column."
    )
    receivers: list[Platform] = per_pair(
        "Receiver of each pair, one per column of range_sums.", optional=False
    )
    sigma: Sigma | None = shared(ONE_SIGMA)
    sigmas: list[Sigma] | None = per_pair(
        "Noise standard deviation of each pair's range sums, m, one per pair."
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
        errors = length(("range_sums",), self.range_sums, t, "sample time")
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
        errors += platform_rules(self, p, t, "sample time")
        errors += one_of(self, "sigma", "sigmas", "one sigma, or one per pair")
        errors += length(("sigmas",), self.sigmas, p, "pair")
        if not errors:
            own = []
            if self.initial is not None:
                own = [
                    (("initial", "position"), self.initial.position),
                    (("initial", "velocity"), self.initial.velocity),
                ]
            errors += dimension(
                [*platform_sizes(self), {len(v) for _, v in own}],
                lambda: iter([*platform_vectors(self), *own]),
            )
        raise_errors(self, errors)
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
