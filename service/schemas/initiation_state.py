"""The wire form of a track-initiation state: what ``initiation.initiate`` returns and takes.

A client sends the state back unchanged with its next scans. It is typed field by field
(STATE_VERSION 3: version 2 had no held plots and no seal): the schema refuses wrong types,
unknown or missing keys, a foreign version, and every number beyond its magnitude
before anything runs, and the service then holds every field to its invariants (array
lengths, ids, histories, covariances: ``core.initiation.state_json``). Each refusal
names the state's own field, ``state.tracks.misses[3]``.

Magnitudes. Copies of plots keep the plots' bounds (sensors within
:data:`~plotgate.service.schemas.common.MAX_DISTANCE`, times within
:data:`~plotgate.service.schemas.solves.MAX_TIME`). What the service derives from a plot may
reach further: a polar plot's position is up to twice MAX_DISTANCE from the origin and a
Cartesian plot's range up to 2 sqrt(2) MAX_DISTANCE from its sensor, so derived positions,
ranges and range sigmas are bounded by :data:`STATE_DISTANCE` (variances by its square),
azimuth sigmas by STATE_DISTANCE / MIN_RANGE rad. A track's state and covariance come
from its filter: they are bounded by :data:`MAX_TRACK_VALUE`, far beyond any radar's
numbers and far enough below the double range (10^308) that every product one scan forms
(dt^2 P over 2 x 10^10 s, determinants of sums) stays finite.

Sizes. A state carries at most :data:`MAX_STATE_TRACKS` tracks and
:data:`MAX_STATE_INITIATORS` initiators (the ceiling; an operator may cap both together
lower: ``PLOTGATE_LIMITS`` size ``state`` of ``initiation.initiate``). A call whose scans
would leave more is refused, naming ``scans``.
"""

import math
from typing import Annotated, Literal

from pydantic import AfterValidator, Field, model_validator

from plotgate.service.schemas.common import MAX_DISTANCE, MAX_PLOTS, MIN_RANGE, Schema, invalid
from plotgate.service.schemas.solves import MAX_TIME

__all__ = [
    "MAX_HISTORY",
    "MAX_HISTORY_CELLS",
    "MAX_PLOT_ID",
    "MAX_SESSION_SCANS",
    "MAX_STATE_INITIATORS",
    "MAX_STATE_TRACKS",
    "MAX_TRACK_ID",
    "MAX_TRACK_VALUE",
    "PLOT_STRIDE",
    "STATE_DISTANCE",
    "SessionHeldPlots",
    "SessionInitiators",
    "SessionState",
    "SessionTracks",
]

MAX_STATE_TRACKS = 20_000
"""Most tracks one state carries (bench/HISTORY.md: one call at the ceiling)."""
MAX_HISTORY_CELLS = 160_000
"""Most plot-history cells (tracks x history) one state carries: at history 8, 20,000
tracks; at history 64, 2,500 (the plot-reuse rules key every pair of a track's plots)."""
MAX_STATE_INITIATORS = MAX_PLOTS
"""Most initiators one state carries: as many plots as one request may."""
MAX_SESSION_SCANS = 2**32
"""Most scans of a session (core.initiation.state.MAX_SESSION_SCANS)."""
MAX_PLOT_ID = 2**52
"""Plot ids scan * 2^20 + index stay below this (scan < 2^32)."""
MAX_TRACK_ID = 2**53
"""Track ids and next_track stay at most this (core.initiation.state.MAX_TRACK_ID)."""
MAX_HISTORY = 64
"""Most plots a track remembers (InitiationSettings.history)."""
STATE_DISTANCE = 4 * MAX_DISTANCE
"""Largest position, range or range sigma the service derives from plots, m."""
MAX_TRACK_VALUE = 1e100
"""Largest magnitude of a track's state, covariance and cost."""

PLOT_STRIDE = 2**20
"""Plot id = scan * PLOT_STRIDE + index (core.initiation.state.PLOT_STRIDE)."""


def _index_in_a_scan(plot: int) -> int:
    """A plot id whose index no scan reaches (a request carries at most MAX_PLOTS plots)
    is refused; -1, no plot, passes."""
    if plot >= 0 and plot % PLOT_STRIDE >= MAX_PLOTS:
        raise ValueError(
            f"plot id {plot} is scan {plot // PLOT_STRIDE}'s plot {plot % PLOT_STRIDE}, but a "
            f"scan holds at most {MAX_PLOTS} plots (indices 0 to {MAX_PLOTS - 1})"
        )
    return plot


PlotId = Annotated[int, Field(ge=0, lt=MAX_PLOT_ID), AfterValidator(_index_in_a_scan)]
ScanNumber = Annotated[int, Field(ge=0, lt=MAX_SESSION_SCANS)]
Seconds = Annotated[float, Field(ge=-MAX_TIME, le=MAX_TIME)]
Distance = Annotated[float, Field(ge=-STATE_DISTANCE, le=STATE_DISTANCE)]
Point = Annotated[list[Distance], Field(min_length=2, max_length=2)]
Sensor = Annotated[
    list[Annotated[float, Field(ge=-MAX_DISTANCE, le=MAX_DISTANCE)]],
    Field(min_length=2, max_length=2),
]
Variance = Annotated[float, Field(ge=-(STATE_DISTANCE**2), le=STATE_DISTANCE**2)]
Covariance2 = Annotated[
    list[Annotated[list[Variance], Field(min_length=2, max_length=2)]],
    Field(min_length=2, max_length=2),
]
Range = Annotated[float, Field(ge=MIN_RANGE, le=STATE_DISTANCE)]
Azimuth = Annotated[float, Field(ge=-math.pi, le=math.pi)]
SigmaR = Annotated[float, Field(gt=0, le=STATE_DISTANCE)]
SigmaAz = Annotated[float, Field(gt=0, le=STATE_DISTANCE / MIN_RANGE)]
TrackValue = Annotated[float, Field(ge=-MAX_TRACK_VALUE, le=MAX_TRACK_VALUE)]
Vector4 = Annotated[list[TrackValue], Field(min_length=4, max_length=4)]
Covariance4 = Annotated[list[Vector4], Field(min_length=4, max_length=4)]


class SessionInitiators(Schema):
    """Single plots waiting for a second plot in a capture gate, one row each."""

    plot: list[PlotId] = Field(
        max_length=MAX_STATE_INITIATORS, description="Plot id: scan * 2^20 + index in that scan."
    )
    scan: list[ScanNumber] = Field(
        max_length=MAX_STATE_INITIATORS, description="The plot's scan number in the session."
    )
    t: list[Seconds] = Field(max_length=MAX_STATE_INITIATORS, description="Its time, s.")
    z: list[Point] = Field(max_length=MAX_STATE_INITIATORS, description="Its [x, y], m.")
    R: list[Covariance2] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its 2 x 2 covariance, m^2."
    )
    sensor: list[Sensor] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its sensor's [x, y], m."
    )
    r: list[Range] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its range from the sensor, m."
    )
    az: list[Azimuth] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its azimuth from the sensor, rad."
    )
    sigma_r: list[SigmaR] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its range sigma, m."
    )
    sigma_az: list[SigmaAz] = Field(
        max_length=MAX_STATE_INITIATORS, description="Its azimuth sigma, rad."
    )
    score: list[TrackValue] = Field(
        max_length=MAX_STATE_INITIATORS,
        description="Track score of the single plot, ln(P_D beta_NT / beta_FT); 0 under k/m.",
    )


class SessionTracks(Schema):
    """Tentative and confirmed tracks, one row each; histories are ``config.history`` wide,
    oldest first, with -1 (plots) or null (ranges, times, sigma_r) before the first plot."""

    id: list[Annotated[int, Field(ge=0, lt=MAX_TRACK_ID)]] = Field(
        max_length=MAX_STATE_TRACKS, description="Track id, increasing."
    )
    confirmed: list[bool] = Field(max_length=MAX_STATE_TRACKS, description="Confirmed or not.")
    x: list[Vector4] = Field(
        max_length=MAX_STATE_TRACKS,
        description="State [x, y, vx, vy] at the state's time, m, m/s.",
    )
    P: list[Covariance4] = Field(max_length=MAX_STATE_TRACKS, description="Its 4 x 4 covariance.")
    t: list[Seconds] = Field(max_length=MAX_STATE_TRACKS, description="Time of x, s.")
    n: list[Annotated[int, Field(ge=2, le=MAX_SESSION_SCANS)]] = Field(
        max_length=MAX_STATE_TRACKS, description="Plots taken so far."
    )
    first_scan: list[ScanNumber] = Field(
        max_length=MAX_STATE_TRACKS, description="Scan of the first plot."
    )
    confirmed_scan: list[Annotated[int, Field(ge=-1, lt=MAX_SESSION_SCANS)]] = Field(
        max_length=MAX_STATE_TRACKS, description="Scan of confirmation, -1 while tentative."
    )
    misses: list[Annotated[int, Field(ge=0, lt=100)]] = Field(
        max_length=MAX_STATE_TRACKS, description="Misses in a row."
    )
    cost: list[Annotated[float, Field(ge=0, le=MAX_TRACK_VALUE)]] = Field(
        max_length=MAX_STATE_TRACKS, description="Sum of the association statistics."
    )
    plots: list[
        Annotated[
            list[Annotated[int, Field(ge=-1, lt=MAX_PLOT_ID), AfterValidator(_index_in_a_scan)]],
            Field(min_length=2, max_length=MAX_HISTORY),
        ]
    ] = Field(max_length=MAX_STATE_TRACKS, description="Ids of its last plots.")
    ranges: list[Annotated[list[Range | None], Field(min_length=2, max_length=MAX_HISTORY)]] = (
        Field(max_length=MAX_STATE_TRACKS, description="Their ranges from their sensors, m.")
    )
    times: list[Annotated[list[Seconds | None], Field(min_length=2, max_length=MAX_HISTORY)]] = (
        Field(max_length=MAX_STATE_TRACKS, description="Their times, s.")
    )
    sigma_r: list[Annotated[list[SigmaR | None], Field(min_length=2, max_length=MAX_HISTORY)]] = (
        Field(max_length=MAX_STATE_TRACKS, description="Their range sigmas, m.")
    )
    az: list[Azimuth] = Field(
        max_length=MAX_STATE_TRACKS, description="Azimuth of the last plot, rad."
    )
    sigma_az: list[SigmaAz] = Field(
        max_length=MAX_STATE_TRACKS, description="Its azimuth sigma, rad."
    )
    sensor: list[Sensor] = Field(
        max_length=MAX_STATE_TRACKS, description="The last plot's sensor [x, y], m."
    )
    score: list[TrackValue] = Field(
        max_length=MAX_STATE_TRACKS,
        description="Track score: the log-likelihood ratio, target against clutter; under "
        "existence confirmation the log-odds of existence; 0 under k/m.",
    )

    @model_validator(mode="after")
    def _cells(self) -> "SessionTracks":
        cells = sum(len(row) for row in self.plots)
        if cells > MAX_HISTORY_CELLS:
            raise invalid(
                "SessionTracks",
                [
                    (
                        ("plots",),
                        f"hold {cells} history cells (tracks x history); a state carries "
                        f"at most {MAX_HISTORY_CELLS}",
                        len(self.plots),
                    )
                ],
            )
        return self


class SessionHeldPlots(Schema):
    """The plots the tentative tracks hold, one row each, ids increasing: what each
    tentative track was made of (the service makes it again from them and compares)."""

    plot: list[PlotId] = Field(max_length=MAX_HISTORY_CELLS, description="Plot id.")
    z: list[Point] = Field(max_length=MAX_HISTORY_CELLS, description="Its [x, y], m.")
    R: list[Covariance2] = Field(
        max_length=MAX_HISTORY_CELLS, description="Its 2 x 2 covariance, m^2."
    )


class SessionState(Schema):
    """Everything initiation remembers between calls (version 3: version 2 had no held
    plots and no seal, version 1 no scores)."""

    version: Literal[3] = Field(description="State format version.")
    config_digest: str = Field(
        pattern=r"^[0-9a-f]{16}$", description="Fingerprint of the settings that made it."
    )
    scans: int = Field(
        ge=0, le=MAX_SESSION_SCANS, description="Scans processed so far (the next scan's number)."
    )
    t: Seconds | None = Field(description="Time of the last scan, s; null before the first.")
    next_track: int = Field(ge=0, le=MAX_TRACK_ID, description="The next track id.")
    initiators: SessionInitiators = Field(description="Plots waiting for a second plot.")
    tracks: SessionTracks = Field(description="The live tracks.")
    plots: SessionHeldPlots = Field(description="The plots the tentative tracks hold.")
    seal: str = Field(
        pattern=r"^[0-9a-f]{16}$",
        description="Fingerprint of the settings' digest and every other value of the state.",
    )

    def size(self) -> int:
        """Tracks and initiators carried: the rows every scan of the next call works on."""
        return len(self.tracks.id) + len(self.initiators.plot)
