"""A track-initiation state read back from JSON, every field checked against its invariants.

A client holds the state between calls, so a state that comes back may be stale, foreign,
truncated or hostile. :func:`state_from_json` rebuilds it and :func:`check_state` holds
every field to what :func:`plotgate.core.initiation.initiate` itself produces, so nothing
downstream meets a value it cannot handle (a negative miss count indexing the gate
widening, a scan counter whose plot ids overflow int64, a covariance that is not
positive definite):

- the version and the settings' digest; counters within the session's bounds
  (:data:`~plotgate.core.initiation.state.MAX_SESSION_SCANS` scans,
  :data:`~plotgate.core.initiation.state.MAX_TRACK_ID` track ids); ``t`` null exactly before the
  first scan;
- every array of a part with the same number of rows, the tracks' histories
  ``config.history`` wide; integers where ids and counts are, true/false where flags
  are, finite floats (null only in the histories, exactly where no plot is yet);
- ids in range: an initiator's plot id is ``scan * PLOT_STRIDE + index`` for its own
  scan, scans before the state's counter, no plot twice and none both an initiator and a
  track's plot (under score confirmation, a confirmed track's); track ids increasing and
  below ``next_track``;
- a track's history: its plots a suffix of its row (-1 before the first) from
  increasing scans before the counter, as many as it took (``n``, at most the history's
  width), its first scan that of its first plot, ``misses`` the scans since its last
  plot (below ``config.drop_misses``), its times non-decreasing and not after ``t``,
  ``confirmed_scan`` set exactly when confirmed; every track at the state's time;
- domains: ranges at least :data:`~plotgate.core.initiation.scan.MIN_SENSOR_RANGE`, azimuths in
  [-pi, pi], sigmas and costs positive, plot covariances symmetric positive definite
  with core's condition bound, track covariances symmetric positive semi-definite to
  rounding (:data:`ROUNDING`) with positive variances; scores
  finite, 0 under k/m confirmation, an initiator's that of a single plot under score
  and existence confirmation (existence's scores are log-odds of existence);
- against the settings and the plots (:func:`_check_against`; the digest is a plain
  fingerprint anyone can recompute, so a state of other settings under a forged one is
  known by these): speeds within v_max but for
  :data:`~plotgate.core.initiation.filter.SPEED_SIGMAS` of the track's own velocity sigma
  (initiation drops a faster track); covariances no tighter than the track's plots can
  measure; range and cross-range sigmas within a plot's (:class:`PlotBounds`, the
  caller's limits); an initiator's range, azimuth and sigmas those of its z, R and
  sensor; initiators within the capture window; confirmation no sooner than
  confirm_k plots (under k/m within the first confirm_m scans), a tentative track one
  that neither confirms nor drops (its score, or existence, between the thresholds); no
  track twice and none sharing two plots with a confirmed one; one time a scan, the last
  the state's, later scans not earlier.

- the plots the tentative tracks hold (``state.plots``): each tentative track's ``x``
  and ``P`` those its plots make again (:mod:`plotgate.core.initiation.held_checks`);
- last, the seal (:func:`~plotgate.core.initiation.state.seal`): a state whose every
  value passes but whose digest was moved from another state, or whose values were
  changed alone, is refused naming ``state.config_digest``.

Not checked, because a state does not carry what it would take: whether a plot index is
below its scan's real plot count (the wire refuses an index no scan reaches, a request's
MAX_PLOTS or more); whether a state of other settings that is consistent with these was
made under them (such a state is one these settings could have made).

Each refusal names the state's own field, ``state.<name>`` or ``state.<part>.<name>``,
with the row as ``index`` (``state.tracks.misses``, index 3: ``state.tracks.misses[3]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from plotgate.core.errors import CovarianceError, NonFiniteError, ParameterError
from plotgate.core.frames import wrap_angle
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.confirmation import confirmation_rule
from plotgate.core.initiation.existence import log_odds
from plotgate.core.initiation.filter import SPEED_SIGMAS, speed_excess
from plotgate.core.initiation.held_checks import check_held_plots
from plotgate.core.initiation.scan import MIN_SENSOR_RANGE
from plotgate.core.initiation.score import first_plot_score, log_clutter_density, wald_thresholds
from plotgate.core.initiation.sharing import keep_greedy, shares_two
from plotgate.core.initiation.state import (
    MAX_SESSION_SCANS,
    MAX_TRACK_ID,
    NULLABLE,
    PLOT_STRIDE,
    STATE_VERSION,
    HeldPlots,
    InitiationState,
    Initiators,
    Tracks,
    layout,
    seal,
)
from plotgate.core.validation import as_covariance, first_index, require

__all__ = ["MAX_PLOT_ID", "ROUNDING", "PlotBounds", "check_state", "state_from_json"]

MAX_PLOT_ID = MAX_SESSION_SCANS * PLOT_STRIDE
"""Plot ids are below this (2^52)."""


@dataclass(frozen=True)
class PlotBounds:
    """What the caller's plots can be, and so what a state's copies of them and the tracks
    made of them can be.

    Core takes any plot with a positive definite covariance (the defaults bound nothing
    further); the service passes its wire limits, from which a state's bounds follow:

    Attributes
    ----------
    min_variance : float
        Smallest eigenvalue of any plot's covariance, m^2. A range sigma and a cross-range
        sigma (range x azimuth sigma) are at least its root, and a track's covariance is
        no tighter than all its plots' information allows (:func:`check_state`).
    max_sigma : float
        Largest range or cross-range sigma of any plot, m.
    max_time : float
        Largest |t| of a scan, s.
    """

    min_variance: float = 0.0
    max_sigma: float = math.inf
    max_time: float = math.inf


ROUNDING = 1e-12
"""How far below zero, relative to its trace, a track covariance's smallest computed
eigenvalue may lie (rounding of an exactly singular one is about 1e-16)."""
_KEYS = (
    "version",
    "config_digest",
    "scans",
    "t",
    "next_track",
    "initiators",
    "tracks",
    "plots",
    "seal",
)
_KINDS: dict[type, str] = {
    np.int64: "i",
    float: "if",
    bool: "b",
}  # numpy dtype kinds each array accepts
_WHAT: dict[type, str] = {np.int64: "int64 integers", float: "numbers", bool: "true or false"}


def _object(field: str, data: Any, names: tuple[str, ...]) -> None:
    if not isinstance(data, dict):
        raise ParameterError(
            field, f"must be an object with the keys {', '.join(names)}, got {type(data).__name__}"
        )
    for name in names:
        if name not in data:
            raise ParameterError(f"{field}.{name}", "is missing")
    for name in data:
        if name not in names:
            raise ParameterError(
                f"{field}.{name}", f"is not a field of {field} (it has: {', '.join(names)})"
            )


def _integer(field: str, value: Any, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= high:
        raise ParameterError(field, f"must be an integer from 0 to {high}, got {value!r}")
    return value


def _array(
    field: str,
    value: Any,
    dtype: type,
    shape: tuple[int, ...],
    nullable: bool,
    rows: tuple[str, int] | None,
) -> np.ndarray:
    """``value`` as an (n, *shape) array of ``dtype``; ``rows`` (the part's first field and
    its length) fixes n."""
    what = f"must be a list of {_WHAT[dtype]}" + (" or null" if nullable else "")
    try:
        if nullable:
            value = [[np.nan if v is None else v for v in row] for row in value]
        a = np.array(value)
    except (TypeError, ValueError, OverflowError):
        a = None
    empty = a is not None and a.shape == (0,)  # [], whatever the rows' shape
    if (
        a is None
        or not empty
        and (
            a.ndim != 1 + len(shape)
            or a.shape[1:] != shape
            or a.size
            and a.dtype.kind not in _KINDS[dtype]
        )
    ):
        i = _bad_row(value, dtype, shape)
        want = f"(n, {', '.join(map(str, shape))})".replace(", )", ")")
        raise ParameterError(
            field,
            f"{what} shaped {want}"
            if i is None
            else f"row {i} must be {_WHAT[dtype]} shaped {shape}",
            i,
        )
    a = (a.reshape((0, *shape)) if empty else a).astype(dtype)
    if rows is not None and a.shape[0] != rows[1]:
        raise ParameterError(field, f"has {a.shape[0]} rows; {rows[0]} has {rows[1]}")
    if dtype is float:
        bad = np.isinf(a) if nullable else ~np.isfinite(a)
        if bad.any():
            i = first_index(bad.reshape(a.shape[0], -1).any(axis=1))
            raise NonFiniteError(field, f"must be finite, got {a[i].tolist()}", i)
    return a


def _bad_row(value: Any, dtype: type, shape: tuple[int, ...]) -> int | None:
    """The first row of ``value`` that is not an array of ``shape`` of ``dtype``'s kind
    (None if ``value`` is no list, or every row is)."""
    if not isinstance(value, list):
        return None
    for i, row in enumerate(value):  # the error path only
        try:
            a = np.array(row)
        except (TypeError, ValueError, OverflowError):
            return i
        if a.shape != shape or a.size and a.dtype.kind not in _KINDS[dtype]:
            return i
    return None


def _part(cls: type, where: str, data: Any, history: int) -> Any:
    field = f"state.{where}"
    names = tuple(f.name for f in fields(cls))
    _object(field, data, names)
    arrays: dict[str, np.ndarray] = {}
    for name in names:
        dtype, shape = layout(where, name, history)
        rows = None if not arrays else (f"{field}.{names[0]}", len(arrays[names[0]]))
        arrays[name] = _array(
            f"{field}.{name}",
            data[name],
            dtype,
            shape,
            where == "tracks" and name in NULLABLE,
            rows,
        )
    return cls(**arrays)


def _angles_and_sigmas(
    field: str,
    r: np.ndarray | None,
    az: np.ndarray,
    sigma_r: np.ndarray | None,
    sigma_az: np.ndarray,
) -> None:
    if r is not None:
        require(
            f"{field}.r",
            r >= MIN_SENSOR_RANGE,
            lambda i: f"is {r[i]} m; a plot is at least {MIN_SENSOR_RANGE} m from its sensor",
        )
    if sigma_r is not None:
        require(f"{field}.sigma_r", sigma_r > 0, lambda i: f"must be > 0, got {sigma_r[i]}")
    require(
        f"{field}.az",
        np.abs(az) <= np.pi,
        lambda i: f"must be an azimuth in [-pi, pi] rad, got {az[i]}",
    )
    require(f"{field}.sigma_az", sigma_az > 0, lambda i: f"must be > 0, got {sigma_az[i]}")


def _check_initiators(state: InitiationState) -> None:
    ini, f = state.initiators, "state.initiators"
    require(
        f"{f}.plot",
        (ini.plot >= 0) & (ini.plot < MAX_PLOT_ID),
        lambda i: f"is {ini.plot[i]}; plot ids are 0 to {MAX_PLOT_ID - 1}",
    )
    require(
        f"{f}.scan",
        (ini.scan >= 0) & (ini.scan < state.scans),
        lambda i: f"is {ini.scan[i]}; this state has processed scans 0 to {state.scans - 1}",
    )
    as_covariance(f"{f}.R", ini.R)
    _angles_and_sigmas(f, ini.r, ini.az, ini.sigma_r, ini.sigma_az)
    require(
        f"{f}.plot",
        ini.plot // PLOT_STRIDE == ini.scan,
        lambda i: (
            f"is {ini.plot[i]} = scan {ini.plot[i] // PLOT_STRIDE} x "
            f"{PLOT_STRIDE} + index {ini.plot[i] % PLOT_STRIDE}, but its scan is "
            f"{ini.scan[i]}"
        ),
    )
    order = np.argsort(ini.plot, kind="stable")
    again = np.zeros(ini.plot.size, dtype=bool)
    again[order[1:]] = ini.plot[order[1:]] == ini.plot[order[:-1]]
    require(f"{f}.plot", ~again, lambda i: f"repeats plot {ini.plot[i]}")
    require(
        f"{f}.t",
        ini.t <= (state.t if state.t is not None else -np.inf),
        lambda i: f"is {ini.t[i]} s, after the state's time {state.t} s",
    )


def _check_scores(state: InitiationState, config: InitiationConfig) -> None:
    """Scores are 0 under k/m confirmation, which never computes one. Under score
    confirmation an initiator's is that of a single plot: ln(P_D beta_NT / beta_FT) with
    the config's clutter density, or between its values for scans of 1 and PLOT_STRIDE
    plots when the density is estimated. A track's score sums its whole history, which
    the state does not keep: it is held finite (and within the wire's magnitudes)."""
    if config.confirmation in ("score", "existence"):  # existence: the log-odds
        one, most = (
            first_plot_score(config, log_clutter_density(config, n)) for n in (1, PLOT_STRIDE)
        )
        score = state.initiators.score
        require(
            "state.initiators.score",
            (score >= min(one, most)) & (score <= max(one, most)),
            lambda i: (
                f"is {score[i]}; a single plot's score under these settings is "
                + (f"{one}" if one == most else f"between {min(one, most)} and {max(one, most)}")
            ),
        )
        return
    for f, values in (
        ("state.initiators", state.initiators.score),
        ("state.tracks", state.tracks.score),
    ):

        def nonzero(i: int, v: np.ndarray = values) -> str:
            return f"is {v[i]}; scores are 0 under k_of_m confirmation"

        require(f"{f}.score", values == 0.0, nonzero)


def _check_track_values(state: InitiationState, config: InitiationConfig) -> None:
    tr, f = state.tracks, "state.tracks"
    require(
        f"{f}.id",
        (tr.id >= 0) & (tr.id < state.next_track),
        lambda i: f"is {tr.id[i]}; track ids are 0 to next_track - 1 = {state.next_track - 1}",
    )
    scale = np.trace(np.abs(tr.P), axis1=1, axis2=2)
    require(
        f"{f}.P",
        (np.abs(tr.P - np.swapaxes(tr.P, 1, 2)) <= 1e-9 * scale[:, None, None]).all(axis=(1, 2)),
        lambda i: f"is not symmetric: {tr.P[i].tolist()}",
        CovarianceError,
    )
    # positive semi-definite to rounding, with positive variances: initiation's own
    # covariances can be singular in exact arithmetic (a two-point start from a plot of
    # 1e-3 m^2 and one of 1e11 m^2), and eigvalsh then rounds their smallest eigenvalue
    # to about -1e-16 of the trace; a tampered one is off by far more
    low = np.linalg.eigvalsh(tr.P).min(axis=1, initial=np.inf)
    variances = np.diagonal(tr.P, axis1=1, axis2=2)
    require(
        f"{f}.P",
        (low >= -ROUNDING * scale) & (variances > 0).all(axis=1),
        lambda i: (
            f"is not positive definite (smallest eigenvalue {low[i]:.3g}): {tr.P[i].tolist()}"
        ),
        CovarianceError,
    )
    require(f"{f}.n", tr.n >= 2, lambda i: f"is {tr.n[i]}; a track starts with two plots")
    require(
        f"{f}.first_scan",
        (tr.first_scan >= 0) & (tr.first_scan < state.scans),
        lambda i: f"is {tr.first_scan[i]}; this state has processed scans 0 to {state.scans - 1}",
    )
    require(
        f"{f}.confirmed_scan",
        (tr.confirmed_scan >= -1) & (tr.confirmed_scan < state.scans),
        lambda i: f"is {tr.confirmed_scan[i]}; -1 (tentative) or a scan 0 to {state.scans - 1}",
    )
    require(
        f"{f}.misses",
        (tr.misses >= 0) & (tr.misses < config.drop_misses),
        lambda i: (
            f"is {tr.misses[i]}; misses in a row are 0 to drop_misses - 1 = "
            f"{config.drop_misses - 1} (a track with more is dropped)"
        ),
    )
    require(f"{f}.cost", tr.cost >= 0, lambda i: f"must be >= 0, got {tr.cost[i]}")
    present = tr.plots >= 0
    require(
        f"{f}.plots",
        ((tr.plots == -1) | present & (tr.plots < state.scans * PLOT_STRIDE)).all(axis=1),
        lambda i: (
            f"holds ids outside -1 and the scans so far "
            f"(0 to {state.scans - 1}): {tr.plots[i].tolist()}"
        ),
    )
    for name, ok in (("ranges", tr.ranges >= MIN_SENSOR_RANGE), ("sigma_r", tr.sigma_r > 0)):
        values: np.ndarray = getattr(tr, name)

        def out_of_domain(i: int, v: np.ndarray = values, n: str = name) -> str:
            return (
                f"holds a {n} out of its domain "
                f"(ranges >= {MIN_SENSOR_RANGE} m, sigmas > 0): {v[i].tolist()}"
            )

        require(f"{f}.{name}", (ok | np.isnan(values)).all(axis=1), out_of_domain)
    _angles_and_sigmas(f, None, tr.az, None, tr.sigma_az)


def _check_track_histories(state: InitiationState) -> None:
    """A track's history: ids increasing, every track at the state's time, its plots a
    suffix of its row from increasing scans, as many as ``n`` (at most the width), its
    first scan that of its oldest plot; then its counters (:func:`_check_track_counters`)."""
    tr, f = state.tracks, "state.tracks"
    H = tr.plots.shape[1]
    present = tr.plots >= 0
    require(
        f"{f}.id",
        np.r_[True, tr.id[1:] > tr.id[:-1]],
        lambda i: f"is {tr.id[i]}, not above the id before it ({tr.id[i - 1]}); ids increase",
    )
    require(
        f"{f}.t",
        tr.t == (state.t if state.t is not None else np.nan),
        lambda i: f"is {tr.t[i]} s; every track is at the state's time {state.t} s",
    )
    require(
        f"{f}.plots",
        (present[:, 1:] >= present[:, :-1]).all(axis=1),
        lambda i: f"has a plot before a -1: {tr.plots[i].tolist()}; -1 only before the first plot",
    )
    scan = np.where(present, tr.plots // PLOT_STRIDE, -1)
    require(
        f"{f}.plots",
        (~present[:, 1:] | (scan[:, 1:] > scan[:, :-1])).all(axis=1),
        lambda i: f"holds plots not from increasing scans: {tr.plots[i].tolist()}",
    )
    count = present.sum(axis=1)
    require(
        f"{f}.n",
        count == np.minimum(tr.n, H),
        lambda i: f"is {tr.n[i]}, but plots[{i}] holds {count[i]} plots of a history of {H}",
    )
    require(
        f"{f}.n",
        tr.n <= state.scans - tr.first_scan,
        lambda i: (
            f"is {tr.n[i]}: more plots than scans since its first scan "
            f"{tr.first_scan[i]} ({state.scans - tr.first_scan[i]})"
        ),
    )
    oldest = scan[np.arange(tr.size), H - np.maximum(count, 1)]
    require(
        f"{f}.first_scan",
        np.where(tr.n <= H, tr.first_scan == oldest, tr.first_scan < oldest),
        lambda i: (
            f"is {tr.first_scan[i]}, but its oldest plot in history is from "
            f"scan {oldest[i]} ({tr.n[i]} plots, history {H})"
        ),
    )
    _check_track_counters(state, scan, present)


def _check_track_counters(state: InitiationState, scan: np.ndarray, present: np.ndarray) -> None:
    """A track's counters and nulls as its history shows them: ``confirmed_scan`` set
    exactly when confirmed and not before its first scan, ``misses`` the scans since its
    last plot, null exactly where no plot is, times non-decreasing and not after the
    state's; ``scan`` (m, H) holds each history plot's scan (-1 where none)."""
    tr, f = state.tracks, "state.tracks"
    require(
        f"{f}.confirmed_scan",
        (tr.confirmed_scan >= 0) == tr.confirmed,
        lambda i: (
            f"is {tr.confirmed_scan[i]} for a "
            f"{'confirmed' if tr.confirmed[i] else 'tentative'} track (-1 exactly while "
            "tentative)"
        ),
    )
    require(
        f"{f}.confirmed_scan",
        ~tr.confirmed | (tr.confirmed_scan >= tr.first_scan),
        lambda i: f"is {tr.confirmed_scan[i]}, before its first scan {tr.first_scan[i]}",
    )
    since = state.scans - 1 - scan[:, -1]
    require(
        f"{f}.misses",
        tr.misses == since,
        lambda i: (
            f"is {tr.misses[i]}, but its last plot is from scan {scan[i, -1]}, "
            f"{since[i]} scans before the last one"
        ),
    )
    for name in sorted(NULLABLE):
        values: np.ndarray = getattr(tr, name)

        def misplaced(i: int, v: np.ndarray = values) -> str:
            return (
                f"must be null exactly where plots[{i}] is -1: "
                f"{v[i].tolist()} against {tr.plots[i].tolist()}"
            )

        require(f"{f}.{name}", (np.isnan(values) == ~present).all(axis=1), misplaced)
    times = np.where(present, tr.times, -np.inf)
    require(
        f"{f}.times",
        (times[:, 1:] >= times[:, :-1]).all(axis=1)
        & (times[:, -1] <= (state.t if state.t is not None else -np.inf)),
        lambda i: (
            f"must be non-decreasing and not after the state's time {state.t} s: "
            f"{tr.times[i].tolist()}"
        ),
    )


def _within(field: str, values: np.ndarray, low: float, high: float, what: str) -> None:
    """Every value (NaN, where no plot is, aside) in [low, high]; rows of a history at once."""
    ok = (values >= low) & (values <= high) | np.isnan(values)
    require(
        field,
        ok.all(axis=1) if ok.ndim == 2 else ok,
        lambda i: (
            f"makes a {what} sigma of {values[i].tolist()} m; a plot's is {low:.3g} to "
            f"{high:.3g} m"
        ),
    )


def _check_sigmas(state: InitiationState, bounds: PlotBounds) -> None:
    """A state's plots' sigmas within the plots' own: the range sigma, and the azimuth
    sigma as the cross-range sigma it makes at the plot's range (an azimuth sigma alone
    has no bound: a Cartesian plot 1 m from its sensor may have one of 10^9 rad)."""
    low, high = math.sqrt(bounds.min_variance), bounds.max_sigma
    ini, tr = state.initiators, state.tracks
    _within("state.initiators.sigma_r", ini.sigma_r, low, high, "range")
    _within("state.initiators.sigma_az", ini.r * ini.sigma_az, low, high, "cross-range")
    _within("state.tracks.sigma_r", tr.sigma_r, low, high, "range")
    _within("state.tracks.sigma_az", tr.ranges[:, -1] * tr.sigma_az, low, high, "cross-range")


def _check_polar_copies(state: InitiationState) -> None:
    """An initiator's range, azimuth and sigmas are its z, R and sensor seen from the
    sensor (a scan derives each form from the other once), so a copy changed alone
    disagrees. Tolerances: 1e-9 of the distances involved for the range and for the
    azimuth's cross-range, 1e-9 of trace R for the variances (one conversion rounds at
    about 1e-16 of them)."""
    ini, f = state.initiators, "state.initiators"
    rel = ini.z - ini.sensor
    r, az = np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 0], rel[:, 1])
    near = 1e-9 * (np.abs(ini.z).sum(axis=1) + np.abs(ini.sensor).sum(axis=1) + ini.r)
    require(
        f"{f}.r",
        np.abs(ini.r - r) <= near,
        lambda i: f"is {ini.r[i]} m, but its z is {r[i]} m from its sensor",
    )
    require(
        f"{f}.az",
        np.abs(wrap_angle(ini.az - az)) * ini.r <= near,
        lambda i: f"is {ini.az[i]} rad, but its z is at {az[i]} rad from its sensor",
    )
    radial = np.column_stack([np.sin(ini.az), np.cos(ini.az)])
    across = np.column_stack([radial[:, 1], -radial[:, 0]])
    tolerance = 1e-9 * np.trace(ini.R, axis1=1, axis2=2)
    for name, sigma, axis in (
        ("sigma_r", ini.sigma_r, radial),
        ("sigma_az", ini.r * ini.sigma_az, across),
    ):
        variance = np.einsum("ni,nij,nj->n", axis, ini.R, axis)

        def disagrees(i: int, s: np.ndarray = sigma, v: np.ndarray = variance) -> str:
            return f"makes a sigma of {s[i]} m where its R gives {np.sqrt(v[i])} m"

        require(f"{f}.{name}", np.abs(sigma**2 - variance) <= tolerance, disagrees)


def _check_information(state: InitiationState, config: InitiationConfig, b: PlotBounds) -> None:
    """No track knows more than its plots tell. Its covariance is at least the inverse of
    the information of its n plots and the velocity prior (score confirmation), whatever
    the filter (a Kalman filter attains the bound, the alpha-beta gains do worse):
    J <= sum_i H_i^T R_i^-1 H_i + 4 / v_max^2, with H_i = [I, dt_i I], |dt_i| <= 2 max_time
    and R_i >= min_variance, so each diagonal element of P is at least 1 / lambda_max(J).
    Loose (10^-39 for three plots under the wire's limits) but it refuses a covariance no
    measurement could give (P = 1e-300 I)."""
    if b.min_variance <= 0.0 or not math.isfinite(b.max_time):
        return
    tr = state.tracks
    with np.errstate(over="ignore", divide="ignore"):
        prior = 4.0 / np.float64(config.v_max) ** 2
        most = tr.n * ((1.0 + (2.0 * b.max_time) ** 2) / b.min_variance) + prior
    floor = 1.0 / most
    diagonal = np.diagonal(tr.P, axis1=1, axis2=2)
    require(
        "state.tracks.P",
        (diagonal >= floor[:, None]).all(axis=1),
        lambda i: (
            f"has variances {diagonal[i].tolist()}: tighter than {tr.n[i]} plots can "
            f"measure (each at least {floor[i]:.3g})"
        ),
        CovarianceError,
    )


def _check_speeds(state: InitiationState, config: InitiationConfig) -> None:
    """Speeds within v_max but for SPEED_SIGMAS of the track's own velocity sigma, as
    initiation keeps them (it drops a faster track, reason "speed")."""
    tr = state.tracks
    excess = speed_excess(tr.x, tr.P, config.v_max)
    require(
        "state.tracks.x",
        excess <= SPEED_SIGMAS,
        lambda i: (
            f"is {tr.x[i].tolist()}: a speed {excess[i]:.3g} of its velocity sigmas above "
            f"v_max = {config.v_max} m/s (at most {SPEED_SIGMAS:g}; initiation drops a "
            "faster track)"
        ),
    )


def _check_confirmation(state: InitiationState, config: InitiationConfig) -> None:
    """Confirmation as the settings' rule allows it: no sooner than confirm_k plots (and,
    under k/m, within the first confirm_m scans); a tentative track one that neither
    confirms nor drops under these settings."""
    tr, f, k = state.tracks, "state.tracks", config.confirm_k
    earliest = tr.first_scan + k - 1
    require(
        f"{f}.confirmed_scan",
        ~tr.confirmed | (tr.confirmed_scan >= earliest),
        lambda i: (
            f"is {tr.confirmed_scan[i]}, but a track first seen in scan {tr.first_scan[i]} "
            f"holds confirm_k = {k} plots in scan {earliest[i]} at the soonest"
        ),
    )
    if config.confirmation == "score":
        _check_tentative_scores(state, config)
        return
    if config.confirmation == "existence":
        _check_tentative_existence(state, config)
        return
    latest = tr.first_scan + config.confirm_m - 1
    require(
        f"{f}.confirmed_scan",
        ~tr.confirmed | (tr.confirmed_scan <= latest),
        lambda i: (
            f"is {tr.confirmed_scan[i]}, but k/m confirms within the first confirm_m = "
            f"{config.confirm_m} scans of a track (its first is {tr.first_scan[i]})"
        ),
    )
    age = state.scans - tr.first_scan  # scans from its first to the last, both counted
    require(
        f"{f}.n",
        tr.confirmed | (tr.n < k) | (age > config.confirm_m),
        lambda i: (
            f"is {tr.n[i]} for a tentative track {age[i]} scans old; with confirm_k = {k} "
            f"within confirm_m = {config.confirm_m} scans it is confirmed"
        ),
    )
    reach = tr.n + config.confirm_m - age
    require(
        f"{f}.first_scan",
        tr.confirmed | (reach >= k),
        lambda i: (
            f"is {tr.first_scan[i]}: a tentative track of {tr.n[i]} plots that can no longer "
            f"reach confirm_k = {k} within confirm_m = {config.confirm_m} scans is dropped"
        ),
    )


def _check_tentative_scores(state: InitiationState, config: InitiationConfig) -> None:
    tr = state.tracks
    confirm_at, delete_at = wald_thresholds(config)
    require(
        "state.tracks.score",
        tr.confirmed | (tr.score > delete_at),
        lambda i: f"is {tr.score[i]}; a tentative track at or below {delete_at} is dropped",
    )
    require(
        "state.tracks.score",
        tr.confirmed | (tr.n < config.confirm_k) | (tr.score < confirm_at),
        lambda i: (
            f"is {tr.score[i]} with {tr.n[i]} plots; a tentative track at {confirm_at} with "
            f"confirm_k = {config.confirm_k} plots is confirmed"
        ),
    )


def _check_tentative_existence(state: InitiationState, config: InitiationConfig) -> None:
    """Existence confirmation: a tentative track's log-odds of existence lie above the
    deletion threshold's and, with confirm_k plots or more, below the confirmation's
    (ln(tau / (1 - tau)) of existence_delete and existence_confirm); else initiation
    would have dropped or confirmed it."""
    tr = state.tracks
    confirm_at, delete_at = (
        log_odds(config.existence_confirm),
        log_odds(config.existence_delete),
    )
    require(
        "state.tracks.score",
        tr.confirmed | (tr.score > delete_at),
        lambda i: (
            f"is {tr.score[i]}: log-odds of existence at or below {delete_at} "
            f"(existence_delete = {config.existence_delete}); such a tentative track is dropped"
        ),
    )
    require(
        "state.tracks.score",
        tr.confirmed | (tr.n < config.confirm_k) | (tr.score < confirm_at),
        lambda i: (
            f"is {tr.score[i]} with {tr.n[i]} plots: log-odds of existence at or above "
            f"{confirm_at} (existence_confirm = {config.existence_confirm}) with confirm_k "
            f"= {config.confirm_k} plots; such a tentative track is confirmed"
        ),
    )


def _check_windows(state: InitiationState, config: InitiationConfig) -> None:
    """Initiators within the settings' capture window (2/N or 2/T): older ones expire."""
    ini = state.initiators
    if config.capture_time is None:
        require(
            "state.initiators.scan",
            ini.scan > state.scans - config.capture_scans,
            lambda i: (
                f"is {ini.scan[i]}: past the capture window of capture_scans = "
                f"{config.capture_scans} (scans after {state.scans - config.capture_scans})"
            ),
        )
        return
    now = state.t if state.t is not None else np.inf
    require(
        "state.initiators.t",
        now - ini.t < config.capture_time,
        lambda i: (
            f"is {ini.t[i]} s: past the capture window of capture_time = "
            f"{config.capture_time} s before the state's time {state.t} s"
        ),
    )


def _check_sharing(state: InitiationState, config: InitiationConfig) -> None:
    """The plot-reuse rules hold: no track twice (two rows holding the same whole history),
    no track sharing two or more plots with a confirmed one. Initiation keeps both: it
    starts one track per (initiator, plot) and prunes a track that shares two plots with
    a confirmed one. A row longer than its history may match another's (their first plots
    differ, out of sight)."""
    tr = state.tracks
    rows = np.flatnonzero(tr.n <= config.history)
    again = np.zeros(tr.size, dtype=bool)
    if rows.size:
        _, first, inverse = np.unique(
            tr.plots[rows], axis=0, return_index=True, return_inverse=True
        )
        again[rows] = first[inverse.ravel()] != np.arange(rows.size)
    require(
        "state.tracks.plots",
        ~again,
        lambda i: f"is {tr.plots[i].tolist()}, the whole history of another track: a duplicate",
    )
    confirmed, tentative = np.flatnonzero(tr.confirmed), np.flatnonzero(~tr.confirmed)
    clash = np.zeros(tr.size, dtype=bool)
    clash[confirmed] = ~keep_greedy(tr.plots[confirmed])
    clash[tentative] = shares_two(tr.plots[tentative], tr.plots[confirmed])
    require(
        "state.tracks.plots",
        ~clash,
        lambda i: (
            f"is {tr.plots[i].tolist()}, sharing two or more plots with a confirmed track "
            "(initiation prunes such a track)"
        ),
    )


def _scan_times(scan: np.ndarray, t: np.ndarray, state: InitiationState) -> np.ndarray:
    """Per plot, its scan's time: the state's for the last scan, else the time most of the
    scan's plots in the state carry (of equally many, the earliest); NaN for a scan whose
    time comes before an earlier scan's (scans come in time order)."""
    order = np.lexsort((t, scan))
    s, u = scan[order], t[order]
    start = np.flatnonzero(np.r_[True, (s[1:] != s[:-1]) | (u[1:] != u[:-1])])
    length = np.diff(np.r_[start, s.size])
    pick = np.lexsort((-length, s[start]))  # per scan, its longest run of one time first
    pick = pick[np.r_[True, s[start][pick][1:] != s[start][pick][:-1]]]
    scans, times = s[start][pick], u[start][pick]
    if state.t is not None:
        times[scans == state.scans - 1] = state.t
    times[1:][times[1:] < np.maximum.accumulate(times)[:-1]] = np.nan
    expected: np.ndarray = times[np.searchsorted(scans, scan)]
    return expected


def _check_scan_times(state: InitiationState) -> None:
    """Every plot of one scan has that scan's time, the last scan's the state's, and a
    later scan is not earlier: a plot id moved to another scan (its index past its own
    scan's plots) shows as a time out of place."""
    ini, tr = state.initiators, state.tracks
    present = tr.plots >= 0
    track, _ = np.nonzero(present)
    scan = np.concatenate([ini.scan, tr.plots[present] // PLOT_STRIDE])
    t = np.concatenate([ini.t, tr.times[present]])
    if scan.size == 0:
        return
    expected = _scan_times(scan, t, state)
    off = t != expected
    if not off.any():
        return
    j = first_index(off)
    assert j is not None
    field, row = (
        ("state.initiators.t", j)
        if j < ini.plot.size
        else ("state.tracks.times", track[j - ini.plot.size])
    )
    raise ParameterError(
        field,
        f"puts a plot of scan {scan[j]} at {t[j]} s, where that scan is at "
        f"{expected[j]} s (one time a scan, the last one the state's, later scans not "
        "earlier)",
        int(row),
    )


def _check_against(state: InitiationState, config: InitiationConfig, bounds: PlotBounds) -> None:
    """What a state that is well formed must also be to come from these settings and these
    plots: the digest is a fingerprint anyone can recompute, not a signature, so a state
    of other settings under a forged one is known by its contents."""
    _check_sigmas(state, bounds)
    _check_polar_copies(state)
    _check_information(state, config, bounds)
    _check_speeds(state, config)
    _check_windows(state, config)
    _check_confirmation(state, config)
    _check_sharing(state, config)
    _check_scan_times(state)


def check_state(
    state: InitiationState, config: InitiationConfig, bounds: PlotBounds = PlotBounds()
) -> None:
    """Check a state against every invariant of the states :func:`initiate` produces.

    Parameters
    ----------
    state : InitiationState
        Its arrays already of the right dtypes and shapes (as :func:`state_from_json`
        builds them).
    config : InitiationConfig
        The settings the state must have been made under.
    bounds : PlotBounds
        What the caller's plots can be (the default: any plot core takes).

    Raises
    ------
    ParameterError, NonFiniteError, CovarianceError
        Naming the offending field (``state.tracks.misses``) and row (``index``).

    Examples
    --------
    >>> from plotgate.core.initiation.state import empty_state
    >>> config = InitiationConfig()
    >>> state = empty_state(config)
    >>> check_state(state, config)
    >>> try:
    ...     check_state(state.replace(scans=1), config)
    ... except ParameterError as exc:
    ...     print(exc.field, "|", exc.reason)
    state.t | must be null exactly when no scan was processed (scans 1)
    """
    if state.version != STATE_VERSION:
        raise ParameterError(
            "state.version", f"is {state.version!r}; this build reads version {STATE_VERSION}"
        )
    if state.config_digest != config.digest():
        raise ParameterError(
            "state.config_digest",
            f"is {state.config_digest!r}: the state "
            f"was made under other settings (these give "
            f"{config.digest()!r}); a state continues only the session and "
            "settings that made it",
        )
    _integer("state.scans", state.scans, MAX_SESSION_SCANS)
    _integer("state.next_track", state.next_track, MAX_TRACK_ID)
    if (state.t is None) != (state.scans == 0):
        raise ParameterError(
            "state.t", f"must be null exactly when no scan was processed (scans {state.scans})"
        )
    _check_initiators(state)
    _check_track_values(state, config)
    _check_scores(state, config)
    _check_track_histories(state)
    rule = confirmation_rule(config)  # under the score only confirmed tracks own plots
    taken = np.isin(state.initiators.plot, rule.held(state.tracks))
    require(
        "state.initiators.plot",
        ~taken,
        lambda i: (
            f"is {state.initiators.plot[i]}, a plot a {rule.holders} holds; an initiator "
            f"is a plot no {rule.holders} took"
        ),
    )
    _check_against(state, config, bounds)
    check_held_plots(state, config)


def _check_seal(data: dict[str, Any]) -> None:
    """The seal of what was read: a state whose values all pass but whose digest came
    from another state (or any value changed alone) no longer matches its seal."""
    if not isinstance(data["seal"], str):
        raise ParameterError("state.seal", f"must be a string, got {data['seal']!r}")
    if data["seal"] != seal(data):
        raise ParameterError(
            "state.config_digest",
            f"is {data['config_digest']!r}, but the state's seal {data['seal']!r} is not "
            "that of its digest and values: the state was made under other settings, or "
            "changed since it was answered",
        )


def state_from_json(
    data: Any, config: InitiationConfig, bounds: PlotBounds = PlotBounds()
) -> InitiationState:
    """Rebuild a state from :meth:`InitiationState.to_json` and check it for ``config``.

    Parameters
    ----------
    data : dict
        The JSON object a previous call returned.
    config : InitiationConfig
        The settings of this call; the state must have been made under them.
    bounds : PlotBounds
        What the caller's plots can be (the default: any plot core takes).

    Returns
    -------
    state : InitiationState

    Raises
    ------
    ParameterError, NonFiniteError, CovarianceError
        For a missing or unknown key, a value of the wrong type or shape, or one that
        breaks an invariant (:func:`check_state`); ``field`` names it (``state.scans``,
        ``state.tracks.misses``) and ``index`` its row.

    Examples
    --------
    >>> from plotgate.core.initiation.state import empty_state
    >>> config = InitiationConfig()
    >>> s = state_from_json(empty_state(config).to_json(), config)
    >>> s.scans, s.tracks.size
    (0, 0)
    """
    _object("state", data, _KEYS)
    version = data["version"]
    if isinstance(version, bool) or not isinstance(version, int) or version != STATE_VERSION:
        raise ParameterError(
            "state.version", f"is {data['version']!r}; this build reads version {STATE_VERSION}"
        )
    if not isinstance(data["config_digest"], str):
        raise ParameterError(
            "state.config_digest", f"must be a string, got {data['config_digest']!r}"
        )
    t = data["t"]
    if t is not None and (
        isinstance(t, bool) or not isinstance(t, (int, float)) or not np.isfinite(t)
    ):
        raise ParameterError("state.t", f"must be a finite time or null, got {t!r}")
    h = config.history
    state = InitiationState(
        STATE_VERSION,
        data["config_digest"],
        _integer("state.scans", data["scans"], MAX_SESSION_SCANS),
        None if t is None else float(t),
        _integer("state.next_track", data["next_track"], MAX_TRACK_ID),
        _part(Initiators, "initiators", data["initiators"], h),
        _part(Tracks, "tracks", data["tracks"], h),
        _part(HeldPlots, "plots", data["plots"], h),
    )
    check_state(state, config, bounds)
    _check_seal(data)
    return state
