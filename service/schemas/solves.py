"""Wire pieces shared by the multistatic solves: limits, field types and platforms.

A transmitter and a receiver form a *pair*; a pair measures the range sum
``l = |x - rx| + |x - tx|`` (m) of a target at ``x``, with Gaussian noise of standard
deviation ``sigma`` (Fadeev et al., eq. 1). Positions are arrays ``[x, y]`` (2D, x east,
y north) or ``[x, y, z]`` (3D), metres; every position and velocity of one request has
the same length. No angles are involved.

Each operation's request and result are in a module of their own:

- ``solves.position`` (:mod:`plotgate.service.schemas.position`): a batch of independent
  single-shot problems, each solved by maximum likelihood (weighted Gauss-Newton,
  Fadeev et al., eq. 6), optionally with the sum-range or difference-range closed form
  alongside (``method``);
- ``solves.trajectory`` (:mod:`plotgate.service.schemas.trajectory`): one
  constant-velocity target fitted to range sums at several sample times, the state
  (x0, v) and positions with covariances at requested times;
- ``solves.crlb`` (:mod:`plotgate.service.schemas.crlb`): the Cramer-Rao bound (Fadeev
  et al., eq. 3), single shot for target positions or accumulated along a track, for the
  range-sum or the range-difference measurement set;
- ``solves.noise`` (:mod:`plotgate.service.schemas.noise`): range-sum noise from a
  quadratic fit of each series (Fadeev et al., eq. 5), and sliding-window polynomial
  smoothing of solved coordinates.

Platforms of the trajectory, CRLB and noise operations are :class:`Platform` objects:
a fixed ``position``, a ``position`` plus a constant ``velocity`` (the position is that
at the first sample time), or one position per sample (``positions``). One transmitter
for every pair is given as ``transmitter``; one per pair as ``transmitters``. One sigma
for every measurement is ``sigma``; one per pair (per measurement) is ``sigmas``.

Rules over several fields (exactly one of two alternatives, matching lengths, one
dimension per request, the size limits) are model validators that answer 422 naming
the offending field (:mod:`plotgate.service.schemas.validation`). The mathematics (fewer
measurements than unknowns, coincident platforms, a range sum shorter than its baseline)
is checked by core and mapped to the field by :mod:`plotgate.service.operations.solves`.
"""

from collections.abc import Iterator, Sequence
from typing import Annotated, Any

from pydantic import Field, model_validator

from plotgate.service.schemas.common import MAX_DISTANCE, Loc, Schema
from plotgate.service.schemas.validation import length, one_of, raise_errors

__all__ = [
    "MAX_DEGREE",
    "MAX_MEASUREMENTS",
    "MAX_PROBLEMS",
    "MAX_RANGE_SUM",
    "MAX_RANGE_SUMS",
    "MAX_SAMPLES",
    "MAX_SPEED",
    "MAX_TIME",
    "MIN_SIGMA",
    "Alpha",
    "Coordinate",
    "FittedState",
    "MaxIter",
    "Platform",
    "Point",
    "RangeSum",
    "Row",
    "Sigma",
    "TargetState",
    "Time",
    "ONE_SIGMA",
    "VelocityVector",
    "per_pair",
    "platform_rules",
    "platform_sizes",
    "platform_vectors",
    "shared",
]


MAX_PROBLEMS = 10_000
"""Most problems of one ``solves.position`` request, or targets of one ``solves.crlb``."""
MAX_SAMPLES = 10_000
"""Most sample times of one trajectory, CRLB track or noise series; also most requested
``times`` of a trajectory solve."""
MAX_MEASUREMENTS = 64
"""Most (transmitter, receiver) pairs of one problem or one sample."""
ONE_SIGMA = "One noise standard deviation for every range sum, m."
"""The ``sigma`` field's description in every multistatic request."""
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
        errors = one_of(
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
        raise_errors(self, errors)
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


def platform_rules(
    request: Any, n_pairs: int, n_samples: int | None, samples: str, timed: bool = True
) -> list[tuple[Loc, str, Any]]:
    """Pair counts and per-sample position counts of a request's transmitter(s), receivers.

    ``n_samples`` is the number of samples (None when unknown: the request is refused
    for another reason) and ``samples`` says what they are, for messages; without
    sample times (``timed`` False) no platform may have a velocity.
    """
    errors = one_of(
        request, "transmitter", "transmitters", "one transmitter for every pair, or one per pair"
    )
    errors += length(("transmitters",), request.transmitters, n_pairs, "pair")
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
            errors += length((*loc, "positions"), platform.positions, n_samples, samples)
    return errors


def platform_sizes(request: Any) -> Iterator[set[int]]:
    """The vector lengths of each platform of a request (its transmitter(s) and receivers)."""
    for platform in (request.transmitter, *(request.transmitters or ()), *request.receivers):
        if platform is not None:
            yield platform.sizes()


def platform_vectors(request: Any) -> Iterator[tuple[Loc, Sequence[float]]]:
    """Every position and velocity of a request's platforms, with its location."""
    if request.transmitter is not None:
        yield from request.transmitter.vectors(("transmitter",))
    for k, p in enumerate(request.transmitters or ()):
        yield from p.vectors(("transmitters", k))
    for k, p in enumerate(request.receivers):
        yield from p.vectors(("receivers", k))


def shared(description: str) -> Any:
    """The field of a multistatic request that one value serves for every pair (the
    ``transmitter``, the ``sigma``): optional, its per-pair list being the other choice."""
    return Field(default=None, description=description)


def per_pair(description: str, *, optional: bool = True) -> Any:
    """The field of a multistatic request that holds one entry per (transmitter, receiver)
    pair (``transmitters``, ``receivers``, ``sigmas``): 1 to :data:`MAX_MEASUREMENTS`
    entries. The block of pairs (``transmitter``/``transmitters``, ``receivers``,
    ``sigma``/``sigmas``) of ``solves.position``, ``solves.trajectory`` and ``solves.crlb``
    is declared with these two, each model saying only its platform type and what a pair's
    entry is one of (a range sum, a column, a pair)."""
    if optional:
        return Field(
            default=None, min_length=1, max_length=MAX_MEASUREMENTS, description=description
        )
    return Field(min_length=1, max_length=MAX_MEASUREMENTS, description=description)
