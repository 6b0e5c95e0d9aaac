"""Tests of core.gates.heading: the compiled prior-averaged density against its numpy reference.

The compiled kernels are held to the numpy reference they replace: the graded heading
panels to rounding (the same nodes), the mapped heading rule and B's principal axes to
a tolerance far below the unconditional probability's target (another rule, the same
integral). The reference itself is held to scipy's adaptive quadrature of the same
double integral.
"""

import math

import numpy as np
import pytest
from scipy import integrate

from plotgate.core import mark_geometry
from plotgate.core.gates import heading
from plotgate.core.gates.probability import RULES
from plotgate.core.sym2 import inverse

TAU = 5.0


def problem(sigma_r, sigma_az_deg, speeds, prior, r=50e3):
    """(geometry, ring, lambda_min, lambda_max) of one problem at azimuth 0.4 rad."""
    g = mark_geometry(r, 0.4, sigma_r, math.radians(sigma_az_deg), tau=TAU)
    lam_min, lam_max = np.linalg.eigvalsh(g.P1[0] + g.P2[0])
    ring = heading.prior_ring(prior, speeds[0] * TAU, speeds[1] * TAU, lam_min)
    return g, ring, lam_min, lam_max


def points(ring, lam_max, count, seed):
    """Random points out to the density's reach, the origin, and points on the ring's circles."""
    rng = np.random.default_rng(seed)
    d = rng.uniform(-1.0, 1.0, (count, 2)) * (ring.R_max + 9.0 * math.sqrt(lam_max))
    d[:3] = [[0.0, 0.0], [ring.R_min, 0.0], [0.0, -ring.R_max]]
    return d


def bound(ring, lam_max):
    """2 pi (c0 + c1 R_max) sqrt(2 pi lambda_max): no density exceeds it."""
    return 2.0 * np.pi * (ring.c0 + ring.c1 * ring.R_max) * np.sqrt(2.0 * np.pi * lam_max)


@pytest.mark.parametrize(
    ("sigma_r", "sigma_az_deg", "speeds", "prior"),
    [
        (20.0, 1.0, (100.0, 500.0), "speed"),  # axis ratio 26: graded about the smeared ring
        (200.0, 0.5, (300.0, 300.0), "area"),  # a circle: the thin-ring rule
        (200.0, 0.5, (300.0, 300.02), "speed"),
        (150.0, 0.05, (0.0, 300.0), "speed"),  # axis ratio 3.4, below the smeared grading
    ],
    ids=["eccentric", "circle", "thin-ring", "elongated"],
)
def test_graded_density_is_the_reference_to_rounding(sigma_r, sigma_az_deg, speeds, prior):
    g, ring, _, lam_max = problem(sigma_r, sigma_az_deg, speeds, prior)
    d = points(ring, lam_max, 3000, 15)
    for rule in RULES:
        ref = heading.prior_density_reference(d[None, :, 0], d[None, :, 1], g.B, ring, rule)[0]
        fast = heading.prior_density(d[:, 0], d[:, 1], g.B, ring, rule)
        np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize(
    ("sigma_r", "sigma_az_deg", "speeds", "prior"),
    [
        (200.0, 0.5, (100.0, 500.0), "area"),  # Konovalov's example
        (200.0, 0.5, (0.0, 300.0), "speed"),
        (150.0, 0.5, (0.0, 500.0), "area"),  # axis ratio 2.9
        (100.0, 0.1, (50.0, 250.0), "speed"),
    ],
)
def test_mapped_heading_rule_matches_the_reference(sigma_r, sigma_az_deg, speeds, prior):
    g, ring, _, lam_max = problem(sigma_r, sigma_az_deg, speeds, prior)
    d = points(ring, lam_max, 400, 16)
    fast = heading.prior_density(d[:, 0], d[:, 1], g.B, ring, RULES[0])
    ref = heading.prior_density_reference(d[None, :, 0], d[None, :, 1], g.B, ring, (30, 0.25))[0]
    # the mapped rule's stop is a heuristic (heading.HEADING_TOL: up to 3e-7 of the bound
    # measured, where the density is far below it); the estimate's second rule covers it
    np.testing.assert_allclose(fast, ref, rtol=0.0, atol=5e-7 * bound(ring, lam_max))
    typical = np.abs(fast - ref) <= 1e-8 * bound(ring, lam_max)
    assert typical.mean() >= 0.99


@pytest.mark.parametrize(
    ("r", "sigma_r", "sigma_az_deg", "speeds"),
    [
        (50e3, 150.0, 0.05, (100.0, 500.0)),  # axis ratio 3.4
        (80e3, 20.0, 1.0, (100.0, 500.0)),  # 70
        (50e3, 1.0, 0.5, (0.0, 500.0)),  # 436, a ring from the first mark
        (30e3, 10.0, 0.5, (20.0, 60.0)),  # 26, a ring narrower than sigma_max
    ],
)
def test_principal_axes_density_matches_the_reference(r, sigma_r, sigma_az_deg, speeds):
    """The area prior with an eccentric B in B's principal axes, against the graded heading
    panels on a fine rule, for both rules of the unconditional probability."""
    g, ring, lam_min, lam_max = problem(sigma_r, sigma_az_deg, speeds, "area", r=r)
    assert lam_max >= heading.ECCENTRIC**2 * lam_min  # the rule the kernel picks
    d = points(ring, lam_max, 1000, 18)
    ref = heading.prior_density_reference(d[None, :, 0], d[None, :, 1], g.B, ring, (16, 0.25))[0]
    for rule in RULES:
        fast = heading.prior_density(d[:, 0], d[:, 1], g.B, ring, rule)
        np.testing.assert_allclose(fast, ref, rtol=0.0, atol=5e-8 * bound(ring, lam_max))


def test_reference_is_the_double_integral():
    """The reference at a few points against scipy's dblquad of the prior over the ring.

    On a fine rule: at d = 0 the heading integrand peaks about B's major axis, not about
    the direction of d, and the production rule (8, 1) is off by 2e-5 of the value there
    (the gate's nodes near z1 carry little weight, rho d rho), the rule (14, 0.25) by 3e-8."""
    g, ring, _, lam_max = problem(200.0, 0.5, (100.0, 500.0), "area")
    Q = np.linalg.inv(g.P1[0] + g.P2[0])
    d = np.array([[0.0, 0.0], [600.0, -300.0], [2400.0, 900.0]])
    ref = heading.prior_density_reference(d[None, :, 0], d[None, :, 1], g.B, ring, (14, 0.25))[0]
    for (px, py), value in zip(d, ref, strict=True):

        def integrand(s, phi, px=px, py=py):
            n = np.array([s * math.cos(phi) - px, s * math.sin(phi) - py])
            return ring.c1 * s * math.exp(-0.5 * n @ Q @ n)

        exact, _ = integrate.dblquad(
            integrand, 0.0, 2.0 * math.pi, ring.R_min, ring.R_max, epsabs=1e-13, epsrel=1e-11
        )
        assert value == pytest.approx(exact, rel=0.0, abs=1e-8 * bound(ring, lam_max))


def test_ray_moments_is_the_reference():
    rng = np.random.default_rng(17)
    g, _, _, _ = problem(200.0, 0.5, (100.0, 500.0), "area")
    gauss = heading.gaussian(g.B)
    Q = inverse(g.B)
    phi = rng.uniform(-math.pi, math.pi, 200)
    m = rng.normal(0.0, 2000.0, (200, 2))
    t1, t2 = rng.uniform(0.0, 1500.0, 200), rng.uniform(1500.0, 4000.0, 200)
    ux, uy = np.cos(phi), np.sin(phi)
    ref = heading.ray_moments_reference(ux, uy, m[:, 0], m[:, 1], Q, t1, t2)
    fast = np.array(
        [
            heading.ray_moments(ux[i], uy[i], m[i, 0], m[i, 1], gauss.args(), t1[i], t2[i])
            for i in range(200)
        ]
    ).T
    for f, r in zip(fast, ref, strict=True):
        np.testing.assert_allclose(f, r, rtol=1e-12, atol=1e-12 * np.abs(r).max())


def test_density_of_no_points_is_empty():
    g, ring, _, _ = problem(200.0, 0.5, (100.0, 500.0), "area")
    assert heading.prior_density(np.empty(0), np.empty(0), g.B, ring, RULES[0]).shape == (0,)
    eccentric, ring, _, _ = problem(20.0, 1.0, (100.0, 500.0), "speed")
    assert heading.prior_density(np.empty(0), np.empty(0), eccentric.B, ring, RULES[0]).shape == (
        0,
    )


@pytest.mark.parametrize(
    ("r", "sigma_r", "sigma_az_deg", "speeds", "prior"),
    [
        (50e3, 200.0, 0.5, (100.0, 500.0), "area"),  # Konovalov's example
        (50e3, 200.0, 0.5, (0.0, 300.0), "speed"),
        (80e3, 20.0, 1.0, (100.0, 500.0), "area"),  # axis ratio 70
        (50e3, 150.0, 0.05, (100.0, 500.0), "area"),  # 3.4
        (20e3, 100.0, 0.5, (0.0, 500.0), "area"),  # a ring from z1
    ],
)
def test_table_interpolates_the_density(r, sigma_r, sigma_az_deg, speeds, prior):
    """The density table (shared by both rules and every gate node) against the density
    computed at each point: the table's error is not in the error estimate, so it must be
    far below it."""
    g, ring, lam_min, lam_max = problem(sigma_r, sigma_az_deg, speeds, prior, r=r)
    assert heading.tabulates(g.B, ring)
    table = heading.density_table(g.B, ring, RULES[0])
    assert table.size == heading.table_size(g.B, ring)
    d = points(ring, lam_max, 2000, 20)
    d[3:6] = [[table.lengths[0], 0.0], [0.0, table.lengths[1]], [1e9, -1e9]]  # edges, far
    d[3:5] = d[3:5] @ np.array(
        [
            [math.cos(table.major), math.sin(table.major)],
            [-math.sin(table.major), math.cos(table.major)],
        ]
    )
    interpolated = heading.interpolated_density(d[:, 0].copy(), d[:, 1].copy(), table.args())
    ref = heading.prior_density_reference(d[None, :, 0], d[None, :, 1], g.B, ring, (16, 0.25))[0]
    np.testing.assert_allclose(interpolated, ref, rtol=0.0, atol=5e-8 * bound(ring, lam_max))
    assert interpolated[5] == 0.0


def test_graded_densities_are_not_tabulated():
    g, ring, _, _ = problem(150.0, 0.05, (100.0, 500.0), "speed")  # axis ratio 3.4
    assert not heading.tabulates(g.B, ring)
    g, ring, _, _ = problem(200.0, 0.5, (300.0, 300.0), "area")  # a circle: nodes
    assert not heading.tabulates(g.B, ring)


def test_tables_are_kept_per_problem():
    g, ring, _, _ = problem(200.0, 0.5, (100.0, 500.0), "area")
    heading.clear_tables()
    first = heading.cached_table(g.B, ring, RULES[0])
    assert heading.cached_table(g.B, ring, RULES[0]) is first
    other, ring2, _, _ = problem(150.0, 0.5, (100.0, 500.0), "area")
    assert heading.cached_table(other.B, ring2, RULES[0]) is not first
