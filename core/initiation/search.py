"""Candidate search: which plots of a scan may lie in a gate.

A query is a centre and a radius that bounds one gate (a track's or an initiator's); the
search returns every (query, plot) pair within it, so the work grows with the plots near
each gate, not with all plots. The gates then test the candidates exactly
(:mod:`plotgate.core.initiation.pairs`).

:func:`near_pairs` is a compiled uniform-grid search: plots sorted by grid cell (the cell
as wide as the bin's largest radius), each query scanning the 3 x 3 cells about its
centre. :func:`near_pairs_reference` is the same search with scipy's ``cKDTree``, the
tested oracle. Both return the pairs sorted by query, then plot, so the order depends on
neither the tree's traversal nor the grid.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plotgate.core.compiled import kernel
from plotgate.core.errors import ParameterError
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.windows import (
    grown,
    in_windows,
    range_bands,
    sort_run,
    window_pairs,
)

__all__ = [
    "BAND_WORK",
    "MAX_CANDIDATES",
    "PlotIndex",
    "cell_order",
    "cell_order_reference",
    "near_pairs",
    "near_pairs_reference",
]

MAX_CANDIDATES = 2**24
"""Most candidate (track or initiator, plot) pairs one search may return (about 400 MB):
plots so dense that every gate holds hundreds (a thousand targets at one spot) would
otherwise grow tentative tracks, and their pairs, without bound. Over it the scan is
refused (ParameterError on ``scans``)."""
BAND_WORK = 2**22
"""Most plots the polar windows' range bands may hold in all, beyond 64 a plot and a window,
before the windows go to the grid search: reading a band costs a few nanoseconds a plot,
so this bounds the read at some tens of milliseconds, whatever the plots' layout."""


def _too_many(count: int) -> ParameterError:
    return ParameterError(
        "scans",
        f"{count} candidate (track, plot) pairs in one search, more than "
        f"{MAX_CANDIDATES}: the plots are too dense for the gates",
    )


def _radius_bins(radius: np.ndarray) -> np.ndarray:
    """Bins of radii within a factor 1.5 of each other (each bin is searched on its own)."""
    smallest = max(float(radius.min()), 1e-9)
    bins: np.ndarray = np.floor(
        np.log(np.maximum(radius, smallest) / smallest) / np.log(1.5)
    ).astype(np.int64)
    return bins


def _sorted_pairs(rows: list[np.ndarray], cols: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    r = np.concatenate(rows).astype(np.int64)
    c = np.concatenate(cols).astype(np.int64)
    order = np.lexsort((c, r))
    return r[order], c[order]


def near_pairs_reference(
    points: np.ndarray, centres: np.ndarray, radius: np.ndarray, p: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`near_pairs` by scipy's ``cKDTree``: the oracle the compiled search is held to.

    Queries go in bins of radii within a factor 1.5, each bin one
    ``sparse_distance_matrix`` between a tree of its centres and a tree of the points,
    then the exact per-query radius.
    """
    if centres.shape[0] == 0 or points.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    tree = cKDTree(points)
    bins = _radius_bins(radius)
    rows, cols = [], []
    for b in np.unique(bins):
        idx = np.flatnonzero(bins == b)
        found = cKDTree(centres[idx]).sparse_distance_matrix(
            tree, float(radius[idx].max()), p=p, output_type="ndarray"
        )
        i = idx[found["i"]]
        keep = found["v"] <= radius[i]
        rows.append(i[keep])
        cols.append(found["j"][keep])
    r, c = _sorted_pairs(rows, cols)
    if r.size > MAX_CANDIDATES:
        raise _too_many(int(r.size))
    return r, c


_GRID = (
    "int64[:], int64[:], int64[:], float64[:, :], int64, int64[:, :], float64[:, :], "
    "float64[:], boolean"
)
"""The grid search's arguments: the plots' cell keys (x cell times ny plus y cell) in
ascending order, where each x column starts among them (one entry past the last), the
plots in that order, the plots, cells along y, each query's cell and centre and radius,
Chebyshev (else Euclidean)."""


@kernel("UniTuple(int64, 2)(int64[:], int64[:], int64, int64, int64)")
def _cell_span(
    keys: np.ndarray, columns: np.ndarray, ny: int, cx: int, cy: int
) -> tuple[int, int]:
    """Where the plots of cells (cx, cy - 1) to (cx, cy + 1) lie among the sorted keys."""
    column = keys[columns[cx] : columns[cx + 1]]
    first = columns[cx] + np.searchsorted(column, cx * ny + max(cy - 1, 0))
    last = columns[cx] + np.searchsorted(column, cx * ny + min(cy + 2, ny))
    return first, last


@kernel("boolean(float64[:], float64[:], float64, boolean)")
def _near(point: np.ndarray, centre: np.ndarray, radius: float, chebyshev: bool) -> bool:
    """Whether the point lies within radius of the centre (Chebyshev or Euclidean)."""
    ex, ey = point[0] - centre[0], point[1] - centre[1]
    if chebyshev:
        return bool(max(abs(ex), abs(ey)) <= radius)
    return bool(np.sqrt(ex * ex + ey * ey) <= radius)


@kernel("Tuple((int64[:], int64[:]))(int64[:, :], int64, int64)")
def cell_order(cell: np.ndarray, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """The plots in order of their cell key (x cell times ny plus y cell; ties by index,
    as a stable argsort), by two counting sorts (by y cell, then by x cell), and where
    each x column starts in that order (one entry past the last)."""
    n = cell.shape[0]
    by_y = np.zeros(ny + 1, dtype=np.int64)
    for i in range(n):
        by_y[cell[i, 1] + 1] += 1
    by_y = np.cumsum(by_y)
    rows = np.empty(n, dtype=np.int64)
    for i in range(n):
        rows[by_y[cell[i, 1]]] = i
        by_y[cell[i, 1]] += 1
    columns = np.zeros(nx + 1, dtype=np.int64)
    for i in range(n):
        columns[cell[i, 0] + 1] += 1
    columns = np.cumsum(columns)
    at = columns[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for plot in rows:
        order[at[cell[plot, 0]]] = plot
        at[cell[plot, 0]] += 1
    return order, columns


def cell_order_reference(cell: np.ndarray, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cell_order` by numpy: a stable argsort of the keys, and a binary search of
    each column's first key."""
    key = cell[:, 0] * ny + cell[:, 1]
    order = np.argsort(key, kind="stable")
    columns = np.searchsorted(key[order], np.arange(nx + 1, dtype=np.int64) * ny)
    return order.astype(np.int64), columns.astype(np.int64)


@kernel(f"Tuple((int64[:], int64[:], int64))(int64, {_GRID})")
def _grid_pairs(
    limit: int,
    keys: np.ndarray,
    columns: np.ndarray,
    order: np.ndarray,
    points: np.ndarray,
    ny: int,
    cells: np.ndarray,
    centres: np.ndarray,
    radius: np.ndarray,
    chebyshev: bool,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The pairs within each query's radius, from the 3 x 3 cells about its own, in one
    pass: each query's count, the plots of query q at ``found[offsets[q]:offsets[q + 1]]``
    (offsets the counts' cumulative sum) in plot order, and the total. Past ``limit`` pairs
    in all the rest are counted, not stored (the caller refuses the search)."""
    counts = np.zeros(cells.shape[0], dtype=np.int64)
    found = np.empty(min(limit, 2 * cells.shape[0] + 1024), dtype=np.int64)
    at = 0
    for q in range(cells.shape[0]):
        start = at
        for cx in range(max(cells[q, 0] - 1, 0), min(cells[q, 0] + 2, columns.size - 1)):
            first, last = _cell_span(keys, columns, ny, cx, cells[q, 1])
            for k in range(first, last):
                if _near(points[order[k]], centres[q], radius[q], chebyshev):
                    if at < limit:
                        found = grown(found, at, limit)
                        found[at] = order[k]
                    at += 1
        counts[q] = at - start
        if at <= limit:
            sort_run(found, start, at)  # a query has a few plots
    return counts, found[: min(at, limit)], at


def _grid_search(
    points: np.ndarray, centres: np.ndarray, radius: np.ndarray, chebyshev: bool, counted: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """One bin's pairs on a grid of cells as wide as its largest radius; None when the
    plots spread over more columns of cells than four a plot, or more cells than integer
    keys hold exactly (the tree searches those). The plots are put in cell order by two
    counting sorts (:func:`cell_order`) when the rows of cells are as few as the columns
    may be, else by an argsort of their keys (:func:`cell_order_reference`)."""
    width = max(float(radius.max()), 1e-9)
    low = points.min(axis=0)
    extent = np.floor((points.max(axis=0) - low) / width) + 1.0
    few = 4 * points.shape[0] + 2**16
    if extent[0] > few or extent[0] * extent[1] > 2.0**52:
        return None
    nx, ny = int(extent[0]), int(extent[1])
    cell = np.floor((points - low) / width).astype(np.int64)
    order, columns = (cell_order if ny <= few else cell_order_reference)(cell, nx, ny)
    keys = cell[order, 0] * ny + cell[order, 1]
    # a query's cell, clipped one cell beyond the grid: its 3 x 3 block then holds no plot
    query = np.clip(np.floor((centres - low) / width), -2.0, extent + 1.0).astype(np.int64)
    centres = np.ascontiguousarray(centres, dtype=float)
    radius = np.ascontiguousarray(radius, dtype=float)
    grid = (keys, columns, order, points, ny, query, centres, radius, chebyshev)
    counts, found, total = _grid_pairs(MAX_CANDIDATES - counted, *grid)
    if counted + total > MAX_CANDIDATES:
        raise _too_many(counted + total)
    return np.repeat(np.arange(centres.shape[0]), counts), found


def near_pairs(
    points: np.ndarray, centres: np.ndarray, radius: np.ndarray, p: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, point) pairs with points[point] within radius[row] of centres[row], sorted.

    ``p`` is the norm: 2 (Euclidean) or ``inf`` (Chebyshev). Queries go in bins of radii
    within a factor 1.5; each bin is searched on a uniform grid of cells as wide as its
    largest radius, so a query reads the plots of the 3 x 3 cells about its centre (a
    compiled loop: the plots sorted by cell, each column's found by its start, each
    cell's by a binary search in its column; no tree to build). A bin whose plots spread
    over more columns than four a plot (far wider than the gates) goes to the tree
    (:func:`near_pairs_reference`). The pairs are found in one pass, stored in an array
    grown by doubling, and only counted past :data:`MAX_CANDIDATES`.

    Raises
    ------
    ParameterError
        ``"scans"`` when a search holds more than :data:`MAX_CANDIDATES` pairs.
    """
    if centres.shape[0] == 0 or points.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    points = np.ascontiguousarray(points, dtype=float)
    bins = _radius_bins(radius)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    counted = 0
    for b in np.unique(bins):
        idx = np.flatnonzero(bins == b)
        found = _grid_search(points, centres[idx], radius[idx], p == np.inf, counted)
        if found is None:
            found = near_pairs_reference(points, centres[idx], radius[idx], p)
        rows.append(idx[found[0]])
        cols.append(found[1])
        counted += found[0].size
    r, c = _sorted_pairs(rows, cols)
    if r.size > MAX_CANDIDATES:
        raise _too_many(int(r.size))
    return r, c


class PlotIndex:
    """Candidate search over one scan's plots (the gates then test the candidates exactly).

    Cartesian gates: the plots (x, y), searched with a radius bounding each gate
    (:func:`near_pairs`). Polar windows |dr| <= W_R, |d az| <= W_az: the plots sorted by
    range, each window reading the plots of its band of ranges
    (:mod:`plotgate.core.initiation.windows`). Where the bands hold more than
    :data:`BAND_WORK` plots in all (plots on a few rings of range), the windows are
    rectangles in (r, az) searched on the grid instead: the points (r, S az), with the
    Chebyshev radius max(W_R, S W_az), S the typical ratio of the two half-widths (so a
    window at 100 km does not drag in a disc of its arc length), every plot also 2 pi
    away for windows across +-pi; the windows' own test then decides.

    Parameters
    ----------
    scan : Scan
    windows : (K_R, K_az) or None
        The polar window coefficients, which set S; None for Cartesian gates.
    """

    def __init__(self, scan: Scan, windows: tuple[float, float] | None) -> None:
        self.scan = scan
        self.windows = windows
        self.points = np.ascontiguousarray(scan.z, dtype=float)
        # polar windows read the plots in range order (ties in any order: a window's
        # plots are sorted by index once found)
        polar = windows is not None
        self.by_range = np.argsort(scan.r if polar else scan.r[:0]).astype(np.int64)
        self.r_sorted = np.ascontiguousarray(scan.r[self.by_range], dtype=float)
        self.az_sorted = np.ascontiguousarray(scan.az[self.by_range], dtype=float)

    def ball(self, centres: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot within radius of centres[row] (Cartesian)."""
        return near_pairs(self.points, centres, radius, 2.0)

    def window(
        self, r: np.ndarray, az: np.ndarray, W_R: np.ndarray, W_az: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot in the window about (r, az)[row]: |dr| <= W_R and
        |d az| <= W_az, each widened by a hair (1e-9) for rounding."""
        queries = (
            np.ascontiguousarray(r, dtype=float),
            np.ascontiguousarray(az, dtype=float),
            np.ascontiguousarray(W_R * (1 + 1e-9), dtype=float),
            np.ascontiguousarray(W_az * (1 + 1e-9), dtype=float),
        )
        first, last = range_bands(self.r_sorted, queries[0], queries[2])
        if int((last - first).sum()) > BAND_WORK + 64 * (self.scan.size + r.size):
            return self._grid_window(*queries)
        bands = (self.r_sorted, self.az_sorted, self.by_range, first, last, *queries)
        counts, found, total = window_pairs(MAX_CANDIDATES, *bands)
        if total > MAX_CANDIDATES:
            raise _too_many(total)
        return np.repeat(np.arange(r.size), counts), found

    def _grid_window(
        self, r: np.ndarray, az: np.ndarray, reach_r: np.ndarray, reach_az: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`window` on the grid in (r, S az), for bands too full to read."""
        assert self.windows is not None  # a polar index
        K_R, K_az = self.windows
        scan = self.scan
        scale = K_R * np.median(scan.sigma_r) / (K_az * np.median(scan.sigma_az))
        other = scan.az - 2.0 * np.pi * np.sign(scan.az)
        points = np.column_stack(
            [np.concatenate([scan.r, scan.r]), scale * np.concatenate([scan.az, other])]
        )
        rows, cols = near_pairs(
            points, np.column_stack([r, scale * az]), np.maximum(reach_r, scale * reach_az), np.inf
        )
        cols = cols % scan.size  # a plot's copy 2 pi away is the plot
        key = np.unique(rows * scan.size + cols)  # a wide window may meet both copies
        row, plot = key // scan.size, key % scan.size
        keep = in_windows(
            scan.r[plot], scan.az[plot], r[row], az[row], reach_r[row], reach_az[row]
        )
        return row[keep], plot[keep]
