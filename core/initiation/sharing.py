"""Which tracks share plots: the plot-reuse rules of track initiation.

"A plot used by a confirmed track is not reused to start new tracks; tentative tracks
sharing two or more plots with a confirmed one are pruned", and of newly confirmed tracks
sharing two or more plots only the better one is kept. Tracks are rows of plot
histories (p, H): plot ids (scan * PLOT_STRIDE + index), newest last, -1 before the first.

Two rows share two or more plots exactly when they hold a common *pair* of plots, so the
rules work on the keys of the rows' plot pairs, and only of plots another row holds too:
at most sum_i h_i (h_i - 1) / 2 keys for rows of h_i such plots, whatever the overlap
(H (H - 1) / 2 a row when every plot is shared: 28 for H = 8, 2016 for H = 64). A join
on single plot ids would cost the square of the number of rows holding one plot (all the
branches of one initiator, or all the tracks that took one plot), which a state of 10^4
tracks, or one scan, can make 10^8.
"""

from __future__ import annotations

import numpy as np

__all__ = ["keep_greedy", "plot_pairs", "shares_two"]


def _member(values: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """values isin ids, for sorted distinct ids (a binary search per value, no sort)."""
    if ids.size == 0:
        return np.zeros(values.shape, dtype=bool)
    found: np.ndarray = ids[np.minimum(np.searchsorted(ids, values), ids.size - 1)] == values
    return found


def plot_pairs(plots: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of plots among ``ids`` within each row of plot histories, as one key.

    Parameters
    ----------
    plots : (p, H) ndarray of int
        Plot ids per row, increasing, -1 before the row's first plot.
    ids : (K,) ndarray of int
        The plot ids that count, sorted and distinct; a row's other plots are ignored.

    Returns
    -------
    rows : (M,) ndarray of int
        The row of each pair; M = sum_i h_i (h_i - 1) / 2 for rows holding h_i of ``ids``.
    keys : (M,) ndarray of int
        rank(u) K + rank(v) for the pair's plots u < v (ranks in ``ids``): equal exactly
        when the two pairs hold the same two plots.

    Examples
    --------
    >>> rows, keys = plot_pairs(np.array([[-1, 5, 7], [5, 7, 9]]), np.array([5, 7, 9]))
    >>> rows.tolist(), keys.tolist()
    ([0, 1, 1, 1], [1, 1, 2, 5])
    """
    if ids.size < 2:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    counted = (plots >= 0) & _member(plots, ids)
    h = counted.sum(axis=1)
    # the counted ids of each row, in order, at its end
    packed = np.take_along_axis(plots, np.argsort(counted, axis=1, kind="stable"), axis=1)
    rows, first, second = [np.zeros(0, dtype=np.int64)], [ids[:0]], [ids[:0]]
    for k in np.unique(h[h >= 2]):  # one pass per count (at most H)
        r = np.flatnonzero(h == k)
        c1, c2 = np.triu_indices(k, 1)
        block = packed[r, plots.shape[1] - k :]
        rows.append(np.repeat(r, c1.size))
        first.append(block[:, c1].ravel())
        second.append(block[:, c2].ravel())
    u = np.searchsorted(ids, np.concatenate(first))
    v = np.searchsorted(ids, np.concatenate(second))
    return np.concatenate(rows), np.minimum(u, v) * ids.size + np.maximum(u, v)


def keep_greedy(plots: np.ndarray) -> np.ndarray:
    """Keep rows in order, each unless it shares two or more plots with a row kept before it.

    Of the tracks one scan confirms, in order of merit (:mod:`plotgate.core.initiation.logic`, step
    5: smaller mean statistic first), the first of two clashing tracks wins. Only the
    pairs of plots that two rows hold can clash, and only rows holding one are contested;
    a kept row claims its pairs (kept rows share at most one plot, so no two claim the
    same pair).

    Parameters
    ----------
    plots : (p, H) ndarray of int
        Plot histories, rows in order of priority, -1 before each row's first plot.

    Returns
    -------
    keep : (p,) ndarray of bool

    Examples
    --------
    Row 1 shares plots 5 and 7 with row 0; row 2 shares only plot 7 with each:

    >>> keep_greedy(np.array([[5, 7, 9], [4, 5, 7], [7, 8, 10]])).tolist()
    [True, False, True]
    """
    keep = np.ones(plots.shape[0], dtype=bool)
    if plots.shape[0] < 2:
        return keep
    ids, count = np.unique(plots[plots >= 0], return_counts=True)
    rows, key = plot_pairs(plots, ids[count >= 2])
    _, key, counts = np.unique(key, return_inverse=True, return_counts=True)
    shared = counts[key] >= 2
    if not shared.any():
        return keep
    rows, key = rows[shared], key[shared]
    sort = np.argsort(rows, kind="stable")
    rows, key = rows[sort], key[sort]
    claimed = np.zeros(counts.size, dtype=bool)
    starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
    for s, e in zip(starts, np.r_[starts[1:], rows.size], strict=True):  # contested rows only
        if claimed[key[s:e]].any():
            keep[rows[s]] = False
        else:
            claimed[key[s:e]] = True
    return keep


def shares_two(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row of ``a``: does it share two or more plots with some row of ``b``?

    Only the plots both hold can be shared, so only their pairs, in rows holding two of
    them, are keyed.

    Parameters
    ----------
    a : (p, H) ndarray of int
    b : (q, H) ndarray of int
        Plot histories, -1 before each row's first plot.

    Returns
    -------
    shares : (p,) ndarray of bool

    Examples
    --------
    >>> shares_two(np.array([[4, 5, 7], [-1, 7, 9], [1, 2, 3]]),
    ...            np.array([[5, 7, 9], [-1, 2, 8]])).tolist()
    [True, True, False]
    """
    out = np.zeros(a.shape[0], dtype=bool)
    if a.shape[0] == 0 or b.shape[0] == 0:
        return out
    in_a = (a >= 0) & _member(a, np.unique(b[b >= 0]))
    both = np.unique(a[in_a])
    if both.size < 2:
        return out
    ra = np.flatnonzero(in_a.sum(axis=1) >= 2)  # rows holding two of them
    rb = np.flatnonzero(_member(b, both).sum(axis=1) >= 2)
    rows, key = plot_pairs(a[ra], both)
    _, other = plot_pairs(b[rb], both)
    out[ra[rows[np.isin(key, other)]]] = True
    return out
