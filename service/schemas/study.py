"""Wire models of ``solves.study``: the Monte Carlo accuracy study of Fadeev et al., Fig. 3.

One transmitter and its receivers (fixed, or moving at constant velocity from their
positions at ``sample_times[0]``, or given per sample) watch a constant-velocity target;
the study simulates ``runs`` noisy range-sum series (seeded) and reports, at every sample,
the six curves of the paper's Fig. 3 and the diagnostics of
:func:`plotgate.core.multistatic.study.accuracy_study`. Positions are 2D or 3D, metres.

Work limits: runs x samples x pairs <= :data:`MAX_STUDY_RANGE_SUMS` (the simulated range
sums), and with ``tracks`` (one trajectory solve per prefix of the samples) runs x
samples^2 x pairs <= :data:`MAX_STUDY_TRACK_WORK`; the default study (1000 runs, 200
samples, 3 pairs) is at the track limit and takes minutes.
"""

from typing import Any

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Loc, Schema
from plotgate.service.schemas.solves import (
    MAX_MEASUREMENTS,
    Alpha,
    Platform,
    Sigma,
    TargetState,
    Time,
)
from plotgate.service.schemas.validation import dimension, length, raise_errors

__all__ = [
    "MAX_STUDY_RANGE_SUMS",
    "MAX_STUDY_RUNS",
    "MAX_STUDY_SAMPLES",
    "MAX_STUDY_TRACK_WORK",
    "StudyRequest",
    "StudyResult",
    "StudySample",
]

MAX_STUDY_RUNS = 10_000
"""Most Monte Carlo runs of one study."""
MAX_STUDY_SAMPLES = 1000
"""Most sample times of one study."""
MAX_STUDY_RANGE_SUMS = 2_400_000
"""Most simulated range sums, runs x samples x pairs (the default scenario with 4000
runs; about 1.5 GB of working memory at the limit)."""
MAX_STUDY_TRACK_WORK = 120_000_000
"""Most runs x samples^2 x pairs with tracks (the range sums all prefix solves fit)."""


class StudyRequest(Schema):
    """A Fadeev et al., Fig. 3 accuracy study: geometry, target, noise and Monte Carlo size."""

    transmitter: Platform = Field(description="The one transmitter of every pair.")
    receivers: list[Platform] = Field(
        min_length=2,
        max_length=MAX_MEASUREMENTS,
        description="The receivers, one per pair; at least D + 1 (the difference-range "
        "method needs them).",
    )
    target: TargetState = Field(
        description="The target: position at sample_times[0] and constant velocity."
    )
    sample_times: list[Time] = Field(
        min_length=2,
        max_length=MAX_STUDY_SAMPLES,
        description="Sample times, s, strictly increasing.",
    )
    sigma: Sigma = Field(description="Range-sum noise standard deviation, m.")
    runs: int = Field(default=1000, ge=2, le=MAX_STUDY_RUNS, description="Monte Carlo runs.")
    seed: int = Field(default=0, ge=0, le=2**63 - 1, description="Seed of the noise.")
    alpha: Alpha = 0.01
    tracks: bool = Field(
        default=True,
        description="Also solve the ML track of every prefix of the samples (curve 3) "
        "and the full track: most of the cost.",
    )

    @model_validator(mode="after")
    def _rules(self) -> "StudyRequest":
        t, p = len(self.sample_times), len(self.receivers)
        errors: list[tuple[Loc, str, Any]] = []
        for loc, platform in [
            (("transmitter",), self.transmitter),
            *((("receivers", k), q) for k, q in enumerate(self.receivers)),
        ]:
            if platform.positions is not None:
                errors += length((*loc, "positions"), platform.positions, t, "sample time")
        work = self.runs * t * p
        if work > MAX_STUDY_RANGE_SUMS:
            errors.append(
                (
                    ("runs",),
                    f"{self.runs} runs x {t} samples x {p} pairs is {work} "
                    f"range sums; at most {MAX_STUDY_RANGE_SUMS}",
                    self.runs,
                )
            )
        elif self.tracks and work * t > MAX_STUDY_TRACK_WORK:
            errors.append(
                (
                    ("runs",),
                    f"with tracks, runs x samples^2 x pairs is "
                    f"{work * t}; at most {MAX_STUDY_TRACK_WORK} (or set tracks "
                    f"false)",
                    self.runs,
                )
            )
        if not errors:
            own = [
                (("target", "position"), self.target.position),
                (("target", "velocity"), self.target.velocity),
            ]
            platforms = [
                *self.transmitter.vectors(("transmitter",)),
                *(v for k, q in enumerate(self.receivers) for v in q.vectors(("receivers", k))),
            ]
            sizes = [
                {len(v) for _, v in own},
                self.transmitter.sizes(),
                *(q.sizes() for q in self.receivers),
            ]
            errors += dimension(sizes, lambda: iter([*own, *platforms]))
        raise_errors(self, errors)
        return self


class StudySample(Schema):
    """Every curve and diagnostic at one sample time (per-axis values are m, D entries)."""

    t: float = Field(description="Sample time, s.")
    position: list[float] = Field(description="True target position, m.")
    crlb: list[float] = Field(description="Curve 1: single-shot CRLB per axis, m.")
    crlb_accumulated: list[float] = Field(
        description="Curve 2: CRLB accumulated over samples 0..i, position at t_i, m."
    )
    crlb_difference: list[float] = Field(
        description="Single-shot CRLB of the range differences (curve 6's bound), m."
    )
    ml_track: list[float] | None = Field(
        description="Curve 3: RMSE of the ML track of samples 0..i at t_i, m (null at "
        "sample 0 and without tracks)."
    )
    ml_single: list[float] = Field(description="Curve 4: ML single-shot RMSE, m.")
    sum_range: list[float] = Field(description="Curve 5: sum-range closed-form RMSE, m.")
    difference_range: list[float] = Field(
        description="Curve 6: difference-range closed-form RMSE, m."
    )
    linearised: list[float] = Field(
        description="RMSE of the linearised efficient single-shot estimator on the same "
        "noise (expected: the CRLB), m."
    )
    linearised_track: list[float] | None = Field(
        description="The same for the track of samples 0..i, m (null where ml_track is)."
    )
    full_track: list[float] | None = Field(
        description="RMSE at t_i of the track fitted to all samples, m (null without tracks)."
    )
    full_track_crlb: list[float] | None = Field(
        description="Its bound at t_i, m (null without tracks)."
    )
    ml_single_se: float = Field(
        description="Relative Monte Carlo standard error of the ML single-shot total RMSE."
    )
    max_distance: float = Field(
        description="Largest Mahalanobis distance sqrt(e^T J e) of an ML single-shot error."
    )
    max_track_distance: float | None = Field(
        description="The same for the ML track (null where ml_track is)."
    )
    gradient: list[float] = Field(
        description="|dl_p/dx| of each pair at the truth: near 0 on that pair's baseline."
    )
    inconsistent: int = Field(description="ML single-shot runs failing the chi-square test.")
    not_converged: int = Field(description="ML single-shot runs that did not converge.")
    false_minima: int = Field(
        description="ML single-shot runs at a false minimum (more than one sigma from the "
        "minimum reached from the truth, with a higher cost)."
    )
    false_unflagged: int = Field(description="Of those, the runs passing the chi-square test.")
    track_inconsistent: int = Field(description="ML track runs failing the chi-square test.")
    track_not_converged: int = Field(description="ML track runs that did not converge.")
    sum_range_unsolvable: int = Field(description="Sum-range runs with no consistent root.")
    difference_range_unsolvable: int = Field(
        description="Difference-range runs with no consistent root."
    )


class StudyResult(Schema):
    """The study at every sample time, and the noise estimate of eq. 5."""

    runs: int = Field(description="Monte Carlo runs.")
    seed: int = Field(description="Seed of the noise.")
    sigma: float = Field(description="Range-sum noise standard deviation, m.")
    noise_sigma: float = Field(
        description="Mean over runs and pairs of the eq. 5 noise estimate (quadratic fits "
        "over windows of 50 samples), m."
    )
    noise_sigma_spread: float = Field(description="Its standard deviation, m.")
    samples: list[StudySample] = Field(description="One entry per sample time.")
