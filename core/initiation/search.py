"""Candidate search: which plots of a scan may lie in a gate, by k-d tree.

A scan's plots go in a ``scipy.spatial.cKDTree`` ((x, y); for polar windows (r, S az)),
queried with a radius that bounds each gate, so the work grows with the plots near each
track and initiator, not with all plots. The gates then test the candidates exactly
(:mod:`plotgate.core.initiation.pairs`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plotgate.core.errors import ParameterError
from plotgate.core.initiation.scan import Scan

__all__ = ["MAX_CANDIDATES", "PlotIndex", "near_pairs"]

MAX_CANDIDATES = 2**24
"""Most candidate (track or initiator, plot) pairs one search may return (about 400 MB):
plots so dense that every gate holds hundreds (a thousand targets at one spot) would
otherwise grow tentative tracks, and their pairs, without bound. Over it the scan is
refused (ParameterError on ``scans``)."""


def near_pairs(
    tree: cKDTree, centres: np.ndarray, radius: np.ndarray, p: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, point) pairs with the tree's point within radius[row] of centres[row] (p-norm).

    Queries go in bins of radii within a factor 1.5, each bin one
    ``sparse_distance_matrix`` between a tree of its centres and the points (pairs come
    back as arrays, not Python lists), then the exact per-query radius. A bin that could
    hold more than :data:`MAX_CANDIDATES` pairs is counted first (``count_neighbors``
    allocates no pairs) and refused over it.

    Raises
    ------
    ParameterError
        ``"scans"`` when a bin holds more than :data:`MAX_CANDIDATES` pairs.
    """
    if centres.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    smallest = max(float(radius.min()), 1e-9)
    bins = np.floor(np.log(np.maximum(radius, smallest) / smallest) / np.log(1.5)).astype(int)
    rows, cols = [], []
    for b in np.unique(bins):  # a few bins of similar radius
        idx = np.flatnonzero(bins == b)
        queries = cKDTree(centres[idx])
        reach = float(radius[idx].max())
        if idx.size * tree.n > MAX_CANDIDATES:
            count = int(queries.count_neighbors(tree, reach, p=p))
            if count > MAX_CANDIDATES:
                raise ParameterError(
                    "scans",
                    f"{count} candidate (track, plot) pairs in "
                    f"one search, more than {MAX_CANDIDATES}: the plots "
                    f"are too dense for the gates",
                )
        found = queries.sparse_distance_matrix(tree, reach, p=p, output_type="ndarray")
        i = idx[found["i"]]
        keep = found["v"] <= radius[i]
        rows.append(i[keep])
        cols.append(found["j"][keep].astype(np.int64))
    return np.concatenate(rows).astype(np.int64), np.concatenate(cols)


class PlotIndex:
    """Candidate search over one scan's plots (the gates then test the candidates exactly).

    Cartesian gates: a cKDTree of (x, y) queried with a radius bounding each gate. Polar
    windows |dr| <= W_R, |d az| <= W_az are rectangles in (r, az): a cKDTree of
    (r, S az) queried with the Chebyshev radius max(W_R, S W_az), S the typical ratio of
    the two half-widths, so a window at 100 km does not drag in a disc of its arc
    length. Every plot also appears 2 pi away, for windows across +-pi.

    Parameters
    ----------
    scan : Scan
    windows : (K_R, K_az) or None
        The polar window coefficients, which set S; None for Cartesian gates.
    """

    def __init__(self, scan: Scan, windows: tuple[float, float] | None) -> None:
        self.tree: cKDTree | None = None
        self.scale = 1.0
        self.owner = np.zeros(0, dtype=np.int64)
        if scan.size == 0:
            return
        if windows is None:
            self.tree = cKDTree(scan.z)
            return
        K_R, K_az = windows
        self.scale = K_R * np.median(scan.sigma_r) / (K_az * np.median(scan.sigma_az))
        other = scan.az - 2.0 * np.pi * np.sign(scan.az)
        pts = np.column_stack(
            [np.concatenate([scan.r, scan.r]), self.scale * np.concatenate([scan.az, other])]
        )
        self.tree = cKDTree(pts)
        self.owner = np.tile(np.arange(scan.size), 2)

    def ball(self, centres: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot within radius of centres[row] (Cartesian)."""
        if self.tree is None:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        return near_pairs(self.tree, centres, radius, 2.0)

    def window(
        self, r: np.ndarray, az: np.ndarray, W_R: np.ndarray, W_az: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(row, plot) pairs with the plot possibly in the window about (r, az)[row]."""
        if self.tree is None:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        rows, cols = near_pairs(
            self.tree,
            np.column_stack([r, self.scale * az]),
            np.maximum(W_R, self.scale * W_az) * (1 + 1e-9),
            np.inf,
        )
        cols = self.owner[cols]
        key = np.unique(rows * self.owner.size + cols)  # a wide window may meet both copies
        return key // self.owner.size, key % self.owner.size
