"""plotgate.core.initiation.assignment.one_to_one against scipy's dense linear_sum_assignment.

The oracle is the formulation it replaced: a tracks x plots cost matrix with a large
cost where no pair exists, assigned by ``linear_sum_assignment``, pairs at that cost
dropped. Both must take the same number of pairs at the same total cost (ties may pick
different pairs), and every pair taken must be a candidate, each track and plot once.
"""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from plotgate.core.errors import ParameterError
from plotgate.core.initiation import assignment
from plotgate.core.initiation.assignment import one_to_one


def dense(rows, cols, s):
    ur, ri = np.unique(rows, return_inverse=True)
    uc, ci = np.unique(cols, return_inverse=True)
    big = 1.0 + 2.0 * s.max() * min(ur.size, uc.size)
    cost = np.full((ur.size, uc.size), big)
    cost[ri, ci] = s
    a, b = linear_sum_assignment(cost)
    ok = cost[a, b] < big
    return ur[a[ok]], uc[b[ok]], cost[a[ok], b[ok]]


@pytest.mark.parametrize("seed", range(200))
def test_matches_the_dense_assignment(seed):
    rng = np.random.default_rng(seed)
    n_r, n_c = rng.integers(1, 30, 2)
    mask = rng.random((n_r, n_c)) < rng.uniform(0.02, 0.6)
    mask[rng.integers(n_r), rng.integers(n_c)] = True
    rows, cols = np.nonzero(mask)
    rows, cols = 3 * rows + 1, 7 * cols + 2  # ids need not be 0..n-1
    s = rng.exponential(size=rows.size)
    if seed % 4 == 0:
        s = np.round(s, 1)  # ties
    r, c, cost = one_to_one(rows, cols, s)
    r_ref, _, cost_ref = dense(rows, cols, s)
    assert r.size == r_ref.size
    assert cost.sum() == pytest.approx(cost_ref.sum(), abs=1e-12)
    assert np.unique(r).size == r.size and np.unique(c).size == c.size
    assert np.all(np.diff(r) > 0)
    lookup = dict(zip(zip(rows.tolist(), cols.tolist(), strict=True), s.tolist(), strict=True))
    assert [lookup[p] for p in zip(r.tolist(), c.tolist(), strict=True)] == cost.tolist()


def test_no_pairs():
    empty = np.zeros(0, dtype=int)
    r, c, s = one_to_one(empty, empty, np.zeros(0))
    assert r.size == c.size == s.size == 0


def test_many_tracks_and_plots_stay_sparse():
    # 10^5 tracks x 10^5 plots (a dense cost matrix would be 80 GB) in 5 x 10^4 tangled
    # pairs of tracks: track i may take plot i (0.5) or its neighbour's i ^ 1 (1.0)
    n = 100_000
    i = np.arange(n)
    rows, cols = np.concatenate([i, i]), np.concatenate([i, i ^ 1])
    s = np.concatenate([np.full(n, 0.5), np.full(n, 1.0)])
    r, c, cost = one_to_one(rows, cols, s)
    assert r.size == n and np.array_equal(c, r)  # every track its own, cheaper plot
    assert cost.sum() == pytest.approx(0.5 * n)


def test_a_tangle_too_large_to_assign_is_refused(monkeypatch):
    monkeypatch.setattr(assignment, "MAX_TANGLED", 3)
    # tracks 0 and 1 chained to plots 0 and 1: 2 x 2 = 4 pairs to assign, over 3
    rows, cols = np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])
    with pytest.raises(ParameterError) as info:
        one_to_one(rows, cols, np.array([0.1, 0.2, 0.3, 0.4]))
    assert info.value.field == "scans"
    # independent pairs stay fine however many
    r, _, _ = one_to_one(np.arange(10), np.arange(10), np.ones(10))
    assert r.size == 10
