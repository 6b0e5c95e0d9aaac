"""Tests of core.gates.thresholds against Konovalov's constants and scipy.stats oracles."""

import numpy as np
import pytest
from scipy import stats

from plotgate.core import (
    ParameterError,
    expansion_coefficient,
    gate_threshold,
    rectangular_coefficient,
)


@pytest.mark.parametrize(("p", "K_g"), [(0.9, 2.146), (0.95, 2.448)], ids=["p=0.9", "p=0.95"])
def test_expansion_coefficient_matches_konovalov(p, K_g):
    assert expansion_coefficient(p) == pytest.approx(K_g, abs=1e-3)


def test_gate_threshold_matches_konovalov():
    assert gate_threshold(0.9, 2) == pytest.approx(4.605, abs=1e-3)
    assert gate_threshold(0.9) == gate_threshold(0.9, 2)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_gate_threshold_is_chi2_quantile(n):
    P_G = np.array([0.5, 0.9, 0.99, 0.999999])
    gamma = gate_threshold(P_G, n)
    assert gamma.shape == P_G.shape
    np.testing.assert_allclose(stats.chi2.cdf(gamma, n), P_G, rtol=0, atol=1e-12)


def test_expansion_coefficient_squared_is_two_dof_threshold():
    p = np.linspace(0.01, 0.999, 50)
    np.testing.assert_allclose(expansion_coefficient(p) ** 2, gate_threshold(p, 2), rtol=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("P", [0.5, 0.9, 0.99, 0.9973, 1 - 1e-9])
def test_rectangular_coefficient_closed_form(P, n):
    k = rectangular_coefficient(P, n)
    assert isinstance(k, float)
    assert (2.0 * stats.norm.cdf(k) - 1.0) ** n == pytest.approx(P, rel=0, abs=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_rectangular_coefficient_monte_carlo(n):
    P = 0.9
    trials = 10**6
    rng = np.random.default_rng(20240501 + n)
    k = rectangular_coefficient(P, n)
    hits = np.mean(np.all(np.abs(rng.standard_normal((trials, n))) <= k, axis=1))
    standard_error = np.sqrt(P * (1.0 - P) / trials)
    assert abs(hits - P) <= 4.0 * standard_error


def test_rectangular_coefficient_one_axis_three_sigma():
    assert rectangular_coefficient(stats.norm.cdf(3.0) - stats.norm.cdf(-3.0), 1) == (
        pytest.approx(3.0, abs=1e-12)
    )


BAD_PROBABILITIES = [0.0, 1.0, -0.1, 1.5, np.nan, np.inf]


@pytest.mark.parametrize(
    ("function", "field"),
    [(gate_threshold, "P_G"), (expansion_coefficient, "p"), (rectangular_coefficient, "P")],
    ids=["gate_threshold", "expansion_coefficient", "rectangular_coefficient"],
)
@pytest.mark.parametrize("bad", BAD_PROBABILITIES, ids=[str(b) for b in BAD_PROBABILITIES])
def test_bad_probability_raises(function, field, bad):
    with pytest.raises(ParameterError, match=rf"^{field}: must lie in the open interval") as info:
        function(bad)
    assert info.value.field == field
    assert info.value.index is None


def test_bad_probability_in_array_reports_index():
    with pytest.raises(ParameterError, match=r"^P_G\[2\]: .*got 1.0") as info:
        gate_threshold(np.array([0.5, 0.9, 1.0, 0.2]))
    assert info.value.index == 2


@pytest.mark.parametrize("n", [0, -1, 2.0, True, "2"], ids=["0", "-1", "float", "bool", "str"])
@pytest.mark.parametrize("function", [gate_threshold, rectangular_coefficient])
def test_bad_dimension_raises(function, n):
    with pytest.raises(ParameterError, match=r"^n: must be an integer >= 1"):
        function(0.9, n)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 10])
def test_the_quantiles_are_scipy_stats_own_to_the_bit(n):
    """scipy.special's functions replace scipy.stats' ppf and isf (a cheaper import): the
    values stay the same, scalar and array, close to 0 and 1 included."""
    rng = np.random.default_rng(25)
    P = np.concatenate([rng.uniform(0.0, 1.0, 200), [1e-300, 1e-12, 0.5, 1 - 1e-12, 1 - 2**-53]])
    P = P[(P > 0.0) & (P < 1.0)]
    np.testing.assert_array_equal(gate_threshold(P, n), stats.chi2.ppf(P, n))
    tail = -np.expm1(np.log(P) / n)
    np.testing.assert_array_equal(rectangular_coefficient(P, n), stats.norm.isf(0.5 * tail))
    for p, t in zip(P[:20], tail[:20], strict=True):
        assert gate_threshold(float(p), n) == float(stats.chi2.ppf(p, n))
        assert rectangular_coefficient(float(p), n) == float(stats.norm.isf(0.5 * t))
