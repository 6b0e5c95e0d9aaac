"""Wire models of ``solves.position``: a batch of single-shot range-sum problems.

Each problem is solved by maximum likelihood (Fadeev et al., eqs. 4 and 6), optionally
with a closed-form solution alongside; the shared limits and field types are in
:mod:`plotgate.service.schemas.solves`.
"""

from collections.abc import Iterator, Sequence
from typing import Any, Literal

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Loc, Schema
from plotgate.service.schemas.solves import (
    MAX_MEASUREMENTS,
    MAX_PROBLEMS,
    MAX_RANGE_SUMS,
    ONE_SIGMA,
    Alpha,
    MaxIter,
    Point,
    RangeSum,
    Sigma,
    per_pair,
    shared,
)
from plotgate.service.schemas.validation import dimension, length, one_of, raise_errors

__all__ = [
    "ClosedFormResult",
    "PositionProblem",
    "PositionSolution",
    "PositionSolveRequest",
    "PositionSolveResult",
]


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
    transmitter: Point | None = shared("The one transmitter of every pair, m.")
    transmitters: list[Point] | None = per_pair(
        "Transmitter of each pair, m, one per range sum (several transmitters)."
    )
    receivers: list[Point] = per_pair(
        "Receiver of each pair, m, one per range sum.", optional=False
    )
    sigma: Sigma | None = shared(ONE_SIGMA)
    sigmas: list[Sigma] | None = per_pair(
        "Noise standard deviation of each range sum, m, one per range sum."
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
        errors = one_of(
            self,
            "transmitter",
            "transmitters",
            "one transmitter for every pair, or one per range sum",
        )
        errors += one_of(self, "sigma", "sigmas", "one sigma, or one per range sum")
        errors += length(("receivers",), self.receivers, p, "range sum")
        errors += length(("transmitters",), self.transmitters, p, "range sum")
        errors += length(("sigmas",), self.sigmas, p, "range sum")
        raise_errors(self, errors)
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
    """A batch of independent single-shot position problems (Fadeev et al., eq. 4 and 6).

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
        "closed-form solution of that method (Fadeev et al., Fig. 3 curves 5 / 6) in closed_form.",
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
        errors += dimension(
            (p.sizes() for p in self.problems),
            lambda: (v for i, p in enumerate(self.problems) for v in p.vectors(("problems", i))),
        )
        raise_errors(self, errors)
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
