"""The state of track initiation between calls: plain arrays, versioned, JSON-ready.

:func:`core.initiation.initiate` is stateless: it takes an :class:`InitiationState` and
scans and returns the next state. A state is the initiators waiting for a second plot,
the tentative and confirmed tracks, and counters; :meth:`InitiationState.to_json` and
:func:`state_from_json` turn it into plain lists and back, bit for bit (floats keep
their 17 significant digits), so a client can hold it between calls and sending scans
one call at a time answers exactly as sending them all at once.

A state is bound to the settings that made it: it carries ``config_digest``, and
:func:`state_from_json` refuses a state of another version, of other settings, or
whose arrays do not fit together (``ParameterError`` naming the offending part).

Plots are identified across calls by ``scan * PLOT_STRIDE + index``, the scan's number
in the session (0, 1, ...) and the plot's index in that scan.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from core.errors import ParameterError
from core.initiation.config import InitiationConfig

__all__ = ["PLOT_STRIDE", "STATE_VERSION", "InitiationState", "Initiators", "Tracks",
           "empty_state", "state_from_json"]

STATE_VERSION = 1
PLOT_STRIDE = 1 << 20
"""Plot id = scan * PLOT_STRIDE + index (at most PLOT_STRIDE plots per scan)."""


@dataclass(frozen=True)
class Initiators:
    """Single plots waiting for a second plot in a capture gate (n of them).

    plot (n,) ids; scan (n,) scan numbers; t (n,) times, s; z (n, 2), R (n, 2, 2) the
    plots and covariances, m, m^2; sensor (n, 2) their sensor, m; r, az, sigma_r,
    sigma_az (n,) their polar form about it, m and rad.
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


@dataclass(frozen=True)
class Tracks:
    """Tentative and confirmed tracks (m of them); H = config.history.

    id (m,) track ids; confirmed (m,) bool; x (m, 4) state [x, y, vx, vy] (m, m/s) at
    time t (m,); P (m, 4, 4) its covariance; n (m,) plots so far; first_scan (m,) scan of
    the first plot; confirmed_scan (m,) scan of confirmation (-1 while tentative);
    misses (m,) misses in a row; cost (m,) sum of the association statistics; plots
    (m, H) the last H plot ids, newest last, -1 before the first; ranges, times (m, H)
    range (m, about the plot's sensor) and time (s) of those plots (NaN where no plot);
    sigma_r (m, H) their range sigmas; az, sigma_az (m,) azimuth of the last plot and its
    sigma, rad; sensor (m, 2) the last plot's sensor, m.
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

    @property
    def size(self) -> int:
        return int(self.id.shape[0])

    def take(self, rows: np.ndarray) -> Tracks:
        """The tracks at ``rows`` (indices or a boolean mask)."""
        return Tracks(*(getattr(self, f.name)[rows] for f in fields(self)))

    def join(self, other: Tracks) -> Tracks:
        """These tracks followed by ``other``."""
        return Tracks(*(np.concatenate([getattr(self, f.name), getattr(other, f.name)])
                        for f in fields(self)))


_DTYPES = {
    "plot": np.int64, "scan": np.int64, "id": np.int64, "confirmed": bool,
    "n": np.int64, "first_scan": np.int64, "confirmed_scan": np.int64,
    "misses": np.int64, "plots": np.int64,
}
_SHAPES = {  # trailing shapes per part; "H" is config.history
    "initiators": {"z": (2,), "R": (2, 2), "sensor": (2,)},
    "tracks": {"x": (4,), "P": (4, 4), "sensor": (2,), "plots": ("H",), "ranges": ("H",),
               "times": ("H",), "sigma_r": ("H",)},
}
_NULLABLE = {"ranges", "times", "sigma_r"}  # tracks: NaN (JSON null) where no plot yet


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
    """

    version: int
    config_digest: str
    scans: int
    t: float | None
    next_track: int
    initiators: Initiators
    tracks: Tracks

    def to_json(self) -> dict[str, Any]:
        """Plain lists, numbers and strings (NaN as None); :func:`state_from_json` inverts it."""

        def part(obj: Any) -> dict[str, Any]:
            out = {}
            for f in fields(obj):
                a = getattr(obj, f.name)
                if isinstance(obj, Tracks) and f.name in _NULLABLE:
                    a = np.where(np.isnan(a), None, a.astype(object))
                out[f.name] = a.tolist()
            return out

        return {"version": self.version, "config_digest": self.config_digest,
                "scans": self.scans, "t": self.t, "next_track": self.next_track,
                "initiators": part(self.initiators), "tracks": part(self.tracks)}

    def replace(self, **changes: Any) -> InitiationState:
        return replace(self, **changes)


def _shape(where: str, name: str, history: int) -> tuple[int, ...]:
    return tuple(history if s == "H" else s for s in _SHAPES[where].get(name, ()))


def _empty(cls: type, where: str, history: int) -> Any:
    arrays = {}
    for f in fields(cls):
        shape = _shape(where, f.name, history)
        arrays[f.name] = np.zeros((0, *shape), dtype=_DTYPES.get(f.name, float))
    return cls(**arrays)


def empty_state(config: InitiationConfig) -> InitiationState:
    """The state before the first scan."""
    return InitiationState(STATE_VERSION, config.digest(), 0, None, 0,
                           _empty(Initiators, "initiators", config.history),
                           _empty(Tracks, "tracks", config.history))


def _array(where: str, name: str, value: Any, rows: int | None, history: int) -> np.ndarray:
    dtype = _DTYPES.get(name, float)
    shape = _shape(where, name, history)
    nullable = where == "tracks" and name in _NULLABLE
    try:
        if nullable:
            value = [[np.nan if v is None else v for v in row] for row in value]
        a = np.array(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ParameterError("state", f"{where}.{name} is not a list of numbers ({exc})") from None
    if a.size == 0 and rows in (None, 0):
        a = a.reshape((0, *shape))
    if a.ndim != 1 + len(shape) or a.shape[1:] != shape or (rows is not None
                                                             and a.shape[0] != rows):
        want = f"({rows if rows is not None else 'n'}, {', '.join(map(str, shape))})"
        raise ParameterError("state", f"{where}.{name} must have shape {want.replace(', )', ')')}"
                             f", got {a.shape}")
    if dtype is float and not nullable and not np.isfinite(a).all():
        raise ParameterError("state", f"{where}.{name} must be finite")
    if dtype is bool and not np.isin(np.array(value, dtype=object), [True, False]).all():
        raise ParameterError("state", f"{where}.{name} must be true or false")
    return a


def _part(cls: type, where: str, data: Any, history: int) -> Any:
    if not isinstance(data, dict) or set(data) != {f.name for f in fields(cls)}:
        names = ", ".join(f.name for f in fields(cls))
        raise ParameterError("state", f"{where} must be an object with exactly: {names}")
    rows = None
    arrays = {}
    for f in fields(cls):
        arrays[f.name] = _array(where, f.name, data[f.name], rows, history)
        rows = arrays[f.name].shape[0]
    return cls(**arrays)


def state_from_json(data: Any, config: InitiationConfig) -> InitiationState:
    """Check and rebuild a state from :meth:`InitiationState.to_json` for ``config``.

    Raises
    ------
    ParameterError
        (field ``"state"``) for another version, a state made under other settings, or
        parts that are missing, of the wrong shape or type, or not finite.

    Examples
    --------
    >>> config = InitiationConfig()
    >>> s = state_from_json(empty_state(config).to_json(), config)
    >>> s.scans, s.tracks.size
    (0, 0)
    """
    keys = {"version", "config_digest", "scans", "t", "next_track", "initiators", "tracks"}
    if not isinstance(data, dict) or set(data) != keys:
        raise ParameterError("state", f"must be an object with exactly: {', '.join(sorted(keys))}")
    if data["version"] != STATE_VERSION:
        raise ParameterError("state", f"has version {data['version']!r}; this build reads "
                             f"version {STATE_VERSION}")
    if data["config_digest"] != config.digest():
        raise ParameterError("state", "was made under other settings (config_digest "
                             f"{data['config_digest']!r}, these settings give "
                             f"{config.digest()!r}); a state continues only the session "
                             f"and settings that made it")
    for name in ("scans", "next_track"):
        value = data[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ParameterError("state", f"{name} must be an integer >= 0, got {value!r}")
    t = data["t"]
    if t is not None and (isinstance(t, bool) or not isinstance(t, (int, float))
                          or not np.isfinite(t)):
        raise ParameterError("state", f"t must be a finite time or null, got {t!r}")
    if (t is None) != (data["scans"] == 0):
        raise ParameterError("state", "t must be null exactly when no scan was processed")
    h = config.history
    return InitiationState(STATE_VERSION, data["config_digest"], data["scans"],
                           None if t is None else float(t), data["next_track"],
                           _part(Initiators, "initiators", data["initiators"], h),
                           _part(Tracks, "tracks", data["tracks"], h))
