"""Minimum-cost one-to-one assignment on a sparse set of candidate pairs.

Confirmed tracks take plots one to one (:mod:`plotgate.core.initiation.logic`, step 2): among the
(track, plot) pairs that passed their gates, as many pairs as can be taken, of least
total gate statistic among those. Tracks and plots that share no pair do not compete, so
the problem splits into the connected components of the pairs' graph: a component with
one track (or one plot) takes its cheapest pair, and only the tangled rest is solved by
``scipy.optimize.linear_sum_assignment``, one component at a time. Memory and time grow
with the pairs and the tangled components, not with tracks x plots (in thick clutter,
10^5 confirmed tracks by 10^5 plots would need an 80 GB cost matrix). A tangled
component larger than :data:`MAX_TANGLED` tracks x plots is refused (ParameterError on
``scans``): clutter so thick that the confirmed tracks' gates chain across the picture.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components

from plotgate.core.errors import ParameterError

__all__ = ["MAX_TANGLED", "one_to_one"]

MAX_TANGLED = 2**24
"""Most tracks x plots of one tangled component (its dense cost matrix: 134 MB, and
seconds of ``linear_sum_assignment``)."""


def one_to_one(
    rows: np.ndarray, cols: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A minimum-cost one-to-one choice among the pairs: as many pairs as can be taken,
    of least total statistic among those.

    Parameters
    ----------
    rows, cols : (E,) ndarray of int
        Track and plot of each candidate pair (each pair once).
    s : (E,) ndarray
        Its cost (the gate statistic), >= 0.

    Returns
    -------
    rows, cols, s : (K,) ndarray
        The pairs chosen, by increasing track, and their costs.

    Raises
    ------
    ParameterError
        On ``scans`` when a tangled component exceeds :data:`MAX_TANGLED`.

    Examples
    --------
    Track 0 could take plot 0 or 1, track 1 only plot 0: both are served.

    >>> r, c, s = one_to_one(np.array([0, 0, 1]), np.array([0, 1, 0]),
    ...                      np.array([0.1, 0.5, 0.2]))
    >>> r.tolist(), c.tolist(), s.tolist()
    ([0, 1], [1, 0], [0.5, 0.2])
    """
    if rows.size == 0:
        return rows, cols, s
    ur, ri = np.unique(rows, return_inverse=True)
    uc, ci = np.unique(cols, return_inverse=True)
    n_r, n_c = ur.size, uc.size
    graph = coo_array((np.ones(s.size), (ri, n_r + ci)), shape=(n_r + n_c, n_r + n_c))
    count, label = connected_components(graph, directed=False)
    component = label[ri]
    tracks = np.bincount(label[:n_r], minlength=count)
    plots = np.bincount(label[n_r:], minlength=count)
    simple = (tracks[component] == 1) | (plots[component] == 1)
    # one track or one plot: its cheapest pair (ties: the lowest plot, then track)
    order = np.lexsort((ri, ci, s, component))
    order = order[simple[order]]
    first = np.ones(order.size, dtype=bool)
    first[1:] = component[order][1:] != component[order][:-1]
    chosen = [order[first]]
    tangled = np.flatnonzero(~simple)
    tangled = tangled[np.argsort(component[tangled], kind="stable")]
    _, starts = np.unique(component[tangled], return_index=True)
    for pairs in np.split(tangled, starts[1:]) if tangled.size else []:  # each densely
        r_local, r_index = np.unique(ri[pairs], return_inverse=True)
        c_local, c_index = np.unique(ci[pairs], return_inverse=True)
        if r_local.size * c_local.size > MAX_TANGLED:
            raise ParameterError(
                "scans",
                f"{r_local.size} confirmed tracks compete for "
                f"{c_local.size} plots through chained gates, more than "
                f"{MAX_TANGLED} pairs to assign: the clutter is too thick",
            )
        big = 1.0 + 2.0 * s[pairs].max() * min(r_local.size, c_local.size)
        index = np.full((r_local.size, c_local.size), -1)
        index[r_index, c_index] = pairs
        cost = np.where(index >= 0, s[np.maximum(index, 0)], big)
        a, b = linear_sum_assignment(cost)
        taken = cost[a, b] < big
        chosen.append(index[a[taken], b[taken]])
    pick = np.concatenate(chosen)
    pick = pick[np.argsort(ri[pick], kind="stable")]
    return ur[ri[pick]], uc[ci[pick]], s[pick]
