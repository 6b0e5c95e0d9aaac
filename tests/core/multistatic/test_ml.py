"""Tests of plotgate.core.multistatic.position and .trajectory (Fadeev et al., eqs. 4, 6).

Geometries: a well-conditioned one (a transmitter at the centre of three receivers
10 km out) and one like the paper's (Fadeev et al., Fig. 2: a transmitter about 9.7 km
east of three receivers, all moving at 10 m/s, and a target flying north at 80 m/s across the three
baselines, where a plain least-squares fit started 500 m off can land in a false
minimum). Every random draw is seeded.
"""

import numpy as np
import pytest
from scipy import optimize, stats

from plotgate.core.errors import GeometryError, NonFiniteError, ParameterError, PlotgateError
from plotgate.core.multistatic.closed_form import sum_range_solve
from plotgate.core.multistatic.crlb import crlb, trajectory_crlb
from plotgate.core.multistatic.model import platform_positions, range_sum_jacobian, range_sums
from plotgate.core.multistatic.position import MLSolution, ml_solve
from plotgate.core.multistatic.trajectory import TrajectorySolution, trajectory_solve

SIGMA = 0.5
TX = np.array([0.0, 0.0])
RX = np.array([[10000.0, 0.0], [-5000.0, 8660.0], [-5000.0, -8660.0]])


def seed_geometry(n_samples=200, dt=0.2):
    """Fadeev et al., Fig. 2-like platforms and target: (t, x_true (T, 2), tx, rx (T, 3, 2))."""
    t = dt * np.arange(n_samples)
    heading_rx, heading_tx = np.pi / 3, 2 * np.pi / 3  # 60 and 120 degrees
    rx = platform_positions(
        [[150.0, 500.0], [70.0, 1000.0], [150.0, 1500.0]],
        10.0 * np.array([np.cos(heading_rx), np.sin(heading_rx)]),
        t,
    )
    tx = platform_positions(
        [9900.0, 1500.0], 10.0 * np.array([np.cos(heading_tx), np.sin(heading_tx)]), t
    )
    tx = np.repeat(tx[:, None], 3, axis=1)
    x = np.array([5000.0, 200.0]) + t[:, None] * [0.0, 80.0]
    return t, x, tx, rx


def normalized_error(x_hat, x_true, covariance):
    """sqrt((x_hat - x)^T C^-1 (x_hat - x)) per row."""
    e = x_hat - x_true
    return np.sqrt(np.einsum("ni,nij,nj->n", e, np.linalg.inv(covariance), e))


# ---------------------------------------------------------------- single shot, exact data


def test_noise_free_data_are_solved_exactly_in_2d_and_3d():
    rng = np.random.default_rng(1)
    x = rng.uniform(-12000.0, 12000.0, (500, 2))
    sol = ml_solve(range_sums(x, TX, RX), TX, RX, SIGMA)
    assert isinstance(sol, MLSolution)
    np.testing.assert_allclose(sol.x, x, rtol=0, atol=1e-6)
    assert sol.converged.all() and sol.consistent.all()
    assert sol.cost.max() < 1e-12 and np.abs(sol.residuals).max() < 1e-6
    assert sol.x.shape == (500, 2) and sol.covariance.shape == (500, 2, 2)
    assert sol.residuals.shape == (500, 3) and sol.iterations.shape == (500,)

    tx3 = np.array([0.0, 0.0, 0.0])
    rx3 = np.array(
        [[10000.0, 0.0, 0.0], [0.0, 10000.0, 0.0], [0.0, 0.0, 3000.0], [-7000.0, -5000.0, 1000.0]]
    )
    x3 = rng.uniform(-10000.0, 10000.0, (300, 3))
    sol3 = ml_solve(range_sums(x3, tx3, rx3), tx3, rx3, SIGMA)
    np.testing.assert_allclose(sol3.x, x3, rtol=0, atol=1e-6)
    assert sol3.converged.all() and sol3.consistent.all()


def test_unbatched_problem_and_per_sample_platforms():
    ls = range_sums([3000.0, 4000.0], TX, RX)
    sol = ml_solve(ls, TX, RX, [0.5, 1.0, 2.0])
    assert sol.x.shape == (1, 2)
    np.testing.assert_allclose(sol.x[0], [3000.0, 4000.0], atol=1e-6)
    # several transmitters: two pairs each, per-problem positions
    tx = np.array([[0.0, 0.0], [0.0, 0.0], [5000.0, 5000.0], [5000.0, 5000.0]])
    rx = np.array([[10000.0, 0.0], [0.0, 10000.0], [10000.0, 0.0], [-3000.0, 8000.0]])
    x = np.random.default_rng(2).uniform(-12000.0, 12000.0, (300, 2))
    sol = ml_solve(range_sums(x, tx, rx), np.broadcast_to(tx, (300, 4, 2)), rx, SIGMA)
    np.testing.assert_allclose(sol.x, x, rtol=0, atol=1e-6)
    # the first transmitter has a single pair: the start is the platforms' centroid
    tx1 = np.array([[0.0, 0.0], [5000.0, 5000.0], [5000.0, 5000.0]])
    rx1 = np.array([[10000.0, 0.0], [10000.0, 0.0], [-3000.0, 8000.0]])
    sol = ml_solve(range_sums([2000.0, 1000.0], tx1, rx1), tx1, rx1, SIGMA)
    np.testing.assert_allclose(sol.x[0], [2000.0, 1000.0], atol=1e-6)


# ---------------------------------------------------------------- noisy data


def test_minimum_matches_an_independent_least_squares_with_unequal_sigmas():
    rng = np.random.default_rng(3)
    sigma = np.array([0.5, 2.0, 1.0])
    x = rng.uniform(-8000.0, 8000.0, (20, 2))
    ls = range_sums(x, TX, RX) + rng.normal(0.0, 1.0, (20, 3)) * sigma
    sol = ml_solve(ls, TX, RX, sigma)
    for n in range(20):

        def whitened(p, n=n):
            return (np.linalg.norm(p - RX, axis=1) + np.linalg.norm(p - TX) - ls[n]) / sigma

        ref = optimize.least_squares(whitened, x[n], xtol=1e-15, ftol=1e-15, gtol=1e-15)
        np.testing.assert_allclose(sol.x[n], ref.x, rtol=0, atol=1e-6)
        assert sol.cost[n] == pytest.approx(2.0 * ref.cost, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(sol.residuals, ls - range_sums(sol.x, TX, RX), atol=1e-9)
    np.testing.assert_allclose(sol.cost, ((sol.residuals / sigma) ** 2).sum(axis=1))
    np.testing.assert_allclose(sol.normalized_cost, sol.cost / (3 - 2))
    # the covariance is (H^T G H)^-1 at the estimate: the bound evaluated there
    np.testing.assert_allclose(sol.covariance, crlb(sol.x, TX, RX, sigma).covariance, rtol=1e-12)


def test_poor_initial_guess_1_to_3_km_off_converges_to_the_same_minimum():
    rng = np.random.default_rng(4)
    n = 1000
    x = rng.uniform(-9000.0, 9000.0, (n, 2))
    ls = range_sums(x, TX, RX) + rng.normal(0.0, SIGMA, (n, 3))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    x0 = x + rng.uniform(1000.0, 3000.0, (n, 1)) * np.stack([np.cos(angle), np.sin(angle)], 1)
    far = ml_solve(ls, TX, RX, SIGMA, x0=x0)
    near = ml_solve(ls, TX, RX, SIGMA)
    assert far.converged.all() and near.converged.all()
    np.testing.assert_allclose(far.x, near.x, rtol=0, atol=1e-5)
    assert far.iterations.max() <= 15  # measured: 10
    # x0 is tried besides the closed form's roots: the same alternatives as without it
    np.testing.assert_array_equal(far.has_alternative, near.has_alternative)
    np.testing.assert_allclose(far.alternative, near.alternative, rtol=0, atol=1e-5)
    # from x0 alone: the same minimum here, and no alternative is searched
    alone = ml_solve(ls, TX, RX, SIGMA, x0=x0, closed_form_starts=False)
    np.testing.assert_allclose(alone.x, near.x, rtol=0, atol=1e-5)
    assert alone.iterations.max() <= 15 and not alone.has_alternative.any()


def test_chi_square_consistency_test_has_its_false_alarm_rate():
    rng = np.random.default_rng(5)
    n, alpha = 4000, 0.05
    x = rng.uniform(-8000.0, 8000.0, (n, 2))
    ls = range_sums(x, TX, RX) + rng.normal(0.0, SIGMA, (n, 3))
    sol = ml_solve(ls, TX, RX, SIGMA, alpha=alpha)
    # cost ~ chi2(P - D = 1): mean 1, and 1 - alpha of the fits pass
    assert sol.cost.mean() == pytest.approx(1.0, abs=0.1)
    rate = 1.0 - sol.consistent.mean()
    assert abs(rate - alpha) < 4.0 * np.sqrt(alpha * (1.0 - alpha) / n)
    np.testing.assert_array_equal(sol.consistent, sol.cost <= stats.chi2.ppf(1.0 - alpha, 1))


def test_data_that_no_position_fits_give_finite_inconsistent_solutions():
    ls = range_sums([3000.0, 4000.0], TX, RX) + [0.0, 400.0, -300.0]
    sol = ml_solve(ls, TX, RX, SIGMA)
    for field in ("x", "covariance", "residuals", "cost", "alternative"):
        assert np.isfinite(getattr(sol, field)).all()
    assert sol.converged[0] and not sol.consistent[0]


# ---------------------------------------------------------------- the baseline-crossing trap


def test_baseline_crossings_converge_to_the_truth_from_the_closed_form_start():
    t, x, tx, rx = seed_geometry()
    bound = crlb(x, tx, rx, SIGMA)
    assert bound.sigma[:, 0].max() > 100.0  # the crossings: seed Fig. 3, curves 1

    exact = ml_solve(range_sums(x, tx, rx), tx, rx, SIGMA)
    np.testing.assert_allclose(exact.x, x, rtol=0, atol=1e-6)

    rng = np.random.default_rng(6)
    for _ in range(3):
        sol = ml_solve(
            range_sums(x, tx, rx) + rng.normal(0.0, SIGMA, x.shape[:1] + (3,)), tx, rx, SIGMA
        )
        assert sol.converged.all()
        # within 5 standard deviations of the truth everywhere (measured: < 3.4)
        assert normalized_error(sol.x, x, bound.covariance).max() < 5.0


def test_starts_500_m_off_end_at_the_truth_or_are_flagged():
    # the trap: from 500 m off alone, Gauss-Newton (as plain least squares)
    # lands in false minima near the crossings; every such minimum must fail the
    # chi-square test, and with the closed form's roots as further starts none is left
    t, x, tx, rx = seed_geometry()
    bound = crlb(x, tx, rx, SIGMA)
    rng = np.random.default_rng(7)
    ls = range_sums(x, tx, rx) + rng.normal(0.0, SIGMA, (t.size, 3))
    angle = rng.uniform(0.0, 2.0 * np.pi, (3, t.size))
    false_minima = 0
    for k in range(3):
        x0 = x + 500.0 * np.stack([np.cos(angle[k]), np.sin(angle[k])], 1)
        sol = ml_solve(ls, tx, rx, SIGMA, x0=x0, max_iter=200, closed_form_starts=False)
        off = normalized_error(sol.x, x, bound.covariance) > 5.0
        false_minima += off.sum()
        assert not (off & sol.consistent).any()
        assert sol.converged.all()
        guarded = ml_solve(ls, tx, rx, SIGMA, x0=x0, max_iter=200)
        assert normalized_error(guarded.x, x, bound.covariance).max() < 5.0
        assert guarded.converged.all()
    assert false_minima > 0  # the trap is real for this geometry


def test_false_minimum_is_flagged_inconsistent():
    t, x, tx, rx = seed_geometry()
    k = 75  # target at (5000, 1400) m, between the baselines
    ls = range_sums(x[k], tx[k], rx[k])
    trapped = ml_solve(ls, tx[k], rx[k], SIGMA, x0=[9600.0, 1700.0], closed_form_starts=False)
    assert trapped.converged[0]
    assert np.linalg.norm(trapped.x[0] - x[k]) > 4000.0  # near the transmitter
    assert trapped.cost[0] > 50.0 * stats.chi2.ppf(0.99, 1)  # measured: 441
    assert not trapped.consistent[0]
    good = ml_solve(ls, tx[k], rx[k], SIGMA)
    np.testing.assert_allclose(good.x[0], x[k], atol=1e-6)
    assert good.consistent[0] and not good.has_alternative[0]
    # the same start with the closed form's roots: the truth, and the false minimum
    # (inconsistent) is not offered as an alternative
    guarded = ml_solve(ls, tx[k], rx[k], SIGMA, x0=[9600.0, 1700.0])
    np.testing.assert_allclose(guarded.x[0], x[k], atol=1e-6)
    assert guarded.consistent[0] and not guarded.has_alternative[0]


def test_two_ellipses_report_the_mirror_solution_as_alternative():
    # one transmitter and two receivers (P = D): two exact intersections
    rx = RX[:2]
    rng = np.random.default_rng(8)
    x = rng.uniform(-8000.0, 8000.0, (200, 2))
    x = x[np.abs(0.866 * x[:, 0] + 0.5 * x[:, 1]) > 1000.0]  # off the line of baseline 2
    x = x[np.abs(x[:, 1]) > 1000.0]  # and of baseline 1
    ls = range_sums(x, TX, rx)
    sol = ml_solve(ls, TX, rx, SIGMA)
    assert sol.has_alternative.all() and sol.consistent.all() and sol.converged.all()
    truth_first = np.linalg.norm(sol.x - x, axis=1) < 1e-6
    found = np.where(truth_first[:, None], sol.x, sol.alternative)
    other = np.where(truth_first[:, None], sol.alternative, sol.x)
    np.testing.assert_allclose(found, x, rtol=0, atol=1e-6)
    np.testing.assert_allclose(range_sums(other, TX, rx), ls, rtol=0, atol=1e-6)
    assert (np.linalg.norm(other - x, axis=1) > 10.0).all()
    # started near the mirror, the solver stays there (a tie: the start's minimum), and
    # with P = D it is consistent; the truth, from the closed form, is the alternative
    mirror = ml_solve(ls, TX, rx, SIGMA, x0=other + 20.0)
    np.testing.assert_allclose(mirror.x, other, rtol=0, atol=1e-6)
    assert mirror.consistent.all() and mirror.has_alternative.all()
    np.testing.assert_allclose(mirror.alternative, x, rtol=0, atol=1e-6)


def test_three_dimensional_two_roots():
    tx = np.array([0.0, 0.0, 0.0])
    rx = np.array([[10000.0, 0.0, 0.0], [0.0, 10000.0, 0.0], [0.0, 0.0, 3000.0]])
    x = np.array([[3000.0, 4000.0, 1000.0], [-2000.0, 5000.0, 2500.0]])
    sol = ml_solve(range_sums(x, tx, rx), tx, rx, SIGMA)
    hit = np.minimum(
        np.linalg.norm(sol.x - x, axis=1), np.linalg.norm(sol.alternative - x, axis=1)
    )
    assert (hit < 1e-6).all() and sol.has_alternative.all()


# ---------------------------------------------------------------- a start besides the closed form

TRAPPED = 10.0
"""A solution more than this many standard deviations (Mahalanobis, by the CRLB at the
truth) from the truth is trapped in a false minimum; the accuracy study bounds every ML
error by it, and at the central crossing the largest is 3.5."""


def study_crossing():
    """The accuracy study's default scenario at its central baseline crossing.

    As ``clients.study.DEFAULT_REQUEST`` (a core test imports no client; the service test
    builds the same point from that request): the transmitter from (9900, 1000) m at
    120 degrees and the receivers from (150, 500), (600, 1000), (150, 1500) m at 60
    degrees, all 10 m/s; the target from (5000, 200.995) m at 80 m/s north, on the
    central baseline at t = 11.2 s (sample 112). Returns tx (2,), rx (3, 2), x (2,).
    """
    t, s60 = 11.2, 10.0 * np.sin(np.pi / 3)
    tx = platform_positions([9900.0, 1000.0], [-5.0, s60], t)
    rx = platform_positions([[150.0, 500.0], [600.0, 1000.0], [150.0, 1500.0]], [5.0, s60], t)
    return tx, rx, np.array([5000.0, 200.99484522385694 + 80.0 * t])


def mahalanobis(e, J):
    """sqrt(e^T J e) per row of e (N, D)."""
    return np.sqrt(np.einsum("ni,ij,nj->n", e, J, e))


def test_starts_500_m_off_at_the_central_crossing_are_never_trapped():
    tx, rx, x = study_crossing()
    assert np.linalg.norm(range_sum_jacobian(x, tx, rx)[1]) < 1e-12  # on baseline 2
    J = crlb(x, tx, rx, SIGMA).information[0]
    rng = np.random.default_rng(12)
    n = 500
    ls = range_sums(x, tx, rx) + SIGMA * rng.standard_normal((n, 3))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    starts = x + 500.0 * np.stack([np.cos(angle), np.sin(angle)], axis=1)

    # from the start alone, most runs end at the transmitter's cone point, all flagged
    alone = ml_solve(ls, tx, rx, SIGMA, x0=starts, closed_form_starts=False)
    trapped = mahalanobis(alone.x - x, J) > TRAPPED
    assert trapped.sum() > 250  # measured: 325 of 500
    assert (np.linalg.norm(alone.x[trapped] - tx, axis=1) < 200.0).all()
    assert not alone.consistent[trapped].any()

    # with the closed form's roots as further starts: none trapped
    sol = ml_solve(ls, tx, rx, SIGMA, x0=starts)
    assert (mahalanobis(sol.x - x, J) <= TRAPPED).all()  # measured: at most 3.5
    assert sol.converged.all() and not sol.has_alternative.any()
    np.testing.assert_array_equal(sol.consistent, sol.cost <= stats.chi2.ppf(0.99, 1))
    # the least-squares minimum found by scipy from the truth, to 1e-4 sigma
    ref = np.array(
        [
            optimize.least_squares(
                lambda p, z=z: (z - range_sums(p, tx, rx)) / SIGMA,
                x,
                xtol=1e-15,
                ftol=1e-15,
                gtol=1e-15,
            ).x
            for z in ls
        ]
    )
    assert mahalanobis(sol.x - ref, J).max() < 1e-4  # measured: 7e-6
    # and the lowest cost of every start: never above x0's alone or the closed form's
    free = ml_solve(ls, tx, rx, SIGMA)
    lowest = np.minimum(alone.cost, free.cost)
    assert (sol.cost <= lowest + 1e-9 * (1.0 + lowest)).all()


def test_a_good_start_gives_the_solution_without_a_start():
    tx, rx, x = study_crossing()
    J = crlb(x, tx, rx, SIGMA).information[0]
    rng = np.random.default_rng(13)
    n = 500
    ls = range_sums(x, tx, rx) + SIGMA * rng.standard_normal((n, 3))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    good = x + 30.0 * np.stack([np.cos(angle), np.sin(angle)], axis=1)  # in the basin
    sol = ml_solve(ls, tx, rx, SIGMA, x0=good)
    free = ml_solve(ls, tx, rx, SIGMA)
    assert mahalanobis(sol.x - free.x, J).max() < 1e-4  # measured: 2e-6
    np.testing.assert_allclose(sol.x, free.x, rtol=0, atol=1e-3)  # m; measured 3e-5
    np.testing.assert_allclose(sol.cost, free.cost, rtol=1e-9, atol=1e-12)
    # covariances relative to sigma_i sigma_j (the off-diagonal terms are near zero)
    s = np.sqrt(np.einsum("nii->ni", free.covariance))
    scaled = (sol.covariance - free.covariance) / (s[:, :, None] * s[:, None, :])
    assert np.abs(scaled).max() < 1e-6  # measured: 6e-8
    np.testing.assert_array_equal(sol.consistent, free.consistent)
    np.testing.assert_array_equal(sol.has_alternative, free.has_alternative)


def test_a_start_at_the_truth_reports_the_second_root_as_alternative():
    # P = D: the outer pairs at the central crossing. Their ellipses meet at the target
    # and at a point near the transmitter, which the closed form ranks first
    tx, rx, x = study_crossing()
    outer = rx[[0, 2]]
    rng = np.random.default_rng(14)
    n = 500
    ls = range_sums(x, tx, outer) + SIGMA * rng.standard_normal((n, 2))
    roots = sum_range_solve(ls, tx, outer, baseline_tol=5 * SIGMA)
    assert roots.has_alternative.all()
    first_near = (
        np.linalg.norm(roots.x - x, axis=1) < np.linalg.norm(roots.alternative - x, axis=1)
    )[:, None]
    near = np.where(first_near, roots.x, roots.alternative)
    far = np.where(first_near, roots.alternative, roots.x)
    assert np.linalg.norm(far - x, axis=1).min() > 4000.0  # measured: 4834 m

    sol = ml_solve(ls, tx, outer, SIGMA, x0=x)
    assert sol.has_alternative.all() and sol.consistent.all() and sol.converged.all()
    np.testing.assert_allclose(sol.x, near, rtol=0, atol=1e-6)
    np.testing.assert_allclose(sol.alternative, far, rtol=0, atol=1e-6)
    for found in (sol.x, sol.alternative):  # both fit the range sums exactly
        np.testing.assert_allclose(range_sums(found, tx, outer), ls, rtol=0, atol=1e-6)
    # without a start the closed form's ranking decides: the far root, the truth second
    free = ml_solve(ls, tx, outer, SIGMA)
    np.testing.assert_allclose(free.x, far, rtol=0, atol=1e-6)
    np.testing.assert_allclose(free.alternative, near, rtol=0, atol=1e-6)


def test_closed_form_starts_is_a_bool_and_needs_a_start_when_false():
    ls = range_sums([3000.0, 4000.0], TX, RX)
    with pytest.raises(ParameterError) as err:
        ml_solve(ls, TX, RX, SIGMA, closed_form_starts=False)
    assert err.value.field == "closed_form_starts"
    with pytest.raises(ParameterError) as err:
        ml_solve(ls, TX, RX, SIGMA, x0=[3000.0, 4000.0], closed_form_starts=1)
    assert err.value.field == "closed_form_starts"


# ---------------------------------------------------------------- constant-velocity track


def test_trajectory_solve_recovers_the_track_exactly_from_noise_free_data():
    t, x, tx, rx = seed_geometry(dt=0.25)  # binary steps: exact on the epoch below
    t = t + 1.7e9  # an absolute epoch: the state refers to t[0]
    sol = trajectory_solve(range_sums(x, tx, rx), t, tx, rx, SIGMA)
    assert isinstance(sol, TrajectorySolution)
    bound = trajectory_crlb([5000.0, 200.0], [0.0, 80.0], t, tx, rx, SIGMA)
    # exact to a millionth of the state's standard deviation
    error = np.abs(sol.state - [5000.0, 200.0, 0.0, 80.0])
    assert np.all(error <= 1e-6 * bound.sigma), error / bound.sigma
    assert sol.converged and sol.consistent and sol.cost < 1e-12 and sol.t_ref == t[0]
    np.testing.assert_array_equal(np.r_[sol.position, sol.velocity], sol.state)
    pos, cov = sol.at(t[[0, 50, 199]])
    np.testing.assert_allclose(pos, x[[0, 50, 199]], atol=1e-4)
    np.testing.assert_allclose(cov, bound.position_covariance[[0, 50, 199]], rtol=1e-6)
    np.testing.assert_allclose(sol.covariance, bound.covariance, rtol=1e-6)
    p1, c1 = sol.at(t[0] + 100.0)  # extrapolation; a scalar time gives M = 1
    assert p1.shape == (1, 2) and c1.shape == (1, 2, 2)
    np.testing.assert_allclose(p1[0], [5000.0, 8200.0], atol=1e-4)


def test_trajectory_with_crossing_mirror_tracks():
    # P = D: every sample has a mirror solution, and here the mirror track crosses
    # the true one, so the per-sample roots swap mid-track
    rx = np.array([[10000.0, 0.0], [0.0, 10000.0]])
    t = np.arange(30.0)
    x0, v = np.array([-1080.79, 2221.32]), np.array([78.24, 55.11])
    ls = range_sums(x0 + t[:, None] * v, TX, rx)
    sol = trajectory_solve(ls, t, TX, rx, SIGMA)
    np.testing.assert_allclose(sol.state, np.r_[x0, v], rtol=0, atol=1e-6)
    assert sol.converged


def test_trajectory_monte_carlo_covariance_matches_trajectory_crlb():
    # 10 samples of the paper-like crossing, 2000 draws: a variance from 2000 draws has
    # a 3.2 % standard error, so the 10 % tolerance is about 3 standard errors
    t, x, tx, rx = seed_geometry(n_samples=10, dt=1.0)
    state = np.array([5000.0, 200.0, 0.0, 80.0])
    bound = trajectory_crlb(state[:2], state[2:], t, tx, rx, SIGMA)
    rng = np.random.default_rng(9)
    ls = range_sums(x, tx, rx)
    draws = 2000
    states = np.empty((draws, 4))
    for k in range(draws):
        sol = trajectory_solve(ls + rng.normal(0.0, SIGMA, ls.shape), t, tx, rx, SIGMA, x0=state)
        assert sol.converged
        states[k] = sol.state
    ratio = states.var(axis=0, ddof=1) / bound.sigma**2
    assert np.all(np.abs(ratio - 1.0) < 0.10), ratio  # measured 0.982 ... 1.045
    assert np.all(np.abs(states.mean(axis=0) - state) < 0.1 * bound.sigma)


def test_a_batch_of_tracks_equals_the_tracks_solved_one_by_one():
    # 40 noisy draws of the paper-like crossing: each batch answer is the single answer
    t, x, tx, rx = seed_geometry(n_samples=40, dt=0.5)
    rng = np.random.default_rng(17)
    ls = range_sums(x, tx, rx) + rng.normal(0.0, SIGMA, (40, 40, 3))
    many = trajectory_solve(ls, t, tx, rx, SIGMA)
    assert many.state.shape == (40, 4) and many.residuals.shape == (40, 40, 3)
    pos, cov = many.at(t[[0, 39]])
    assert pos.shape == (40, 2, 2) and cov.shape == (40, 2, 2, 2)
    for k in (0, 13, 39):
        one = trajectory_solve(ls[k], t, tx, rx, SIGMA)
        np.testing.assert_allclose(many.state[k], one.state, rtol=0, atol=1e-9)
        np.testing.assert_allclose(many.covariance[k], one.covariance, rtol=1e-9)
        assert many.cost[k] == pytest.approx(one.cost, rel=1e-9)
        assert many.consistent[k] == one.consistent and many.converged[k] == one.converged
        np.testing.assert_allclose(pos[k], one.at(t[[0, 39]])[0], rtol=0, atol=1e-9)


def test_a_batch_mixes_mirrored_and_plain_tracks_with_per_track_inputs():
    # P = D: the crossing-mirror track of the test above next to a plain one, each
    # with its own platforms, sigmas and (for the second call) start
    rx = np.array([[10000.0, 0.0], [0.0, 10000.0]])
    t = np.arange(30.0)
    states = np.array([[-1080.79, 2221.32, 78.24, 55.11], [3000.0, 4000.0, 0.0, 80.0]])
    shift = np.array([[0.0, 0.0], [500.0, -300.0]])  # the second track's platforms moved
    tx = np.broadcast_to(TX + shift[:, None, None], (2, 30, 2, 2))
    rxs = np.broadcast_to(rx + shift[:, None, None], (2, 30, 2, 2))
    x = states[:, None, :2] + t[:, None] * states[:, None, 2:]
    ls = range_sums(x, tx, rxs)
    sigma = np.stack([np.full((30, 2), SIGMA), np.full((30, 2), 2.0 * SIGMA)])
    sol = trajectory_solve(ls, t, tx, rxs, sigma)
    np.testing.assert_allclose(sol.state, states, rtol=0, atol=1e-6)
    assert sol.converged.all()
    given = trajectory_solve(ls, t, tx, rxs, sigma, x0=states + [30.0, -20.0, 1.0, 1.0])
    np.testing.assert_allclose(given.state, states, rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"tx": np.zeros((2, 3, 2))}, "tx"),  # 2 samples, not 3
        ({"rx": np.broadcast_to(RX, (4, 3, 3, 2))}, "rx"),  # 4 tracks, not 2
        ({"sigma": np.full((3, 3, 3), SIGMA)}, "sigma"),
        ({"x0": np.zeros((3, 4))}, "x0"),
        ({"l": np.full((2, 3, 3, 1), 2e4)}, "l"),
    ],
)
def test_a_batch_of_tracks_refuses_mismatched_shapes(kwargs, field):
    args = {"l": np.full((2, 3, 3), 2e4), "t": [0.0, 1.0, 2.0], "tx": TX, "rx": RX, "sigma": SIGMA}
    args.update(kwargs)
    with pytest.raises(ParameterError) as info:
        trajectory_solve(**args)
    assert info.value.field == field


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("kwargs", "error", "field", "index"),
    [
        ({"sigma": 0.0}, ParameterError, "sigma", None),
        ({"sigma": [[0.5, 0.5, 0.5], [0.5, -1.0, 0.5]]}, ParameterError, "sigma", 1),
        ({"sigma": [0.5, 0.5]}, ParameterError, "sigma", None),
        ({"l": [[1e4, 1e4]]}, ParameterError, "l", None),
        ({"l": [[np.nan, 2e4, 2e4], [2e4, 2e4, 2e4]]}, NonFiniteError, "l", 0),
        ({"l": [[2e4, 2e4, 2e4], [2e4, 1000.0, 2e4]]}, GeometryError, "l", 1),
        ({"rx": RX[:1], "l": [2e4]}, ParameterError, "l", None),
        ({"rx": [[10000.0, 0.0], [10000.0, 0.0], [0.0, 5000.0]]}, GeometryError, "rx", 0),
        ({"x0": [1.0, 2.0, 3.0]}, ParameterError, "x0", None),
        ({"x0": np.zeros((3, 2))}, ParameterError, "x0", None),
        ({"alpha": 1.0}, ParameterError, "alpha", None),
        ({"max_iter": 0}, ParameterError, "max_iter", None),
        ({"max_iter": 2.5}, ParameterError, "max_iter", None),
        ({"tol": -1e-9}, ParameterError, "tol", None),
    ],
)
def test_ml_solve_refuses_bad_input(kwargs, error, field, index):
    args = {"l": [[2e4, 2e4, 2e4], [2.1e4, 2.1e4, 2.1e4]], "tx": TX, "rx": RX, "sigma": SIGMA}
    args.update(kwargs)
    with pytest.raises(error) as info:
        ml_solve(**args)
    assert isinstance(info.value, PlotgateError)
    assert info.value.field == field and info.value.index == index


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"t": [[0.0, 1.0, 2.0]]}, "t"),
        ({"t": [0.0, 1.0]}, "l"),
        ({"t": [5.0, 5.0, 5.0]}, "t"),
        ({"l": np.full(3, 2e4)}, "l"),
        ({"x0": [0.0, 0.0]}, "x0"),
        ({"sigma": -0.5}, "sigma"),
        ({"tx": np.zeros((4, 3, 2))}, "tx"),
    ],
)
def test_trajectory_solve_refuses_bad_input(kwargs, field):
    args = {"l": np.full((3, 3), 2e4), "t": [0.0, 1.0, 2.0], "tx": TX, "rx": RX, "sigma": SIGMA}
    args.update(kwargs)
    with pytest.raises(PlotgateError) as info:
        trajectory_solve(**args)
    assert info.value.field == field
