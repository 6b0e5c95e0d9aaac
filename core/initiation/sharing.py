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

:func:`keep_greedy` and :func:`shares_two` are compiled loops over the rows, each beside
its numpy reference on plot-pair keys (:func:`keep_greedy_reference`,
:func:`shares_two_reference`), which the tests hold them to: a row's plots are looked up
among the plots the other side holds (a binary search each), and two of them are shared
with one row exactly when a row holding the first also holds the second (the rows
holding a plot are listed by plot). The work grows with the rows' plots and the rows
holding each, not with the square of anything; the numpy versions cost ten thousand
small calls a scan at 10^5 plots.
"""

from __future__ import annotations

import numpy as np

from plotgate.core.compiled import kernel

__all__ = [
    "keep_greedy",
    "keep_greedy_reference",
    "plot_pairs",
    "shares_two",
    "shares_two_reference",
]


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


def keep_greedy_reference(plots: np.ndarray) -> np.ndarray:
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

    >>> keep_greedy_reference(np.array([[5, 7, 9], [4, 5, 7], [7, 8, 10]])).tolist()
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


def shares_two_reference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
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
    >>> shares_two_reference(np.array([[4, 5, 7], [-1, 7, 9], [1, 2, 3]]),
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


def _holders(plots: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plot ids held by ``rows`` of ``plots`` (sorted, distinct), and for the j-th the
    rows holding it, ascending, at ``holder[start[j]:start[j + 1]]``."""
    held = plots[rows] >= 0
    ids = plots[rows][held]
    holder = np.broadcast_to(rows[:, None], held.shape)[held]
    order = np.lexsort((holder, ids))
    ids, holder = ids[order], holder[order].astype(np.int64)
    distinct, start = np.unique(ids, return_index=True)
    return distinct.astype(np.int64), np.append(start, ids.size).astype(np.int64), holder


@kernel("boolean(int64[:], int64, int64, int64, int64)")
def _meet(holder: np.ndarray, a0: int, a1: int, b0: int, b1: int) -> bool:
    """Whether two ascending runs of rows, holder[a0:a1] and holder[b0:b1], share one."""
    while a0 < a1 and b0 < b1:
        if holder[a0] == holder[b0]:
            return True
        if holder[a0] < holder[b0]:
            a0 += 1
        else:
            b0 += 1
    return False


@kernel("boolean(int64[:], int64[:], int64[:], int64[:], int64[:])")
def _shares_with_holders(
    row: np.ndarray, ids: np.ndarray, start: np.ndarray, holder: np.ndarray, found: np.ndarray
) -> bool:
    """Whether two plots of one row are held by one row among the holders."""
    h = 0
    for plot in row:
        j = np.searchsorted(ids, plot) if plot >= 0 else ids.size
        if j < ids.size and ids[j] == plot:
            found[h] = j
            h += 1
    for u in range(h):
        for v in range(u + 1, h):
            ju, jv = found[u], found[v]
            if _meet(holder, start[ju], start[ju + 1], start[jv], start[jv + 1]):
                return True
    return False


@kernel("boolean[:](int64[:, :], int64[:], int64[:], int64[:])")
def _shares_two_compiled(
    a: np.ndarray, ids: np.ndarray, start: np.ndarray, holder: np.ndarray
) -> np.ndarray:
    out = np.zeros(a.shape[0], dtype=np.bool_)
    found = np.empty(a.shape[1], dtype=np.int64)
    for i in range(a.shape[0]):
        out[i] = _shares_with_holders(a[i], ids, start, holder, found)
    return out


def shares_two(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`shares_two_reference`, compiled: per row of ``a``, does it share two or more
    plots with some row of ``b``?

    >>> shares_two(np.array([[4, 5, 7], [-1, 7, 9], [1, 2, 3]]),
    ...            np.array([[5, 7, 9], [-1, 2, 8]])).tolist()
    [True, True, False]
    """
    if a.shape[0] == 0 or b.shape[0] == 0:
        return np.zeros(a.shape[0], dtype=bool)
    ids, start, holder = _holders(b, np.arange(b.shape[0]))
    return _shares_two_compiled(np.ascontiguousarray(a, dtype=np.int64), ids, start, holder)


@kernel("boolean(int64[:], int64)")
def _holds(row: np.ndarray, plot: int) -> bool:
    """Whether a row of plot ids holds the plot."""
    for held in row:
        if held == plot:
            return True
    return False


@kernel("boolean[:](int64[:, :], int64[:])")
def _keep_greedy_compiled(plots: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Rows in order, each kept unless two of its plots are held by one row kept before.

    The kept rows holding each plot are chained (head and next), newest first; a row's
    plots are checked against the kept rows holding its first plot of each pair.
    """
    p, H = plots.shape
    keep = np.ones(p, dtype=np.bool_)
    head = np.full(ids.size, -1, dtype=np.int64)
    next_entry = np.empty(p * H, dtype=np.int64)
    entry_row = np.empty(p * H, dtype=np.int64)
    found = np.empty(H, dtype=np.int64)
    entries = 0
    for i in range(p):
        h = 0
        for plot in plots[i]:
            if plot >= 0:
                found[h] = np.searchsorted(ids, plot)
                h += 1
        for u in range(h):  # a kept row holding plot u and another plot of row i
            e = head[found[u]]
            while e >= 0 and keep[i]:
                other = plots[entry_row[e]]
                for v in range(u + 1, h):
                    if _holds(other, ids[found[v]]):
                        keep[i] = False
                e = next_entry[e]
        if keep[i]:
            for u in range(h):
                next_entry[entries], entry_row[entries] = head[found[u]], i
                head[found[u]] = entries
                entries += 1
    return keep


def keep_greedy(plots: np.ndarray) -> np.ndarray:
    """:func:`keep_greedy_reference`, compiled: keep rows in order, each unless it shares
    two or more plots with a row kept before it.

    >>> keep_greedy(np.array([[5, 7, 9], [4, 5, 7], [7, 8, 10]])).tolist()
    [True, False, True]
    """
    if plots.shape[0] < 2:
        return np.ones(plots.shape[0], dtype=bool)
    ids = np.unique(plots[plots >= 0]).astype(np.int64)
    return _keep_greedy_compiled(np.ascontiguousarray(plots, dtype=np.int64), ids)
