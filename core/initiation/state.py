"""The state of track initiation between calls: plain arrays, versioned, JSON-ready.

:func:`plotgate.core.initiation.initiate` is stateless: it takes an :class:`InitiationState` and
scans and returns the next state. A state is the initiators waiting for a second plot,
the tentative and confirmed tracks, and counters; :meth:`InitiationState.to_json` and
:func:`plotgate.core.initiation.state_json.state_from_json` turn it into plain lists and back,
bit for bit (floats keep their 17 significant digits), so a client can hold it between
calls and sending scans one call at a time answers exactly as sending them all at once.

A state is bound to the settings that made it: it carries ``config_digest``, and
:func:`~plotgate.core.initiation.state_json.state_from_json` refuses a state of another version,
of other settings, or any field that breaks an invariant (naming the field).

A state carries the plots its tentative tracks were made of (:class:`HeldPlots`), so a
tentative track's state and covariance can be made again from them and compared
(:mod:`plotgate.core.initiation.held_checks`). Its JSON form carries a ``seal``
(:func:`seal`), a fingerprint of the settings' digest and every other value, so a digest
moved from another state, or any value changed alone, no longer matches it; like the
digest, anyone can recompute it, so it is a check of integrity, not a signature.

Plots are identified across calls by ``scan * PLOT_STRIDE + index``, the scan's number
in the session (0, 1, ...) and the plot's index in that scan.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, fields, replace
from typing import Any, Self

import numpy as np

from plotgate.core.initiation.config import InitiationConfig

__all__ = [
    "MAX_SESSION_SCANS",
    "MAX_TRACK_ID",
    "NULLABLE",
    "PLOT_STRIDE",
    "STATE_VERSION",
    "HeldPlots",
    "Rows",
    "InitiationState",
    "Initiators",
    "Tracks",
    "empty_state",
    "layout",
    "no_held_plots",
    "seal",
]

STATE_VERSION = 3
"""Version 2 added the track score (``score`` of initiators and tracks); version 3 the
plots the tentative tracks hold (``plots``) and the ``seal``."""
PLOT_STRIDE = 1 << 20
"""Plot id = scan * PLOT_STRIDE + index (at most PLOT_STRIDE plots per scan)."""
MAX_SESSION_SCANS = 1 << 32
"""Most scans of one session (13.6 years at 10 scans a second): plot ids stay below
2^52, track ids below MAX_TRACK_ID, both exact in any JSON reader's doubles."""
MAX_TRACK_ID = 1 << 53
"""Track ids (and next_track) stay at most 2^53, exact in a double."""


@dataclass(frozen=True)
class Rows:
    """Arrays of one length along their first axis, a row each: initiators or tracks."""

    @property
    def size(self) -> int:
        """Number of rows."""
        return int(getattr(self, fields(self)[0].name).shape[0])

    def take(self, rows: np.ndarray) -> Self:
        """The rows at ``rows`` (indices or a boolean mask; a mask is turned into indices
        once, not once per array)."""
        index = np.flatnonzero(rows) if rows.dtype == bool else rows
        return type(self)(*(np.take(getattr(self, f.name), index, axis=0) for f in fields(self)))

    def join(self, other: Self) -> Self:
        """These rows followed by ``other``'s."""
        return type(self)(
            *(
                np.concatenate([getattr(self, f.name), getattr(other, f.name)])
                for f in fields(self)
            )
        )


@dataclass(frozen=True)
class Initiators(Rows):
    """Single plots waiting for a second plot in a capture gate (n of them).

    plot (n,) ids; scan (n,) scan numbers; t (n,) times, s; z (n, 2), R (n, 2, 2) the
    plots and covariances, m, m^2; sensor (n, 2) their sensor, m; r, az, sigma_r,
    sigma_az (n,) their polar form about it, m and rad; score (n,) the track score of a
    single plot (:func:`~plotgate.core.initiation.score.first_plot_score`; 0 under k/m
    confirmation).
    """

    plot: np.ndarray
    scan: np.ndarray
    t: np.ndarray
    z: np.ndarray
    R: np.ndarray
    sensor: np.ndarray
    r: np.ndarray
    az: np.ndarray
    sigma_r: np.ndarray
    sigma_az: np.ndarray
    score: np.ndarray


@dataclass(frozen=True)
class Tracks(Rows):
    """Tentative and confirmed tracks (m of them); H = config.history.

    id (m,) track ids; confirmed (m,) bool; x (m, 4) state [x, y, vx, vy] (m, m/s) at
    time t (m,); P (m, 4, 4) its covariance; n (m,) plots so far; first_scan (m,) scan of
    the first plot; confirmed_scan (m,) scan of confirmation (-1 while tentative);
    misses (m,) misses in a row; cost (m,) sum of the association statistics; plots
    (m, H) the last H plot ids, newest last, -1 before the first; ranges, times (m, H)
    range (m, about the plot's sensor) and time (s) of those plots (NaN where no plot);
    sigma_r (m, H) their range sigmas; az, sigma_az (m,) azimuth of the last plot and its
    sigma, rad; sensor (m, 2) the last plot's sensor, m; score (m,) the track's
    log-likelihood ratio (:mod:`plotgate.core.initiation.score`; 0 under k/m
    confirmation).
    """

    id: np.ndarray
    confirmed: np.ndarray
    x: np.ndarray
    P: np.ndarray
    t: np.ndarray
    n: np.ndarray
    first_scan: np.ndarray
    confirmed_scan: np.ndarray
    misses: np.ndarray
    cost: np.ndarray
    plots: np.ndarray
    ranges: np.ndarray
    times: np.ndarray
    sigma_r: np.ndarray
    az: np.ndarray
    sigma_az: np.ndarray
    sensor: np.ndarray
    score: np.ndarray


@dataclass(frozen=True)
class HeldPlots(Rows):
    """The plots the tentative tracks hold (k of them, ids increasing): what each
    tentative track was made of, so it can be made again and compared.

    plot (k,) ids; z (k, 2) the plots, m; R (k, 2, 2) their covariances, m^2.
    """

    plot: np.ndarray
    z: np.ndarray
    R: np.ndarray


def no_held_plots() -> HeldPlots:
    """The held plots of a state without tentative tracks."""
    return HeldPlots(np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)))


_DTYPES: dict[str, type] = {
    "plot": np.int64,
    "scan": np.int64,
    "id": np.int64,
    "confirmed": bool,
    "n": np.int64,
    "first_scan": np.int64,
    "confirmed_scan": np.int64,
    "misses": np.int64,
    "plots": np.int64,
}
_SHAPES: dict[str, dict[str, tuple[int | str, ...]]] = {  # "H" is config.history
    "initiators": {"z": (2,), "R": (2, 2), "sensor": (2,)},
    "plots": {"z": (2,), "R": (2, 2)},
    "tracks": {
        "x": (4,),
        "P": (4, 4),
        "sensor": (2,),
        "plots": ("H",),
        "ranges": ("H",),
        "times": ("H",),
        "sigma_r": ("H",),
    },
}
NULLABLE = frozenset({"ranges", "times", "sigma_r"})
"""Tracks' history arrays that hold NaN (JSON null) where no plot is yet."""


def layout(part: str, name: str, history: int) -> tuple[type, tuple[int, ...]]:
    """dtype and trailing shape of the array ``name`` of ``part`` ("initiators",
    "tracks" or "plots"); ``history`` is config.history, the width H of the tracks' histories."""
    shape = tuple(history if s == "H" else int(s) for s in _SHAPES[part].get(name, ()))
    return _DTYPES.get(name, float), shape


@dataclass(frozen=True)
class InitiationState:
    """Everything initiation remembers between scans.

    Attributes
    ----------
    version : int
        STATE_VERSION.
    config_digest : str
        :meth:`InitiationConfig.digest` of the settings that made the state.
    scans : int
        Scans processed so far (the next scan's number).
    t : float or None
        Time of the last scan, s (None before the first).
    next_track : int
        The next track id.
    initiators : Initiators
    tracks : Tracks
    plots : HeldPlots
        The plots the tentative tracks hold.
    """

    version: int
    config_digest: str
    scans: int
    t: float | None
    next_track: int
    initiators: Initiators
    tracks: Tracks
    plots: HeldPlots = field(default_factory=no_held_plots)

    def to_json(self) -> dict[str, Any]:
        """Plain lists, numbers and strings (NaN as None), sealed (:func:`seal`);
        ``state_from_json`` inverts it."""

        def part(obj: Any) -> dict[str, Any]:
            out = {}
            for f in fields(obj):
                a = getattr(obj, f.name)
                if isinstance(obj, Tracks) and f.name in NULLABLE:
                    a = np.where(np.isnan(a), None, a.astype(object))
                out[f.name] = a.tolist()
            return out

        data = {
            "version": self.version,
            "config_digest": self.config_digest,
            "scans": self.scans,
            "t": self.t,
            "next_track": self.next_track,
            "initiators": part(self.initiators),
            "tracks": part(self.tracks),
            "plots": part(self.plots),
        }
        return {**data, "seal": seal(data)}

    def replace(self, **changes: Any) -> InitiationState:
        return replace(self, **changes)


def seal(data: dict[str, Any]) -> str:
    """A short fingerprint (sha256, 16 hex digits) of a state's JSON form but its ``seal``:
    its settings' digest bound to every value it holds. Python's JSON writes each float
    with the digits that read back to it, so a state read back seals the same."""
    body = {key: value for key, value in data.items() if key != "seal"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _empty(cls: type, where: str, history: int) -> Any:
    arrays: dict[str, np.ndarray] = {}
    for f in fields(cls):
        dtype, shape = layout(where, f.name, history)
        arrays[f.name] = np.zeros((0, *shape), dtype=dtype)
    return cls(**arrays)


def empty_state(config: InitiationConfig) -> InitiationState:
    """The state before the first scan."""
    return InitiationState(
        STATE_VERSION,
        config.digest(),
        0,
        None,
        0,
        _empty(Initiators, "initiators", config.history),
        _empty(Tracks, "tracks", config.history),
    )
