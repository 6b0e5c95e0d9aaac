"""Shared wire types: finite numbers, plots in Cartesian or polar form, problem details.

Every model forbids unknown fields and non-finite numbers (``NaN`` and ``Infinity`` are
refused with the field named), so a typo or a broken sensor value never passes silently.
Units are SI; angles on the wire are degrees in fields named ``*_deg``.

Magnitudes are bounded to what a radar can mean, which also keeps every quantity the
gates compute finite in double precision: coordinates and ranges within 10^9 m
(:data:`MAX_DISTANCE`), standard deviations from 1 mm to 10^9 m, azimuth sigmas from
10^-6 to 180 degrees, ranges of polar plots at least 1 m (:data:`MIN_RANGE`).
"""

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from pydantic_core import InitErrorDetails, PydanticCustomError

__all__ = [
    "Loc",
    "MAX_DISTANCE",
    "MAX_PLOTS",
    "MIN_RANGE",
    "MIN_VARIANCE",
    "CartesianPlot",
    "FieldError",
    "Plot",
    "PolarPlot",
    "Position",
    "Problem",
    "Schema",
    "invalid",
]

MAX_PLOTS = 100_000
"""Most plots (or pairs) one request may carry; a longer list is refused with 422."""
MAX_DISTANCE = 1e9
"""Largest coordinate or range, m (beyond geostationary orbit)."""
MIN_RANGE = 1.0
"""Smallest range of a plot from the radar it is measured about, m."""
MIN_VARIANCE = 1e-6
"""Smallest variance on a Cartesian plot's diagonal, m^2 (a polar plot's range sigma is at
least its root, 1 mm)."""


Loc = tuple[str | int, ...]
"""A location inside a request, as pydantic reports it: ("problems", 3, "receivers")."""


def invalid(model: str, errors: list[tuple[Loc, str, Any]]) -> ValidationError:
    """A validation error at the given (location, reason, input) triples.

    Raised from a model validator, its locations are kept (prefixed by the enclosing
    model's own), so a rule over several fields still names the field it concerns.
    """
    return ValidationError.from_exception_data(
        model,
        [
            InitErrorDetails(
                type=PydanticCustomError("invalid_combination", reason), loc=loc, input=value
            )
            for loc, reason, value in errors
        ],
    )


class Schema(BaseModel):
    """Base of every wire model: strict about unknown fields and non-finite floats."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


Coordinate = Annotated[float, Field(ge=-MAX_DISTANCE, le=MAX_DISTANCE)]
Position = tuple[Coordinate, Coordinate]
"""A point (x east, y north) in metres."""

Variance = Annotated[float, Field(ge=MIN_VARIANCE, le=MAX_DISTANCE**2)]
CrossCovariance = Annotated[float, Field(ge=-(MAX_DISTANCE**2), le=MAX_DISTANCE**2)]
Covariance = tuple[tuple[Variance, CrossCovariance], tuple[CrossCovariance, Variance]]


class CartesianPlot(Schema):
    """A mark (plot) at (x, y) with its 2x2 position covariance."""

    frame: Literal["cartesian"] = Field(description="Discriminator: Cartesian plot.")
    x: Coordinate = Field(description="East coordinate, m.")
    y: Coordinate = Field(description="North coordinate, m.")
    covariance: Covariance = Field(
        description="Position covariance [[Pxx, Pxy], [Pxy, Pyy]], m^2; symmetric positive "
        "definite."
    )
    sensor: Position = Field(
        default=(0.0, 0.0), description="Position of the radar that made the plot, m."
    )


class PolarPlot(Schema):
    """A mark measured in range and azimuth (clockwise from north) by a radar at ``sensor``."""

    frame: Literal["polar"] = Field(description="Discriminator: polar plot.")
    r: float = Field(ge=MIN_RANGE, le=MAX_DISTANCE, description="Range from the sensor, m.")
    az_deg: float = Field(ge=-360, le=360, description="Azimuth, degrees clockwise from north.")
    sigma_r: float = Field(
        ge=MIN_VARIANCE**0.5, le=MAX_DISTANCE, description="Range error sigma, m."
    )
    sigma_az_deg: float = Field(ge=1e-6, le=180, description="Azimuth error sigma, degrees.")
    sensor: Position = Field(default=(0.0, 0.0), description="Position of the radar, m.")


Plot = Annotated[CartesianPlot | PolarPlot, Field(discriminator="frame")]


class FieldError(Schema):
    """One offending input: where it is and what is wrong with it."""

    field: str = Field(description="Dotted path into the request body, e.g. candidates[3].r.")
    reason: str = Field(description="What is wrong with it, in words.")


class Problem(BaseModel):
    """RFC 9457 problem details, the body of every 4xx and 5xx answer."""

    model_config = ConfigDict(extra="allow")

    type: str = Field(description="URI naming the kind of problem.")
    title: str = Field(description="A short summary of the kind of problem.")
    status: int = Field(description="The HTTP status code of the answer.")
    detail: str = Field(description="What went wrong with this request, in words.")
    instance: str | None = Field(default=None, description="The request path.")
    request_id: str | None = Field(
        default=None,
        description="The exchange's id (the X-Request-ID header), under which it is recorded.",
    )
    errors: list[FieldError] = Field(
        default_factory=list,
        description="Each offending field of the request and why (empty when the problem is "
        "not one field's).",
    )
