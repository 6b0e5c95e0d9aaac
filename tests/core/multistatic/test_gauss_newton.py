"""The compiled range-sum Gauss-Newton engine against the numpy reference (Fadeev et al., eq. 6).

:func:`gauss_newton` fuses the iteration of :func:`gauss_newton_reference` per problem;
both must take the same steps: the same iteration counts and convergence flags, and the
same minima to rounding (1e-12 relative), or within the solver's tolerance where the cost
is flat along a direction (a minimum the data hardly determine). Every draw is seeded.
"""

import numpy as np
import pytest

from plotgate.core.multistatic.gauss_newton import (
    GaussNewtonFit,
    gauss_newton,
    gauss_newton_reference,
)
from plotgate.core.multistatic.model import (
    platform_positions,
    range_sum_jacobian_unchecked,
    range_sums,
    range_sums_unchecked,
)
from plotgate.core.multistatic.position import sum_range_starts

TOL = 1e-9
MAX_ITER = 50


def reference(ls, sigma, tx, rx, tau, row, theta0, max_iter=MAX_ITER):
    """The numpy engine on the same range-sum model (positions K = D, tracks K = 2D)."""
    d = tx.shape[-1]
    moving = theta0.shape[1] != d

    def predict(theta, idx):
        if not moving:
            return range_sums_unchecked(theta, tx[row[idx]], rx[row[idx]])
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]  # (m, M, D): one pair each
        return range_sums_unchecked(x, tx[row[idx], :, None], rx[row[idx], :, None])[..., 0]

    def jacobian(theta, idx):
        if not moving:
            return range_sum_jacobian_unchecked(theta, tx[row[idx]], rx[row[idx]])
        x = theta[:, None, :d] + tau[:, None] * theta[:, None, d:]
        H = range_sum_jacobian_unchecked(x, tx[row[idx], :, None], rx[row[idx], :, None])[
            ..., 0, :
        ]
        return np.concatenate([H, tau[:, None] * H], axis=-1)

    return gauss_newton_reference(predict, jacobian, ls[row], sigma[row], theta0, max_iter, TOL)


def assert_agree(
    ref: GaussNewtonFit, new: GaussNewtonFit, flips: float = 0.0, exact_share: float = 0.99
) -> None:
    """Same steps (iterations, flags) and the same minima, to rounding.

    Near a minimum the accepted step depends on comparing two costs that differ by
    rounding, so the engines may end a few ulps (of the cost) apart: minima agree to
    1e-12 relative, or where the cost cannot tell them apart, (dtheta)^T J (dtheta) <=
    1e-10 (1 + cost) (a flat direction: in 3D with LAPACK's eigenvectors, at a false
    minimum on a platform). ``flips`` is the fraction of problems whose iteration
    count may differ by such a rounding decision (0 for the study's 2D problems), and
    ``exact_share`` the least fraction of minima equal to 1e-12 (the study's: 0.99).
    """
    np.testing.assert_array_equal(new.converged, ref.converged)
    assert (new.iterations != ref.iterations).mean() <= flips
    scale = 1.0 + np.abs(ref.theta).max(axis=1)
    exact = np.abs(new.theta - ref.theta).max(axis=1) <= 1e-12 * scale
    assert exact.mean() >= exact_share
    dx = new.theta - ref.theta
    assert (np.einsum("ni,nij,nj->n", dx, ref.information, dx) <= 1e-10 * (1.0 + ref.cost)).all()
    assert (np.abs(new.cost - ref.cost) <= 1e-10 * (1.0 + ref.cost)).all()
    big = 1.0 + np.abs(ref.information).max(axis=(1, 2))[:, None, None]
    assert (np.abs(new.information - ref.information)[exact] <= 1e-10 * big[exact]).all()
    # the floored inverse (compiled in the kernel): as accurate as the information's
    # condition allows
    cov = np.abs(ref.covariance).max(axis=(1, 2))[:, None, None]
    assert (np.abs(new.covariance - ref.covariance)[exact] <= 1e-8 * cov[exact]).all()
    # a range sum moves at most 2 |dx|: residuals agree to 2e-12 of the coordinates
    gap = np.abs(new.residuals - ref.residuals).max(axis=1)
    assert (gap[exact] <= 4e-12 * scale[exact]).all()


def study_geometry(n_samples=200, dt=0.2):
    """The accuracy study's platforms (Fadeev et al., Fig. 2): (t, x (T, 2), tx, rx (T, 3, 2))."""
    t = dt * np.arange(n_samples)
    heading_rx, heading_tx = np.pi / 3, 2 * np.pi / 3
    rx = platform_positions(
        [[150.0, 500.0], [70.0, 1000.0], [150.0, 1500.0]],
        10.0 * np.array([np.cos(heading_rx), np.sin(heading_rx)]),
        t,
    )
    tx = platform_positions(
        [9900.0, 1500.0], 10.0 * np.array([np.cos(heading_tx), np.sin(heading_tx)]), t
    )
    x = np.array([5000.0, 200.0]) + t[:, None] * [0.0, 80.0]
    return t, x, np.repeat(tx[:, None], 3, axis=1), rx


def single_shot(ls, sigma, tx, rx, theta0, row=None):
    row = np.arange(theta0.shape[0]) if row is None else row
    tau = np.zeros(ls.shape[1])
    return (
        reference(ls, sigma, tx, rx, tau, row, theta0),
        gauss_newton(ls, sigma, tx, rx, tau, row, theta0, MAX_ITER, TOL),
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_study_problems_from_the_roots_and_from_starts_500_m_off(seed):
    rng = np.random.default_rng(seed)
    _, x, tx, rx = study_geometry()
    i = rng.integers(0, x.shape[0], 2000)  # the baseline crossings included
    tx, rx, x = tx[i], rx[i], x[i]
    ls = range_sums(x, tx, rx) + 0.5 * rng.standard_normal((i.size, 3))
    sigma = np.full(ls.shape, 0.5)
    start, alt, has = sum_range_starts(ls, tx, rx)
    angle = rng.uniform(0.0, 2.0 * np.pi, i.size)
    off = x + 500.0 * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    row = np.concatenate([np.arange(i.size), np.flatnonzero(has), np.arange(i.size)])
    ref, new = single_shot(ls, sigma, tx, rx, np.concatenate([start, alt[has], off]), row)
    assert_agree(ref, new)
    assert (ref.iterations > 10).any()  # the starts 500 m off take the long way


def test_the_baseline_crossing_with_unequal_sigmas():
    rng = np.random.default_rng(4)
    _, x, tx, rx = study_geometry()
    k = 112  # the target is on the central baseline
    n = 500
    ls = range_sums(x[k], tx[k], rx[k]) + 0.5 * rng.standard_normal((n, 3))
    sigma = rng.uniform(0.3, 2.0, (n, 3))
    starts = x[k] + rng.normal(0.0, 300.0, (n, 2))
    ref, new = single_shot(
        ls,
        sigma,
        np.broadcast_to(tx[k], (n, 3, 2)).copy(),
        np.broadcast_to(rx[k], (n, 3, 2)).copy(),
        starts,
    )
    assert_agree(ref, new)


def test_three_dimensional_problems():
    rng = np.random.default_rng(5)
    n, p = 400, 4
    tx = np.broadcast_to(rng.uniform(-5e3, 5e3, (n, 1, 3)), (n, p, 3)).copy()
    rx = rng.uniform(-1e4, 1e4, (n, p, 3))
    x = rng.uniform(-2e4, 2e4, (n, 3))
    ls = range_sums(x, tx, rx) + rng.standard_normal((n, p))
    ref, new = single_shot(ls, np.ones((n, p)), tx, rx, x + rng.normal(0.0, 200.0, (n, 3)))
    assert_agree(ref, new, flips=0.01, exact_share=0.75)


def test_degenerate_geometry_a_target_on_a_sensor_one_problem_and_an_empty_batch():
    # every platform on the x axis (the cross-axis derivative vanishes on it), and a
    # start exactly on a receiver (its unit vector is taken as 0)
    tx = np.array([[[0.0, 0.0]] * 3, [[0.0, 0.0]] * 3])
    rx = np.array([[[1e4, 0.0], [-5e3, 0.0], [2e4, 0.0]]] * 2)
    x = np.array([[3e3, 0.0], [3e3, 4e3]])
    ls = range_sums(x, tx, rx)
    starts = np.array([[3.5e3, 0.0], rx[1, 0]])
    ref, new = single_shot(ls, np.ones((2, 3)), tx, rx, starts)
    assert_agree(ref, new)
    one_ref, one_new = single_shot(ls[1:], np.ones((1, 3)), tx[1:], rx[1:], starts[1:])
    assert_agree(one_ref, one_new)
    np.testing.assert_array_equal(one_new.theta, new.theta[1:])
    empty = gauss_newton(
        np.zeros((0, 3)),
        np.ones((0, 3)),
        np.zeros((0, 3, 2)),
        np.zeros((0, 3, 2)),
        np.zeros(3),
        np.zeros(0, dtype=int),
        np.zeros((0, 2)),
        MAX_ITER,
        TOL,
    )
    assert empty.theta.shape == (0, 2) and empty.covariance.shape == (0, 2, 2)


def test_max_iter_stops_both_engines_alike():
    rng = np.random.default_rng(6)
    _, x, tx, rx = study_geometry()
    ls = range_sums(x, tx, rx) + 0.5 * rng.standard_normal(x.shape[:1] + (3,))
    sigma = np.full(ls.shape, 0.5)
    starts = x + rng.normal(0.0, 1000.0, x.shape)
    row = np.arange(x.shape[0])
    tau = np.zeros(3)
    for max_iter in (1, 2, 8):
        ref = reference(ls, sigma, tx, rx, tau, row, starts, max_iter)
        new = gauss_newton(ls, sigma, tx, rx, tau, row, starts, max_iter, TOL)
        assert_agree(ref, new)


@pytest.mark.parametrize("receivers", [3, 2])
def test_tracks_from_several_starts(receivers):
    rng = np.random.default_rng(7)
    t, x, tx, rx = study_geometry()
    tx, rx = tx[:, :receivers], rx[:, :receivers]
    n = 6
    ls = range_sums(x, tx, rx) + 0.5 * rng.standard_normal((n, t.size, receivers))
    m = t.size * receivers
    truth = np.array([5000.0, 200.0, 0.0, 80.0])
    starts = truth + rng.normal(0.0, 1.0, (2 * n, 4)) * [300.0, 300.0, 10.0, 10.0]
    row = np.repeat(np.arange(n), 2)
    tau = np.repeat(t - t[0], receivers)
    args = (
        ls.reshape(n, m),
        np.full((n, m), 0.5),
        np.broadcast_to(tx.reshape(m, 2), (n, m, 2)).copy(),
        np.broadcast_to(rx.reshape(m, 2), (n, m, 2)).copy(),
        tau,
        row,
        starts,
    )
    ref = reference(*args)
    new = gauss_newton(*args, MAX_ITER, TOL)
    assert_agree(ref, new, flips=0.2, exact_share=0.25)
