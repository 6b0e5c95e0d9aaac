"""The compiled grid search against its oracle, scipy's cKDTree (search.py)."""

import numpy as np
import pytest

from plotgate.core import ParameterError
from plotgate.core.initiation import search
from plotgate.core.initiation.search import near_pairs, near_pairs_reference


def _both(points, centres, radius, p):
    got = near_pairs(points, centres, radius, p)
    want = near_pairs_reference(points, centres, radius, p)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    return got


@pytest.mark.parametrize("p", [2.0, np.inf])
@pytest.mark.parametrize("seed", range(5))
def test_random_batches_match_the_tree(seed, p):
    rng = np.random.default_rng(seed)
    m, n = rng.integers(1, 3000, 2)
    points = rng.uniform(-5e3, 5e3, (m, 2))
    centres = rng.uniform(-6e3, 6e3, (n, 2))
    radius = rng.uniform(1.0, 400.0, n) ** rng.uniform(0.5, 1.2)
    rows, cols = _both(points, centres, radius, p)
    assert np.all(np.diff(rows) >= 0)  # sorted by query, then plot
    same = np.flatnonzero(np.diff(rows) == 0)
    assert np.all(cols[same + 1] > cols[same])


def test_edges_match_the_tree():
    rng = np.random.default_rng(7)
    points = rng.uniform(0.0, 100.0, (50, 2))
    # a query on a plot, one exactly a radius away, a zero radius, queries far outside
    centres = np.array([points[0], points[1] + [10.0, 0.0], points[2], [1e9, -1e9], [-1e9, 0]])
    radius = np.array([0.0, 10.0, 0.0, 5.0, 1e3])
    rows, cols = _both(points, centres, radius, 2.0)
    assert (0, 0) in set(zip(rows.tolist(), cols.tolist(), strict=True))
    _both(points[:1], centres, radius, 2.0)  # one plot
    _both(np.repeat(points[:1], 20, axis=0), points[:3], np.full(3, 1.0), np.inf)  # duplicates


def test_empty_inputs():
    none = np.zeros((0, 2))
    for points, centres in ((none, np.ones((3, 2))), (np.ones((3, 2)), none)):
        rows, cols = near_pairs(points, centres, np.ones(centres.shape[0]), 2.0)
        assert rows.size == cols.size == 0


def test_plots_spread_far_wider_than_the_gates_go_to_the_tree():
    rng = np.random.default_rng(3)
    points = rng.uniform(-1e9, 1e9, (200, 2))  # 10^18 cells of 1 m: the grid is refused
    centres = points[:20] + 0.5
    _both(points, centres, np.full(20, 1.0), 2.0)


def test_too_many_pairs_are_refused_before_they_are_stored(monkeypatch):
    monkeypatch.setattr(search, "MAX_CANDIDATES", 100)
    points = np.zeros((20, 2))
    with pytest.raises(ParameterError) as err:
        near_pairs(points, np.zeros((10, 2)), np.ones(10), 2.0)
    assert err.value.field == "scans" and "200 candidate" in str(err.value)


def test_dense_gates_grow_the_pairs_array_past_its_first_size():
    # 10 queries each holding all 3,000 plots: 30,000 pairs, past the first 1,044 slots
    rng = np.random.default_rng(11)
    points = rng.uniform(0.0, 10.0, (3000, 2))
    rows, _ = _both(points, rng.uniform(4.0, 6.0, (10, 2)), np.full(10, 20.0), 2.0)
    assert rows.size == 30_000


def test_plots_on_a_tall_strip_are_ordered_by_argsort():
    # one column of cells, far more rows of cells than plots: the counting sort's rows
    # would outgrow the plots, so the keys are argsorted
    rng = np.random.default_rng(12)
    points = np.column_stack([rng.uniform(0.0, 1.0, 300), rng.uniform(-1e7, 1e7, 300)])
    _both(points, points[:40] + 0.25, np.full(40, 1.0), np.inf)


@pytest.mark.parametrize("seed", range(4))
def test_the_counting_sort_orders_the_cells_as_a_stable_argsort(seed):
    rng = np.random.default_rng(seed)
    nx, ny = rng.integers(1, 60, 2)
    cell = np.column_stack([rng.integers(0, nx, 2000), rng.integers(0, ny, 2000)])
    got = search.cell_order(cell, int(nx), int(ny))
    want = search.cell_order_reference(cell, int(nx), int(ny))
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
