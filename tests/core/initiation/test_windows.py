"""The compiled polar window search against its brute-force reference (windows.py), and the
plot index's two paths for polar windows (the range bands and the grid) against each other."""

import numpy as np
import pytest

from plotgate.core.errors import ParameterError
from plotgate.core.initiation import polar_scan, search
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.windows import (
    in_windows,
    near_windows_reference,
    range_bands,
    window_pairs,
)


def near_windows(plot_r, plot_az, r, az, reach_r, reach_az):
    """The kernels' search, as PlotIndex.window runs it."""
    order = np.argsort(plot_r, kind="stable").astype(np.int64)
    first, last = range_bands(plot_r[order], r, reach_r)
    bands = (plot_r[order], plot_az[order], order, first, last, r, az, reach_r, reach_az)
    counts, found, total = window_pairs(search.MAX_CANDIDATES, *bands)
    assert total == found.size
    return np.repeat(np.arange(r.size), counts), found


def random_windows(rng, n, m):
    plot_r = rng.uniform(1.0, 5e3, n)
    plot_az = rng.uniform(-np.pi, np.pi, n)
    r = rng.uniform(-100.0, 5.1e3, m)
    az = rng.uniform(-np.pi, np.pi, m)
    reach_r = rng.uniform(0.0, 300.0, m)
    reach_az = rng.uniform(0.0, 0.5, m) ** rng.uniform(1.0, 3.0, m)
    return plot_r, plot_az, r, az, reach_r, reach_az


@pytest.mark.parametrize("seed", range(6))
def test_random_windows_match_the_brute_force(seed):
    rng = np.random.default_rng(seed)
    args = random_windows(rng, *rng.integers(1, 1500, 2))
    rows, cols = near_windows(*args)
    want = near_windows_reference(*args)
    assert rows.size > 0
    np.testing.assert_array_equal(rows, want[0])
    np.testing.assert_array_equal(cols, want[1])


def test_edges_match_the_brute_force():
    # windows across +-pi, wider than a turn, of zero size on a plot, NaN, and azimuths
    # given beyond +-pi (a polar scan takes them as they come)
    plot_r = np.array([100.0, 100.0, 100.0, 200.0, 100.0, 100.0])
    plot_az = np.array([3.1, -3.1, 0.0, 0.0, 7.0, -2 * np.pi])
    r = np.array([100.0, 100.0, 100.0, np.nan, 100.0, 150.0])
    az = np.array([-3.13, 3.0, 0.0, 0.0, 0.7168, 0.0])
    reach_r = np.array([1.0, 1.0, 0.0, 1.0, 1.0, 60.0])
    reach_az = np.array([0.1, 4.0, 0.0, 1.0, 1e-3, 1e-9])
    rows, cols = near_windows(plot_r, plot_az, r, az, reach_r, reach_az)
    want = near_windows_reference(plot_r, plot_az, r, az, reach_r, reach_az)
    np.testing.assert_array_equal(rows, want[0])
    np.testing.assert_array_equal(cols, want[1])
    pairs = set(zip(rows.tolist(), cols.tolist(), strict=True))
    assert {(0, 0), (0, 1), (2, 2), (4, 4), (5, 2), (5, 5)} <= pairs
    assert not any(row == 3 for row, _ in pairs)


def test_in_windows_is_the_kernels_test_on_pairs():
    rng = np.random.default_rng(9)
    plot_r, plot_az, r, az, reach_r, reach_az = random_windows(rng, 500, 500)
    rows, cols = near_windows(plot_r, plot_az, r, az, reach_r, reach_az)
    assert in_windows(
        plot_r[cols], plot_az[cols], r[rows], az[rows], reach_r[rows], reach_az[rows]
    ).all()


@pytest.mark.parametrize("seed", range(3))
def test_the_grid_answers_as_the_bands_when_the_bands_are_too_full(seed, monkeypatch):
    # plots on a few rings of range: every band holds a ring; over the work bound the
    # index searches the grid in (r, S az) and then applies the same window test
    rng = np.random.default_rng(seed)
    n = 2000
    r = rng.choice([5000.0, 5010.0, 8000.0], n) + rng.normal(0.0, 2.0, n)
    scan = polar_scan(0.0, r, rng.uniform(-np.pi, np.pi, n), np.full(n, 5.0), np.full(n, 3e-3))
    index = PlotIndex(scan, (3.0, 3.0))
    m = 300
    queries = (
        rng.choice(r, m),
        rng.uniform(-np.pi, np.pi, m),
        rng.uniform(1.0, 30.0, m),
        rng.uniform(1e-3, 0.2, m),
    )
    bands = index.window(*queries)
    monkeypatch.setattr(search, "BAND_WORK", -(10**9))
    grid = index.window(*queries)
    assert bands[0].size > 100
    np.testing.assert_array_equal(bands[0], grid[0])
    np.testing.assert_array_equal(bands[1], grid[1])


def test_too_many_pairs_are_counted_and_refused(monkeypatch):
    rng = np.random.default_rng(4)
    n = 400
    az = rng.uniform(-0.1, 0.1, n)
    scan = polar_scan(0.0, np.full(n, 5000.0), az, np.full(n, 5.0), np.full(n, 3e-3))
    index = PlotIndex(scan, (3.0, 3.0))
    queries = (np.full(3, 5000.0), np.zeros(3), np.full(3, 10.0), np.full(3, 0.2))
    assert index.window(*queries)[0].size == 3 * n
    monkeypatch.setattr(search, "MAX_CANDIDATES", 3 * n - 1)
    with pytest.raises(ParameterError, match=f"{3 * n} candidate"):
        index.window(*queries)
