"""Wire models of ``solves.noise``: range-sum noise estimation and position smoothing.

The noise of each range-sum series from a polynomial fit (Fadeev et al., eq. 5), and
sliding-window polynomial smoothing of solved coordinates; the shared limits and field
types are in :mod:`plotgate.service.schemas.solves`.
"""

from typing import Any

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Loc, Schema
from plotgate.service.schemas.solves import (
    MAX_DEGREE,
    MAX_RANGE_SUMS,
    MAX_SAMPLES,
    Point,
    Row,
    Time,
)
from plotgate.service.schemas.validation import dimension, length, raise_errors

__all__ = [
    "NoiseRequest",
    "NoiseResult",
]


class NoiseRequest(Schema):
    """Range-sum noise from polynomial fits (Fadeev et al., eq. 5) and coordinate smoothing.

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
            errors += length(("range_sums",), self.range_sums, t, "sample time")
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
            errors += length(("positions",), self.positions, t, "sample time")
            positions = self.positions
            errors += dimension(
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
        raise_errors(self, errors)
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
