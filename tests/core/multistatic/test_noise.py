"""Tests of core.multistatic.noise (Fadeev et al., eq. 5): noise estimation and smoothing."""

import numpy as np
import pytest

from plotgate.core.errors import NonFiniteError, ParameterError
from plotgate.core.multistatic.model import platform_positions, range_sums
from plotgate.core.multistatic.noise import (
    SMOOTHING_CELLS,
    NoiseEstimate,
    range_sum_noise,
    smooth_positions,
)


def test_noise_of_quadratic_plus_noise_series_is_recovered():
    # T = 2000: the relative standard error of a sigma estimate is 1/sqrt(2 (T - 3))
    # = 1.6 %, so a 5 % tolerance is about 3 standard errors
    rng = np.random.default_rng(20)
    t = 1.7e9 + np.linspace(0.0, 60.0, 2000)  # an absolute epoch must not matter
    tau = t - t[0]
    sigma = np.array([0.5, 1.0, 2.0])
    clean = np.stack(
        [
            12000.0 + 80.0 * tau - 0.9 * tau**2,
            9000.0 - 40.0 * tau + 0.3 * tau**2,
            15000.0 + 5.0 * tau,
        ],
        axis=1,
    )
    data = clean + rng.normal(0.0, 1.0, clean.shape) * sigma
    est = range_sum_noise(t, data)
    assert isinstance(est, NoiseEstimate)
    assert est.dof == 1997 and est.sigma.shape == (3,)
    np.testing.assert_allclose(est.sigma, sigma, rtol=0.05)  # measured within 0.5 %
    np.testing.assert_allclose(est.variance, est.sigma**2)
    # the smoothed series is the quadratic, far closer to the truth than the data
    assert np.abs(est.smoothed - clean).max() < 0.5 * sigma.min()
    np.testing.assert_allclose(est.residuals, data - est.smoothed, rtol=0, atol=1e-9)


def test_divisor_is_the_residual_degrees_of_freedom():
    t = np.array([0.0, 1.0, 2.5, 4.0, 6.0])
    y = np.array([3.0, 1.0, 4.0, 1.0, 5.0])
    est = range_sum_noise(t, y)
    coef = np.polyfit(t, y, 2)
    rss = np.sum((y - np.polyval(coef, t)) ** 2)
    assert est.dof == 2 and est.sigma.shape == ()
    assert float(est.variance) == pytest.approx(rss / 2, rel=1e-10)
    np.testing.assert_allclose(est.smoothed, np.polyval(coef, t), rtol=1e-10)
    line = range_sum_noise(t, y, degree=1)
    rss1 = np.sum((y - np.polyval(np.polyfit(t, y, 1), t)) ** 2)
    assert line.dof == 3 and float(line.variance) == pytest.approx(rss1 / 3, rel=1e-10)


def test_noise_free_quadratic_gives_zero():
    t = np.linspace(0.0, 10.0, 50)
    est = range_sum_noise(t, 2e4 + 80.0 * t + 3.0 * t**2)
    assert float(est.sigma) < 1e-9


def test_seed_like_range_sum_series_give_the_noise():
    # 10 s of a target at 80 m/s seen by moving platforms (Fadeev et al., Fig. 2): the range
    # sums are nearly quadratic (model error about 0.05 m against sigma = 0.5 m). Mean
    # of sigma^2 / 0.25 over 400 draws of three series: standard error 0.6 %.
    t = 0.2 * np.arange(50)
    rx = platform_positions([[150.0, 500.0], [70.0, 1000.0], [150.0, 1500.0]], [5.0, 8.66], t)
    tx = platform_positions([9900.0, 1500.0], [-5.0, 8.66], t)[:, None].repeat(3, axis=1)
    x = np.array([5000.0, 200.0]) + t[:, None] * [0.0, 80.0]
    clean = range_sums(x, tx, rx)
    rng = np.random.default_rng(21)
    ratios = [
        range_sum_noise(t, clean + rng.normal(0.0, 0.5, clean.shape)).variance / 0.25
        for _ in range(400)
    ]
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.05)  # measured 1.01


def test_smoothing_reproduces_polynomial_tracks_exactly():
    t = np.sort(np.random.default_rng(22).uniform(0.0, 30.0, 60))  # uneven sampling
    x = np.stack([5000.0 + 80.0 * t - 0.5 * t**2, 200.0 + 3.0 * t], axis=1)
    for window in (3, 4, 11, 60):
        np.testing.assert_allclose(smooth_positions(t, x, window), x, rtol=0, atol=1e-8)
    line = x[:, 1]
    np.testing.assert_allclose(smooth_positions(t, line, 7, degree=1), line, atol=1e-9)


def test_smoothing_reduces_the_noise_of_a_straight_track():
    # a centred quadratic window of w equally spaced samples keeps a variance fraction
    # 3 (3 w^2 - 7) / (4 w (w^2 - 4)) of white noise: 0.1075 for w = 21 (sd x 0.33)
    rng = np.random.default_rng(23)
    t = 0.5 * np.arange(4000)
    x = np.stack([5000.0 + 80.0 * t, 200.0 - 30.0 * t], axis=1)
    noisy = x + rng.normal(0.0, 20.0, x.shape)
    smooth = smooth_positions(t, noisy, 21)
    inner = slice(10, -10)
    ratio = np.std(smooth[inner] - x[inner]) / np.std(noisy[inner] - x[inner])
    assert ratio == pytest.approx(np.sqrt(3 * (3 * 21**2 - 7) / (4 * 21 * (21**2 - 4))), rel=0.05)
    # the ends use the nearest full window: still smoothed, just less
    assert np.std(smooth[:10] - x[:10]) < np.std(noisy[:10] - x[:10])


def test_window_equal_to_degree_plus_one_interpolates():
    t = np.arange(10.0)
    x = np.random.default_rng(24).normal(size=(10, 2))
    np.testing.assert_allclose(smooth_positions(t, x, 3), x, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "error", "field", "index"),
    [
        ({"t": [0.0, 1.0, 1.0, 2.0, 3.0]}, ParameterError, "t", 2),
        ({"t": [[0.0, 1.0, 2.0, 3.0, 4.0]]}, ParameterError, "t", None),
        ({"t": [0.0, 1.0, 2.0], "l": np.ones(3)}, ParameterError, "t", None),  # no dof
        ({"l": np.ones((4, 2))}, ParameterError, "l", None),
        ({"l": [1.0, 2.0, np.inf, 4.0, 5.0]}, NonFiniteError, "l", 2),
        ({"degree": -1}, ParameterError, "degree", None),
        ({"degree": 1.5}, ParameterError, "degree", None),
        ({"degree": True}, ParameterError, "degree", None),
    ],
)
def test_range_sum_noise_refuses_bad_input(kwargs, error, field, index):
    args = {"t": [0.0, 1.0, 2.0, 3.0, 4.0], "l": np.ones((5, 2))}
    args.update(kwargs)
    with pytest.raises(error) as info:
        range_sum_noise(**args)
    assert info.value.field == field and info.value.index == index


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"window": 2}, ParameterError, "window"),  # below degree + 1
        ({"window": 6}, ParameterError, "t"),  # more samples than the series has
        ({"window": 3.0}, ParameterError, "window"),
        ({"x": np.ones((4, 2))}, ParameterError, "x"),
        ({"x": [[0.0, np.nan]] * 5}, NonFiniteError, "x"),
        ({"t": [0.0, 2.0, 1.0, 3.0, 4.0]}, ParameterError, "t"),
        ({"degree": -2}, ParameterError, "degree"),
    ],
)
def test_smooth_positions_refuses_bad_input(kwargs, error, field):
    args = {"t": [0.0, 1.0, 2.0, 3.0, 4.0], "x": np.ones((5, 2)), "window": 3}
    args.update(kwargs)
    with pytest.raises(error) as info:
        smooth_positions(**args)
    assert info.value.field == field


def test_smoothing_a_long_window_builds_its_fits_in_bounded_blocks():
    """A window of the whole series is smoothed in blocks of SMOOTHING_CELLS (issue 24: a
    10,000-sample window at degree 10 would have built 8 GB at once)."""
    import tracemalloc

    rng = np.random.default_rng(24)
    t = np.arange(600.0)
    x = np.column_stack([3.0 * t, -2.0 * t]) + rng.normal(0.0, 5.0, (600, 2))
    tracemalloc.start()
    try:
        smooth_positions(t, x, window=600, degree=10)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * SMOOTHING_CELLS * 8  # at once: 600 x 600 x 11 x 8 = 32 MB, x 4


def test_smoothing_in_blocks_gives_the_numbers_of_one_block(monkeypatch):
    from plotgate.core.multistatic import noise

    rng = np.random.default_rng(25)
    t = np.cumsum(rng.uniform(0.5, 1.5, 300))
    x = np.column_stack([3.0 * t, -2.0 * t]) + rng.normal(0.0, 5.0, (300, 2))
    whole = smooth_positions(t, x, window=41, degree=3)  # one block: 300 x 41 x 4 cells
    monkeypatch.setattr(noise, "SMOOTHING_CELLS", 41 * 4 * 7)  # blocks of 7 samples
    np.testing.assert_array_equal(smooth_positions(t, x, window=41, degree=3), whole)
