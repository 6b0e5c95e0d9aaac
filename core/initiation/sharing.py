"""Which tracks share plots: the plot-reuse rules of track initiation (DESIGN section 5).

"A plot used by a confirmed track is not reused to start new tracks; tentative tracks
sharing two or more plots with a confirmed one are pruned", and of newly confirmed tracks
sharing two or more plots only the better one is kept. Tracks are rows of plot
histories (p, H): plot ids (scan * PLOT_STRIDE + index), newest last, -1 before the first.

Two rows share two or more plots exactly when they hold a common *pair* of plots, so the
rules work on the keys of the rows' plot pairs: sum_i h_i (h_i - 1) / 2 keys for rows of
h_i plots, whatever the overlap. A join on single plot ids would cost the square of the
number of rows holding one plot (all the branches of one initiator, or all the tracks
that took one plot), which a state of 10^4 tracks, or one scan, can make 10^8.
"""

from __future__ import annotations

import numpy as np

__all__ = ["keep_greedy", "plot_pairs", "shares_two"]


def plot_pairs(plots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of plots within each row of plot histories, as one integer key per pair.

    Parameters
    ----------
    plots : (p, H) ndarray of int
        Plot ids per row, -1 before the row's first plot (the valid ids are a suffix).

    Returns
    -------
    rows : (K,) ndarray of int
        The row of each pair; K = sum_i h_i (h_i - 1) / 2 for rows of h_i plots.
    keys : (K,) ndarray of int
        Equal exactly when the two pairs hold the same two plot ids.

    Examples
    --------
    >>> rows, keys = plot_pairs(np.array([[-1, 5, 7], [5, 7, 9]]))
    >>> rows.tolist(), keys[0] == keys[1], len(set(keys[1:].tolist()))
    ([0, 1, 1, 1], np.True_, 3)
    """
    h = (plots >= 0).sum(axis=1)
    rows, first, second = [], [], []
    for k in np.unique(h[h >= 2]):  # one pass per history length (at most H)
        r = np.flatnonzero(h == k)
        c1, c2 = np.triu_indices(k, 1)
        block = plots[r, plots.shape[1] - k:]
        rows.append(np.repeat(r, c1.size))
        first.append(block[:, c1].ravel())
        second.append(block[:, c2].ravel())
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    a, b = np.concatenate(first), np.concatenate(second)
    u, v = np.minimum(a, b), np.maximum(a, b)
    ids, index = np.unique(np.concatenate([u, v]), return_inverse=True)
    return np.concatenate(rows).astype(np.int64), index[:u.size] * ids.size + index[u.size:]


def keep_greedy(plots: np.ndarray) -> np.ndarray:
    """Keep rows in order, each unless it shares two or more plots with a row kept before it.

    Of the tracks one scan confirms, in order of merit (:mod:`core.initiation.logic`, step
    5: smaller mean statistic first), the first of two clashing tracks wins. Only
    rows holding a plot pair that another row holds are contested; a kept row claims its
    pairs (kept rows share at most one plot, so no two claim the same pair).

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
    rows, key = plot_pairs(plots)
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
    rows, key = plot_pairs(np.concatenate([a, b]))
    in_a = rows < a.shape[0]
    out = np.zeros(a.shape[0], dtype=bool)
    out[rows[in_a][np.isin(key[in_a], key[~in_a])]] = True
    return out
