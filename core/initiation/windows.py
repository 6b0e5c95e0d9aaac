"""Candidate search for polar windows: |r - r_q| <= reach_r and |az - az_q| <= reach_az.

A polar window (a track's range and azimuth windows, or an initiator's first-association
windows) holds the plots of the band of ranges r_q +- reach_r whose azimuth lies within
reach_az of az_q, the difference wrapped to [0, pi]. With the plots sorted by range once
per scan, each window's band is found by two binary searches (:func:`range_bands`); a
compiled loop then reads the band's plots in range order and tests their azimuths
(:func:`window_pairs`: a band counted in vector code, read again only where it holds a
plot, the plots found stored in an array grown by doubling, counted but no longer stored
past a limit). The work is the plots in the bands, known before any is
read, so a caller can send windows whose bands are too full (plots on one ring of range)
to another search.

:func:`in_windows` is the test in numpy on given pairs, and :func:`near_windows_reference`
the whole search by brute force in numpy: the references the kernels are held to, with
the same arithmetic, so the pairs agree exactly. Pairs come sorted by window, then plot.
"""

from __future__ import annotations

import numpy as np

from plotgate.core.compiled import kernel

__all__ = [
    "in_windows",
    "near_windows_reference",
    "range_bands",
    "grown",
    "sort_run",
    "window_pairs",
]

_TWO_PI = 2.0 * np.pi

_BANDS = (
    "float64[:], float64[:], int64[:], int64[:], int64[:], float64[:], float64[:], "
    "float64[:], float64[:]"
)
"""The band search's arguments: the plots' ranges and azimuths in range order and their
indices in the scan; each window's first and last-plus-one plot in that order, its
centre (r, az) and its reaches in range and azimuth."""


def _positions(r_sorted: np.ndarray, keys: np.ndarray, side: str) -> np.ndarray:
    """np.searchsorted of the keys, searched in their own sorted order: a binary search
    that starts where the last one ended is fourteen times quicker than one at random."""
    order = np.argsort(keys)
    found = np.empty(keys.size, dtype=np.int64)
    found[order] = np.searchsorted(r_sorted, keys[order], side=side)  # type: ignore[call-overload]
    return found


def range_bands(
    r_sorted: np.ndarray, r: np.ndarray, reach_r: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each window's band [first, last) among plots sorted by range: r - reach_r <= r_p <=
    r + reach_r (a NaN window gets an empty band)."""
    first = _positions(r_sorted, r - reach_r, "left")
    last = _positions(r_sorted, r + reach_r, "right")
    return first, np.maximum(last, first)


@kernel("boolean(float64, float64, float64, float64, float64, float64, boolean)", inline=True)
def _inside(
    r_p: float, az_p: float, r: float, az: float, reach_r: float, reach_az: float, beyond: bool
) -> bool:
    """Whether a plot lies in one window (the azimuth difference wrapped to [0, pi]).

    ``beyond``: an azimuth of the plots or of the window lies beyond +-pi, so the
    difference may pass a turn (rare: the remainder, and its branch, only then). The rest
    has no branch on the plot's numbers, so a band's loop compiles to vector code: a band
    reads plots in range order, their azimuths at random, and a branch on them would be
    mispredicted every other plot. ``min(d, 2 pi - d)`` is the reference's ``2 pi - d``
    where ``d > pi``, the same double."""
    d_az = abs(az_p - az)
    if beyond and d_az > _TWO_PI:
        d_az %= _TWO_PI
    d_az = min(d_az, _TWO_PI - d_az)
    return (d_az <= reach_az) & (abs(r_p - r) <= reach_r)


@kernel(
    "int64(float64[:], float64[:], int64, int64, float64, float64, float64, float64, boolean)",
    inline=True,
)
def _band_count(
    r_sorted: np.ndarray,
    az_sorted: np.ndarray,
    first: int,
    last: int,
    r: float,
    az: float,
    reach_r: float,
    reach_az: float,
    beyond: bool,
) -> int:
    """The plots of one window's band in the window. Two loops, ``beyond`` known in each:
    a flag tested inside the loop keeps it from vector code (numba leaves the branch in,
    and the band's loop costs three times as much)."""
    count = 0
    if beyond:
        for k in range(first, last):
            count += _inside(r_sorted[k], az_sorted[k], r, az, reach_r, reach_az, True)
    else:
        for k in range(first, last):
            count += _inside(r_sorted[k], az_sorted[k], r, az, reach_r, reach_az, False)
    return count


@kernel("void(int64[:], int64, int64)")
def sort_run(found: np.ndarray, start: int, stop: int) -> None:
    """Insertion sort of found[start:stop] (a few plots)."""
    for i in range(start + 1, stop):
        plot, j = found[i], i - 1
        while j >= start and found[j] > plot:
            found[j + 1] = found[j]
            j -= 1
        found[j + 1] = plot


@kernel("int64[:](int64[:], int64, int64)")
def grown(found: np.ndarray, at: int, limit: int) -> np.ndarray:
    """``found`` with room for a plot at ``at`` (``at < limit``): itself, or a copy twice as
    long, never longer than ``limit``, holding its first ``at`` plots."""
    if at < found.size:
        return found
    bigger = np.empty(min(2 * found.size + 1, limit), dtype=np.int64)
    bigger[:at] = found[:at]
    return bigger


@kernel(f"Tuple((int64[:], int64[:], int64))(int64, {_BANDS})")
def window_pairs(
    limit: int,
    r_sorted: np.ndarray,
    az_sorted: np.ndarray,
    order: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    r: np.ndarray,
    az: np.ndarray,
    reach_r: np.ndarray,
    reach_az: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The plots in each window (its band's plots read in range order: counted, then read
    again to store them where it holds any): each window's count, the plots of window q
    at ``found[offsets[q]:offsets[q + 1]]`` (offsets the counts' cumulative sum) in plot
    order, and the total. Past ``limit`` plots in all the rest are counted, not stored
    (the caller refuses the search)."""
    counts = np.zeros(r.size, dtype=np.int64)
    found = np.empty(min(limit, 2 * r.size + 1024), dtype=np.int64)
    in_turn = np.abs(az_sorted).max() <= np.pi if az_sorted.size else True
    at = 0
    for q in range(r.size):
        beyond = not (in_turn and abs(az[q]) <= np.pi)
        count = _band_count(
            r_sorted, az_sorted, first[q], last[q], r[q], az[q], reach_r[q], reach_az[q], beyond
        )
        counts[q] = count
        if count == 0:  # most windows: the band read once, in vector code
            continue
        start = at
        for k in range(first[q], last[q]):
            if _inside(r_sorted[k], az_sorted[k], r[q], az[q], reach_r[q], reach_az[q], beyond):
                if at < limit:
                    found = grown(found, at, limit)
                    found[at] = order[k]
                at += 1
        if at <= limit:
            sort_run(found, start, at)  # a window has a few plots
    return counts, found[: min(at, limit)], at


def in_windows(
    r_p: np.ndarray,
    az_p: np.ndarray,
    r: np.ndarray,
    az: np.ndarray,
    reach_r: np.ndarray,
    reach_az: np.ndarray,
) -> np.ndarray:
    """The kernels' test in numpy, on pairs (plot p, window) given as equal-length arrays."""
    d_az = np.abs(az_p - az)
    d_az = np.where(d_az > _TWO_PI, d_az % _TWO_PI, d_az)
    d_az = np.where(d_az > np.pi, _TWO_PI - d_az, d_az)
    inside: np.ndarray = (np.abs(r_p - r) <= reach_r) & (d_az <= reach_az)
    return inside


def near_windows_reference(
    plot_r: np.ndarray,
    plot_az: np.ndarray,
    r: np.ndarray,
    az: np.ndarray,
    reach_r: np.ndarray,
    reach_az: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(window, plot) of every plot in every window, by brute force (windows x plots)."""
    window, plot = np.divmod(np.arange(r.size * plot_r.size, dtype=np.int64), plot_r.size)
    keep = in_windows(
        plot_r[plot], plot_az[plot], r[window], az[window], reach_r[window], reach_az[window]
    )
    return window[keep], plot[keep]
