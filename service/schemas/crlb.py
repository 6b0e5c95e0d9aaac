"""Wire models of ``solves.crlb``: the Cramer-Rao bound of range-sum positioning.

Single shot for target positions or accumulated along a track, for the range-sum or
the range-difference measurement set (Fadeev et al., eq. 3); the shared limits, field
types and platforms are in :mod:`plotgate.service.schemas.solves`.
"""

from typing import Literal

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Loc, Schema
from plotgate.service.schemas.solves import (
    MAX_PROBLEMS,
    MAX_RANGE_SUMS,
    MAX_SAMPLES,
    ONE_SIGMA,
    Platform,
    Point,
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
    "AccumulatedBound",
    "CrlbRequest",
    "CrlbResult",
    "SingleShotBound",
]


class CrlbRequest(Schema):
    """Cramer-Rao bound of the position error (Fadeev et al., eq. 3).

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
    transmitter: Platform | None = shared("The one transmitter of every pair.")
    transmitters: list[Platform] | None = per_pair(
        "Transmitter of each pair (several transmitters)."
    )
    receivers: list[Platform] = per_pair("Receiver of each pair.", optional=False)
    sigma: Sigma | None = shared(ONE_SIGMA)
    sigmas: list[Sigma] | None = per_pair(
        "Noise standard deviation of each pair's range sum, m, one per pair."
    )

    @model_validator(mode="after")
    def _rules(self) -> "CrlbRequest":
        p = len(self.receivers)
        errors = one_of(self, "targets", "track", "single-shot targets, or a track")
        n = None
        if self.track is not None:
            if self.sample_times is None:
                errors.append((("sample_times",), "is required with track", None))
            n = None if self.sample_times is None else len(self.sample_times)
        elif self.targets is not None:
            errors += length(("sample_times",), self.sample_times, len(self.targets), "target")
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
        errors += platform_rules(self, p, n, "sample", timed=self.sample_times is not None)
        errors += one_of(self, "sigma", "sigmas", "one sigma, or one per pair")
        errors += length(("sigmas",), self.sigmas, p, "pair")
        if not errors:
            own: list[tuple[Loc, list[float]]] = [
                (("targets", i), x) for i, x in enumerate(self.targets or ())
            ]
            if self.track is not None:
                own += [
                    (("track", "position"), self.track.position),
                    (("track", "velocity"), self.track.velocity),
                ]
            errors += dimension(
                [{len(v) for _, v in own}, *platform_sizes(self)],
                lambda: iter([*own, *platform_vectors(self)]),
            )
        raise_errors(self, errors)
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
