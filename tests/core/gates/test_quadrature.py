"""Tests of core._quadrature: graded Gauss-Legendre panels for thin features."""

import math

import numpy as np
import pytest

from plotgate.core.gates.quadrature import RATIO, adaptive_panels, breakpoints, panel_rule

TWO_PI = 2.0 * math.pi


def integrate_rule(edges, m, f):
    x, w = panel_rule(edges, m)
    return np.sum(w * f(x), axis=-1)


def wrapped(x):
    return np.mod(x + math.pi, TWO_PI) - math.pi


@pytest.mark.parametrize(
    "centre", [0.3, 3.0, 1e-5, TWO_PI - 5e-5], ids=["inside", "middle", "at-lo", "at-hi"]
)
def test_narrow_periodic_gaussian_peak(centre):
    # width 1e-4 on [0, 2 pi]: the integral of the periodic peak is w sqrt(2 pi) (the
    # other images are e^-(pi/w)^2 / 2 away); near the domain's ends half of it wraps
    w = 1e-4
    edges = breakpoints(
        np.array(0.0), np.array(TWO_PI), np.array([centre]), np.array([w]), periodic=True
    )
    assert edges.ndim == 1 and len(edges) <= 30  # few panels: ~ 2 log(2 pi / w) / log 3
    exact = w * math.sqrt(2.0 * math.pi)
    value = integrate_rule(edges, 12, lambda x: np.exp(-0.5 * (wrapped(x - centre) / w) ** 2))
    assert abs(value - exact) <= 2e-11 * exact
    assert abs(value - exact) <= 1e-12


def test_ungraded_panels_miss_the_peak():
    # the same number of uniform panels is nowhere near: grading is what the test checks
    w, centre = 1e-4, 0.3
    graded = breakpoints(
        np.array(0.0), np.array(TWO_PI), np.array([centre]), np.array([w]), periodic=True
    )
    uniform = np.linspace(0.0, TWO_PI, len(graded))
    exact = w * math.sqrt(2.0 * math.pi)
    value = integrate_rule(uniform, 12, lambda x: np.exp(-0.5 * ((x - centre) / w) ** 2))
    assert abs(value - exact) > 0.5 * exact


@pytest.mark.parametrize("centre", [0.37, 0.999999])
def test_boundary_layer_with_kink(centre):
    # f = exp(-|x - c| / w) on [0, 1]: a kink and two layers of width w = 1e-5 at c;
    # integral w (2 - e^-(c / w) - e^-((1 - c) / w))
    w = 1e-5
    edges = breakpoints(np.array(0.0), np.array(1.0), np.array([centre]), np.array([w]))
    assert len(edges) <= 30
    exact = w * (2.0 - math.exp(-centre / w) - math.exp(-(1.0 - centre) / w))
    value = integrate_rule(edges, 12, lambda x: np.exp(-np.abs(x - centre) / w))
    assert abs(value - exact) <= 1e-12 * exact


def test_boundary_layer_at_domain_edge():
    # f = 1 / (1 + x / w)^2 on [0, 1] (an algebraic layer of width w = 1e-6 at 0):
    # integral w (1 - 1 / (1 + 1 / w))
    w = 1e-6
    edges = breakpoints(np.array(0.0), np.array(1.0), np.array([0.0]), np.array([w]))
    exact = w * (1.0 - 1.0 / (1.0 + 1.0 / w))
    value = integrate_rule(edges, 16, lambda x: 1.0 / (1.0 + x / w) ** 2)
    assert abs(value - exact) <= 1e-12 * exact


def test_grading_geometry():
    # edges sit at c +- w RATIO^j until they leave the domain
    w, c = 1e-3, 0.5
    edges = breakpoints(np.array(0.0), np.array(1.0), np.array([c]), np.array([w]))
    expected = [
        c + s * w * RATIO**j
        for j in range(10)
        for s in (-1.0, 1.0)
        if 0.0 < c + s * w * RATIO**j < 1.0
    ]
    np.testing.assert_allclose(edges, np.sort([0.0, c, *expected, 1.0]), rtol=0, atol=1e-15)


def test_a_width_near_the_largest_double_grades_nothing_and_warns_nothing():
    # a fine feature sets many levels; the huge one's offsets overflow, and under the
    # suite's filterwarnings an overflow warning would fail this test
    fine = breakpoints(np.array(0.0), np.array(1.0), np.array([0.25]), np.array([1e-3]))
    both = breakpoints(
        np.array(0.0), np.array(1.0), np.array([0.25, 0.75]), np.array([1e-3, 1e308])
    )
    np.testing.assert_array_equal(np.unique(both), np.unique([*fine, 0.75]))


def test_batch_empty_panels_contribute_zero():
    # problem 0 has a thin feature, problem 1 none (NaN centre): problem 1 is padded with
    # repeated last edges, i.e. empty panels, whose weights are exactly zero
    lo, hi = np.array([0.0, 0.0]), np.array([1.0, 2.0])
    centres = np.array([[0.4], [np.nan]])
    widths = np.array([[1e-6], [1e-6]])
    edges = breakpoints(lo, hi, centres, widths, uniform=2)
    alone = breakpoints(hi[1:] * 0.0, hi[1:], np.array([[np.nan]]), np.array([[1e-6]]), uniform=2)
    np.testing.assert_array_equal(alone[0], [0.0, 1.0, 2.0])
    assert edges.shape[0] == 2 and edges.shape[1] > 3
    np.testing.assert_array_equal(edges[1, :3], [0.0, 1.0, 2.0])
    assert (edges[1, 3:] == 2.0).all()
    x, w = panel_rule(edges, 8)
    empty = w[1, 2 * 8 :]
    assert (empty == 0.0).all() and (x[1, 2 * 8 :] == 2.0).all()

    peak = np.array([[1.0], [0.0]])  # the thin peak only where it was graded for

    def f(t):
        return peak[: len(t)] * np.exp(-0.5 * ((t - 0.4) / 1e-6) ** 2) + np.cos(t)

    value = integrate_rule(edges, 8, f)
    single = integrate_rule(alone, 8, np.cos)
    assert value[1] == pytest.approx(single[0], rel=1e-15, abs=0.0)
    assert value[1] == pytest.approx(math.sin(2.0), rel=1e-12)
    assert value[0] == pytest.approx(math.sin(1.0) + 1e-6 * math.sqrt(2 * math.pi), rel=1e-12)


@pytest.mark.parametrize(("lo", "hi"), [(0.0, TWO_PI), (-math.pi, math.pi), (2.0, 2.0 + TWO_PI)])
def test_periodic_edges_wrap_into_domain(lo, hi):
    centres = np.array([[3.1, -7.0, 20.0, math.pi - 1e-4]])
    widths = np.full((1, 4), 1e-3)
    fixed = np.array([[100.0, np.nan, -0.5]])
    edges = breakpoints(
        np.array([lo]), np.array([hi]), centres, widths, fixed, periodic=True, uniform=4
    )[0]
    assert edges[0] == lo and edges[-1] == hi
    assert (np.diff(edges) >= 0.0).all()
    assert ((edges >= lo) & (edges <= hi)).all()
    # each centre and each fixed kink is an edge, modulo 2 pi
    for c in [3.1, -7.0, 20.0, math.pi - 1e-4, 100.0, -0.5]:
        image = lo + (c - lo) % TWO_PI
        assert np.min(np.abs(edges - image)) <= 1e-12, c
    # the wrapped peak at pi - 1e-4 (its mass split by the seam when lo = -pi) integrates
    w, c = 1e-3, math.pi - 1e-4
    value = integrate_rule(edges, 12, lambda x: np.exp(-0.5 * (wrapped(x - c) / w) ** 2))
    assert value == pytest.approx(w * math.sqrt(2.0 * math.pi), rel=1e-11)


def test_periodic_short_domain_is_clipped():
    # a domain shorter than a turn: images of the centres inside it are edges, others clip
    edges = breakpoints(
        np.array([0.0]),
        np.array([1.0]),
        np.array([[7.0, 4.0]]),
        np.array([[1e-3, 1e-3]]),
        periodic=True,
    )[0]
    assert edges[0] == 0.0 and edges[-1] == 1.0
    assert ((edges >= 0.0) & (edges <= 1.0)).all() and (np.diff(edges) > 0.0).all()
    assert np.min(np.abs(edges - (7.0 - TWO_PI))) <= 1e-12


def test_panel_rule_exact_for_polynomials():
    # the m-point Gauss-Legendre rule is exact for degree 2m - 1 on every panel
    rng = np.random.default_rng(1234)
    edges = np.sort(
        np.concatenate([[[-1.0]] * 3, rng.uniform(-1.0, 2.0, (3, 9)), [[2.0]] * 3], axis=1), axis=1
    )
    for m in (3, 8, 12):
        deg = 2 * m - 1
        value = integrate_rule(edges, m, lambda x, d=deg: x**d)
        exact = (2.0 ** (deg + 1) - 1.0) / (deg + 1)
        np.testing.assert_allclose(value, exact, rtol=1e-13)
        x, w = panel_rule(edges, m)
        assert x.shape == w.shape == (3, 10 * m)


@pytest.mark.parametrize("tol", [1e-8, 1e-12])
def test_adaptive_panels_reach_tolerance(tol):
    # problem 0: a Gaussian of width 0.02 at 0.3 on [0, 1] from two plain panels;
    # problem 1: sqrt(x) on [0, 1] (unbounded derivative at 0), with an empty panel
    def integrand(rows, x):
        out = np.sqrt(x)
        first = rows == 0
        out[first] = np.exp(-0.5 * ((x[first] - 0.3) / 0.02) ** 2)
        return out

    edges = np.array([[0.0, 0.5, 1.0], [0.0, 1.0, 1.0]])
    integral, error = adaptive_panels(integrand, edges, tol)
    s = 0.02 * math.sqrt(2.0)
    exact = np.array(
        [
            0.02 * math.sqrt(2.0 * math.pi) * 0.5 * (math.erf(0.7 / s) + math.erf(0.3 / s)),
            2.0 / 3.0,
        ]
    )
    assert (error <= tol).all()
    assert (np.abs(integral - exact) <= error + 1e-15).all()
    assert (np.abs(integral - exact) <= tol).all()
