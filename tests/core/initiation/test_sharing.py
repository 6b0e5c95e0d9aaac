"""The plot-reuse rules on plot-pair keys against a brute force over every pair of rows."""

import numpy as np
import pytest

from plotgate.core.initiation.sharing import keep_greedy, plot_pairs, shares_two


def _histories(rng: np.random.Generator, p: int, H: int, pool: int) -> np.ndarray:
    """p rows of 0..H increasing plot ids from a small pool (much sharing), -1 first."""
    out = np.full((p, H), -1, dtype=np.int64)
    for i in range(p):
        h = rng.integers(0, H + 1)
        out[i, H - h :] = np.sort(rng.choice(pool, h, replace=False)) * (1 << 20) + 3
    return out


def _shared(a: np.ndarray, b: np.ndarray) -> int:
    return len(set(a[a >= 0].tolist()) & set(b[b >= 0].tolist()))


@pytest.mark.parametrize("seed", range(20))
def test_greedy_and_pruning_equal_the_brute_force(seed):
    rng = np.random.default_rng(seed)
    H = int(rng.integers(2, 7))
    a = _histories(rng, int(rng.integers(0, 40)), H, pool=int(rng.integers(H, 12)))
    b = _histories(rng, int(rng.integers(0, 10)), H, pool=12)
    keep = []
    for i in range(a.shape[0]):
        keep.append(all(_shared(a[i], a[j]) < 2 for j in range(i) if keep[j]))
    assert keep_greedy(a).tolist() == keep
    expected = [any(_shared(row, other) >= 2 for other in b) for row in a]
    assert shares_two(a, b).tolist() == expected


def test_pair_keys_count_every_pair_once():
    rng = np.random.default_rng(5)
    plots = _histories(rng, 30, 6, pool=9)
    rows, keys = plot_pairs(plots, np.unique(plots[plots >= 0]))
    h = (plots >= 0).sum(axis=1)
    assert np.bincount(rows, minlength=30).tolist() == (h * (h - 1) // 2).tolist()
    some = np.unique(plots[plots >= 0])[::2]
    rows_some, _ = plot_pairs(plots, some)
    k = np.isin(plots, some).sum(axis=1)
    assert np.bincount(rows_some, minlength=30).tolist() == (k * (k - 1) // 2).tolist()
    for i in range(30):
        for j in range(30):
            common = set(keys[rows == i].tolist()) & set(keys[rows == j].tolist())
            assert (len(common) > 0) == (_shared(plots[i], plots[j]) >= 2)


def test_many_branches_of_one_plot_cost_no_pairs():
    # 10^5 tracks sharing one initiator plot: a join on plot ids would form 10^10 pairs
    n = 100_000
    plots = np.column_stack([np.full(n, 7), np.arange(n) + (1 << 20)])
    rows, keys = plot_pairs(plots, np.unique(plots))
    assert rows.size == n and np.unique(keys).size == n
    assert plot_pairs(plots, np.array([7]))[0].size == 0  # the one plot they share
    assert keep_greedy(plots).all()
    assert not shares_two(plots, np.array([[7, 5 << 20]])).any()
