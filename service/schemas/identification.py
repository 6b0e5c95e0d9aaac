"""Wire models of passive/active mark identification (Kvasnov).

Operations:

- ``identification.pair``: one passive (ESM) track's bearings against one active radar
  track's bearings (optionally elevations): Fisher's Z-test of Kvasnov eq. 5 with its
  p-value, critical value and decision, beta and the m needed for a stated separation,
  the paper's conditions as numbers, and optionally the decision after each active
  sample (the sequential mode);
- ``identification.picture``: many passive and many active tracks: the Z matrix and a
  one-to-one identification (minimum total |Z| among the pairs that pass);
- ``identification.simulate``: the paper's experiment by Monte Carlo (realized alpha or
  beta).

Angles are degrees on the wire (``*_deg``), any value in [-720, 720]; differences are
wrapped, so 359 and 1 degree are 2 degrees apart. Levels (``alpha``, ``beta_max``,
``normality_alpha``) lie in [1e-12, 1) and sigmas in [1e-6, 180] degrees, so critical
values and Z stay finite.
"""

from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from plotgate.service.schemas.common import Loc, Schema, invalid

__all__ = [
    "MAX_PICTURE_SAMPLES",
    "MAX_SIMULATED_SAMPLES",
    "MAX_TRACK_SAMPLES",
    "IdentifyPairRequest",
    "IdentifyPairResult",
    "IdentifyPictureRequest",
    "IdentifyPictureResult",
    "IdentifySimulateRequest",
    "IdentifySimulateResult",
    "SequentialHistory",
]

MAX_TRACK_SAMPLES = 100_000
"""Most samples of one track."""
MAX_PICTURE_SAMPLES = 1_000_000
"""Most samples of one picture, passive and active together."""
MAX_SIMULATED_SAMPLES = 500_000_000
"""Most bearings one simulation may draw: runs x (n + m). The draws are made in chunks of
10^6 bearings (``core.identification.simulate``), so memory does not grow with it; the
default cap (``Endpoint.caps``) holds one process to about a second, and a Dask cluster
takes up to this bound (``Endpoint.cluster_caps``)."""

Angle = Annotated[float, Field(ge=-720, le=720)]
Samples = Annotated[list[Angle], Field(min_length=2, max_length=MAX_TRACK_SAMPLES)]
Level = Annotated[float, Field(ge=1e-12, lt=1)]
"""A level or error probability in [1e-12, 1): below 1e-12 the critical value
z_{1 - level/2} is as good as infinite (1 - level/2 rounds to 1 near 1e-16)."""
Sigma = Annotated[float, Field(ge=1e-6, le=180)]
"""A sigma in degrees, [1e-6, 180] as the plots' sigma_az_deg: much smaller, Z = d sqrt(m) /
sigma would overflow double precision."""


class IdentifyPairRequest(Schema):
    """One passive and one active track."""

    passive_bearings_deg: Samples = Field(
        description="Passive bearings, degrees (the population: n >= 2, n >> m)."
    )
    active_bearings_deg: Samples = Field(description="Active bearings, degrees (m >= 2).")
    sigma_deg: Sigma | None = Field(
        default=None,
        description="Bearing sigma of the population, degrees, in [1e-6, "
        "180]; null: estimated from the passive bearings.",
    )
    alpha: Level = Field(default=0.05, description="Level of the two-sided test, in [1e-12, 1).")
    passive_elevations_deg: Samples | None = Field(
        default=None, description="Passive elevations, degrees (with active ones)."
    )
    active_elevations_deg: Samples | None = Field(
        default=None, description="Active elevations, degrees (with passive ones)."
    )
    sigma_elevation_deg: Sigma | None = Field(
        default=None, description="Elevation sigma, degrees, in [1e-6, 180]; null: estimated."
    )
    delta_deg: Annotated[float, Field(gt=0, le=180)] | None = Field(
        default=None,
        description="Smallest bearing separation of two objects, degrees: gives beta.",
    )
    beta_max: Level | None = Field(
        default=None,
        description="Wanted type II error, in [1e-12, 1): gives m_required (needs delta_deg).",
    )
    ratio: float = Field(
        default=10.0, gt=1, le=1e6, description="The n / m that counts as 'n much larger than m'."
    )
    normality_alpha: Level = Field(
        default=0.05, description="Level of the Shapiro-Wilk normality check, in [1e-12, 1)."
    )
    sequential: bool = Field(
        default=False, description="Also return the decision after each active sample."
    )


class SequentialHistory(Schema):
    """The decision after 2, 3, ..., m active samples."""

    m: list[int] = Field(description="Active samples used.")
    z: list[float] = Field(description="Z after each.")
    identified: list[bool] = Field(description="The decision after each.")
    first_decision: int = Field(description="The m from which the decision stayed final.")


class IdentifyPairResult(Schema):
    """The Z-test of one pair."""

    z: list[float] = Field(description="Z per coordinate: [bearing] or [bearing, elevation].")
    p_value: list[float] = Field(description="Two-sided p-values.")
    critical: float = Field(description="z_{1 - alpha / (2k)}, k coordinates (Bonferroni).")
    identified: bool = Field(description="One object: every |Z| <= critical.")
    difference_deg: list[float] = Field(
        description="Wrapped difference of the circular means, active minus passive."
    )
    sigma_deg: list[float] = Field(description="The sigma used per coordinate, degrees.")
    n: int = Field(description="Passive samples.")
    m: int = Field(description="Active samples.")
    n_over_m: float = Field(description="n / m.")
    large_population: bool = Field(description="n / m >= ratio.")
    normality_p: list[float | None] = Field(
        description="Shapiro-Wilk p-value of the passive deviations (null when n < 3)."
    )
    normal: bool = Field(description="Every normality_p >= normality_alpha.")
    beta: float | None = Field(description="Type II error at delta_deg, or null.")
    m_required: int | None = Field(description="Smallest m with beta <= beta_max, or null.")
    history: SequentialHistory | None = Field(
        default=None, description="With sequential: the decision after each active sample."
    )


MAX_TRACKS = 10_000
"""Most passive (or active) tracks in one picture."""
Tracks = Annotated[list[Samples], Field(min_length=1, max_length=MAX_TRACKS)]


class IdentifyPictureRequest(Schema):
    """Many passive and many active tracks at once."""

    passive_deg: Tracks = Field(description="Bearings of each passive track, degrees.")
    active_deg: Tracks = Field(description="Bearings of each active track, degrees.")
    sigma_deg: Sigma | Annotated[list[Sigma], Field(max_length=MAX_TRACKS)] | None = Field(
        default=None,
        description="Bearing sigma, degrees, each in [1e-6, 180]: one for "
        "all, one per passive track, or null (estimated per passive track).",
    )
    alpha: Level = Field(default=0.05, description="Level of each pair's test, in [1e-12, 1).")

    @model_validator(mode="after")
    def _size(self) -> "IdentifyPictureRequest":
        errors: list[tuple[Loc, str, Any]] = []
        total = sum(map(len, self.passive_deg)) + sum(map(len, self.active_deg))
        if total > MAX_PICTURE_SAMPLES:
            errors.append(
                (
                    ("passive_deg",),
                    f"the picture carries {total} samples; at most {MAX_PICTURE_SAMPLES}",
                    total,
                )
            )
        if isinstance(self.sigma_deg, list) and len(self.sigma_deg) != len(self.passive_deg):
            errors.append(
                (
                    ("sigma_deg",),
                    f"must have {len(self.passive_deg)} entries, one "
                    f"per passive track; got {len(self.sigma_deg)}",
                    len(self.sigma_deg),
                )
            )
        if errors:
            raise invalid("IdentifyPictureRequest", errors)
        return self


class IdentifyPictureResult(Schema):
    """The Z matrix and the identification."""

    z: list[list[float]] = Field(description="Z[i][j] of passive i against active j.")
    p_value: list[list[float]] = Field(description="Two-sided p-values.")
    critical: float = Field(description="z_{1 - alpha/2}.")
    passes: list[list[bool]] = Field(description="|Z| <= critical.")
    pairs: list[Annotated[list[int], Field(min_length=2, max_length=2)]] = Field(
        description="One-to-one identification [passive, active], by minimum total |Z|."
    )
    unassigned_passive: list[int] = Field(description="Passive tracks without a partner.")
    unassigned_active: list[int] = Field(description="Active tracks without a partner.")
    sigma_deg: list[float] = Field(description="Bearing sigma of each passive track.")


class IdentifySimulateRequest(Schema):
    """Kvasnov's experiment: normal passive bearings, active ones uniform in a sector."""

    n: int = Field(default=50, ge=2, le=MAX_TRACK_SAMPLES, description="Passive samples.")
    m: int = Field(default=5, ge=2, le=MAX_TRACK_SAMPLES, description="Active samples.")
    sigma_deg: Sigma = Field(
        default=1.0, description="Passive bearing sigma, degrees, in [1e-6, 180]."
    )
    separation_deg: Annotated[float, Field(ge=-180, le=180)] = Field(
        default=0.0,
        description="Active object's bearing minus the passive one's: 0 "
        "measures the type I error, else the type II error.",
    )
    width_deg: Annotated[float, Field(gt=0, le=360)] = Field(
        default=3.0, description="Width of the active bearings' uniform sector, degrees."
    )
    law: Literal["uniform", "normal"] = Field(
        default="uniform",
        description="Active bearings uniform in the sector (the paper) or normal with sigma.",
    )
    estimate_sigma: bool = Field(
        default=False, description="Estimate sigma from each passive sample."
    )
    alpha: Level = Field(default=0.05, description="Level of the test, in [1e-12, 1).")
    runs: int = Field(default=10_000, ge=1, le=10_000_000, description="Monte Carlo runs.")
    seed: int = Field(default=0, ge=0, le=2**63 - 1, description="Seed.")

    @model_validator(mode="after")
    def _work(self) -> "IdentifySimulateRequest":
        work = self.runs * (self.n + self.m)
        if work > MAX_SIMULATED_SAMPLES:
            raise invalid(
                "IdentifySimulateRequest",
                [
                    (
                        ("runs",),
                        f"runs x (n + m) is {work}; at most {MAX_SIMULATED_SAMPLES}",
                        self.runs,
                    )
                ],
            )
        return self


class IdentifySimulateResult(Schema):
    """Fractions over the runs."""

    runs: int = Field(description="Monte Carlo runs.")
    identified: float = Field(
        description="Fraction identified: the type II error beta when separation_deg != 0."
    )
    rejected: float = Field(
        description="Fraction rejected: the realized type I error when separation_deg = 0."
    )
    standard_error: float = Field(description="Binomial standard error of the fractions.")
