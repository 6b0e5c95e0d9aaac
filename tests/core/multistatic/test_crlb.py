"""Tests of core.multistatic.crlb (Fadeev et al., eq. 3): single-shot, difference and track bounds.

The bounds are checked against scalar references (finite-difference gradients and
explicit loops) and against the Monte Carlo covariance of the estimators they bound:
the ML solve (one transmitter and three receivers about 10 km apart, sigma 0.5 m) and
the difference-range closed form. With 2000 draws the sample covariance C of a 2D
estimate has standard errors of about 3 %; the tests whiten it by the bound B and
require the eigenvalues of B^-1/2 C B^-1/2 to lie within 10 % of 1 (the extreme
eigenvalues of a 2x2 Wishart sample from 2000 draws spread by about +-6 %).
"""

import numpy as np
import pytest

from plotgate.core.errors import GeometryError, NonFiniteError, ParameterError
from plotgate.core.multistatic.closed_form import difference_range_solve
from plotgate.core.multistatic.crlb import (
    CRLB,
    TrajectoryCRLB,
    crlb,
    difference_crlb,
    trajectory_crlb,
)
from plotgate.core.multistatic.information import symmetric_eigh
from plotgate.core.multistatic.model import range_sums
from plotgate.core.multistatic.position import ml_solve

SIGMA = 0.5
TX = np.array([0.0, 0.0])
RX = np.array([[10000.0, 0.0], [-5000.0, 8660.0], [-5000.0, -8660.0]])


def reference_jacobian(x, tx, rx, step=1e-3):
    """Central finite differences of the range sums of one problem: (P, D)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = step
        plus = np.linalg.norm(x + e - rx, axis=1) + np.linalg.norm(x + e - tx, axis=1)
        minus = np.linalg.norm(x - e - rx, axis=1) + np.linalg.norm(x - e - tx, axis=1)
        cols.append((plus - minus) / (2 * step))
    return np.stack(cols, axis=1)


def reference_information(x, tx, rx, sigma):
    """Fadeev et al., eq. 3 term by term: sum_p (1/sigma_p^2) grad l_p grad l_p^T."""
    H = reference_jacobian(x, tx, rx)
    J = np.zeros((H.shape[1], H.shape[1]))
    for p in range(H.shape[0]):
        J += np.outer(H[p], H[p]) / sigma[p] ** 2
    return J


def whitened_eigenvalues(C, B):
    L_inv = np.linalg.inv(np.linalg.cholesky(B))
    return np.linalg.eigvalsh(L_inv @ C @ L_inv.T)


def test_crlb_matches_eq_3_term_by_term_in_2d_and_3d():
    rng = np.random.default_rng(10)
    for d, p in ((2, 3), (2, 5), (3, 4)):
        n = 10
        x = rng.uniform(-8000.0, 8000.0, (n, d))
        tx = rng.uniform(-10000.0, 10000.0, (n, p, d))
        rx = rng.uniform(-10000.0, 10000.0, (n, p, d))
        sigma = rng.uniform(0.2, 3.0, (n, p))
        b = crlb(x, tx, rx, sigma)
        assert isinstance(b, CRLB)
        assert b.covariance.shape == (n, d, d) and b.sigma.shape == (n, d)
        for i in range(n):
            J = reference_information(x[i], tx[i], rx[i], sigma[i])
            np.testing.assert_allclose(b.information[i], J, rtol=1e-6, atol=1e-12)
            cov = np.linalg.inv(J)
            np.testing.assert_allclose(b.covariance[i], cov, rtol=1e-5)
            np.testing.assert_allclose(b.sigma[i], np.sqrt(np.diag(cov)), rtol=1e-5)
            ref = 1.0 / np.sqrt(np.mean(1.0 / sigma[i] ** 2))
            assert b.sigma_ref[i] == pytest.approx(ref, rel=1e-12)
            assert b.gdop[i] == pytest.approx(np.sqrt(np.trace(cov)) / ref, rel=1e-5)


def test_gdop_is_geometry_only():
    x = [[3000.0, 4000.0], [-2000.0, 1000.0]]
    b = crlb(x, TX, RX, SIGMA)
    np.testing.assert_allclose(b.sigma_ref, SIGMA)
    H = np.stack([reference_jacobian(xi, TX[None], RX) for xi in np.asarray(x)])
    np.testing.assert_allclose(
        b.gdop,
        np.sqrt(np.trace(np.linalg.inv(np.swapaxes(H, 1, 2) @ H), axis1=1, axis2=2)),
        rtol=1e-6,
    )
    # scaling every sigma scales the bound, not the GDOP
    sig = np.array([0.5, 1.0, 2.0])
    b1, b10 = crlb(x, TX, RX, sig), crlb(x, TX, RX, 10.0 * sig)
    np.testing.assert_allclose(b10.covariance, 100.0 * b1.covariance, rtol=1e-12)
    np.testing.assert_allclose(b10.gdop, b1.gdop, rtol=1e-12)


def test_ml_monte_carlo_covariance_matches_the_crlb():
    # 2000 noisy draws, sigma 0.5 m, one transmitter and three receivers ~10 km apart
    rng = np.random.default_rng(11)
    for x in ([3000.0, 4000.0], [2000.0, -1000.0], [6000.0, 500.0]):
        x = np.array(x)
        ls = range_sums(x, TX, RX) + rng.normal(0.0, SIGMA, (2000, 3))
        sol = ml_solve(ls, TX, RX, SIGMA)
        assert sol.converged.all()
        B = crlb(x, TX, RX, SIGMA).covariance[0]
        C = np.cov(sol.x.T)
        ev = whitened_eigenvalues(C, B)
        assert np.all(np.abs(ev - 1.0) < 0.10), ev  # measured 0.973 ... 1.024
        bias = (sol.x.mean(axis=0) - x) / np.sqrt(np.diag(B))
        assert np.all(np.abs(bias) < 0.1)  # 0.1 sd; the standard error is 0.022 sd


def test_bound_grows_where_the_target_crosses_the_baselines():
    # Fadeev et al., Fig. 3 curves 1: a transmitter ~9.8 km east of three receivers; a
    # target flying north at x = 5 km crosses the baselines at y = 997, 1251, 1500 m
    tx = np.array([9900.0, 1500.0])
    rx = np.array([[150.0, 500.0], [70.0, 1000.0], [150.0, 1500.0]])
    y = np.linspace(-1000.0, 3000.0, 401)
    b = crlb(np.stack([np.full_like(y, 5000.0), y], axis=1), tx, rx, SIGMA)
    assert np.isfinite(b.covariance).all()
    peak = np.argmax(b.sigma[:, 0])
    assert 997.0 <= y[peak] <= 1500.0
    assert b.sigma[peak, 0] > 5.0 * max(b.sigma[0, 0], b.sigma[-1, 0])  # 118 m vs 12 m
    # exactly on a baseline with P = D the information is singular: floored, finite
    on = crlb([5000.0, 0.0], TX, RX[:2], SIGMA)
    assert np.isfinite(on.covariance).all() and on.sigma[0, 1] > 1e5


def test_difference_crlb_matches_its_definition():
    rng = np.random.default_rng(12)
    n, p, d = 8, 4, 2
    x = rng.uniform(-8000.0, 8000.0, (n, d))
    tx = rng.uniform(-10000.0, 10000.0, (n, 1, d)).repeat(p, axis=1)
    rx = rng.uniform(-10000.0, 10000.0, (n, p, d))
    sigma = rng.uniform(0.2, 3.0, (n, p))
    b = difference_crlb(x, tx, rx, sigma)
    A = np.hstack([-np.ones((p - 1, 1)), np.eye(p - 1)])  # d_k = l_k - l_1
    for i in range(n):
        Hd = A @ reference_jacobian(x[i], tx[i], rx[i])
        C = A @ np.diag(sigma[i] ** 2) @ A.T
        J = Hd.T @ np.linalg.solve(C, Hd)
        np.testing.assert_allclose(b.information[i], J, rtol=1e-6)
        # the differences lose information: J - J_d is positive semi-definite
        full = reference_information(x[i], tx[i], rx[i], sigma[i])
        assert np.linalg.eigvalsh(full - J).min() > -1e-9 * np.abs(full).max()
    # with one transmitter it cancels: moving it leaves the bound unchanged
    moved = difference_crlb(x, tx + [700.0, -300.0], rx, sigma)
    np.testing.assert_allclose(moved.covariance, b.covariance, rtol=1e-9)


def test_difference_range_closed_form_monte_carlo_matches_difference_crlb():
    # three receivers: two differences for two unknowns, so the closed form is the
    # exact inverse of the difference measurements and attains their bound
    rng = np.random.default_rng(13)
    for x in ([3000.0, 4000.0], [2000.0, -1000.0]):
        x = np.array(x)
        ls = range_sums(x, TX, RX) + rng.normal(0.0, SIGMA, (2000, 3))
        sol = difference_range_solve(ls, TX, RX, baseline_tol=5 * SIGMA)
        assert sol.solvable.all()
        Bd = difference_crlb(x, TX, RX, SIGMA).covariance[0]
        ev = whitened_eigenvalues(np.cov(sol.x.T), Bd)
        assert np.all(np.abs(ev - 1.0) < 0.10), ev  # measured 0.978 ... 1.024
        # and the difference bound is above the sum-range one (semidefinite: with
        # P = D + 1 the differences lose nothing along one direction)
        B = crlb(x, TX, RX, SIGMA).covariance[0]
        assert np.linalg.eigvalsh(Bd - B).min() > -1e-12 * np.trace(Bd)


def test_trajectory_crlb_accumulates_eq_3_over_the_samples():
    rng = np.random.default_rng(14)
    t = np.sort(rng.uniform(0.0, 20.0, 15)) + 1000.0
    x0, v = np.array([3000.0, 4000.0]), np.array([-60.0, 45.0])
    tx = rng.uniform(-500.0, 500.0, (15, 1, 2)).repeat(3, axis=1)  # a wandering transmitter
    rx = RX + rng.uniform(-100.0, 100.0, (15, 3, 2))
    sigma = np.array([0.5, 1.0, 0.8])
    b = trajectory_crlb(x0, v, t, tx, rx, sigma)
    assert isinstance(b, TrajectoryCRLB) and b.t_ref == t[0]
    J = np.zeros((4, 4))
    for i, ti in enumerate(t):
        tau = ti - t[0]
        H = reference_jacobian(x0 + tau * v, tx[i], rx[i])
        Hs = np.hstack([H, tau * H])
        J += Hs.T @ np.diag(1.0 / sigma**2) @ Hs
    np.testing.assert_allclose(b.information, J, rtol=1e-6)
    cov = np.linalg.inv(J)
    np.testing.assert_allclose(b.covariance, cov, rtol=1e-5)
    np.testing.assert_allclose(b.sigma, np.sqrt(np.diag(cov)), rtol=1e-5)
    for i, ti in enumerate(t):
        A = np.hstack([np.eye(2), (ti - t[0]) * np.eye(2)])
        np.testing.assert_allclose(b.position_covariance[i], A @ cov @ A.T, rtol=1e-5)
    # accumulating samples beats every single shot (Fadeev et al., Fig. 3 curves 2 vs 1)
    single = crlb(x0 + (t - t[0])[:, None] * v, tx, rx, sigma)
    gap = single.covariance - b.position_covariance
    assert np.linalg.eigvalsh(gap).min() > 0.0
    assert b.position_sigma.shape == (15, 2) and b.gdop.shape == (15,)


def test_accumulated_difference_bound_is_the_dense_model_of_all_differences():
    # the T (P - 1) differences of the whole track as one linear-Gaussian model:
    # G = blockdiag(A) [H_i, tau_i H_i] stacked, C = blockdiag(A diag(sigma_i^2) A^T),
    # J = G^T C^-1 G by dense matrices, independent of the per-sample code
    rng = np.random.default_rng(15)
    t = np.sort(rng.uniform(0.0, 20.0, 8))
    x0, v = np.array([3000.0, 4000.0]), np.array([-60.0, 45.0])
    tx = np.repeat(rng.uniform(-500.0, 500.0, (8, 1, 2)), 3, axis=1)
    rx = RX + rng.uniform(-100.0, 100.0, (8, 3, 2))
    sigma = rng.uniform(0.4, 1.2, (8, 3))
    b = trajectory_crlb(x0, v, t, tx, rx, sigma, measurements="difference")
    A = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    G = np.zeros((16, 4))
    C = np.zeros((16, 16))
    for i in range(8):
        tau = t[i] - t[0]
        H = reference_jacobian(x0 + tau * v, tx[i], rx[i])
        G[2 * i : 2 * i + 2] = A @ np.hstack([H, tau * H])
        C[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = A @ np.diag(sigma[i] ** 2) @ A.T
    J = G.T @ np.linalg.solve(C, G)
    np.testing.assert_allclose(b.information, J, rtol=1e-6)
    # differencing drops information: the bound is never below the range-sum one
    s = trajectory_crlb(x0, v, t, tx, rx, sigma)
    assert np.linalg.eigvalsh(b.covariance - s.covariance).min() > -1e-12 * np.trace(b.covariance)
    with pytest.raises(ParameterError) as info:
        trajectory_crlb(x0, v, t, tx, rx, sigma, measurements="ratio")
    assert info.value.field == "measurements"
    with pytest.raises(ParameterError) as info:
        trajectory_crlb(x0, v, t, tx[:, :2], rx[:, :2], sigma[:, :2], measurements="difference")
    assert info.value.field == "rx"


def test_trajectory_crlb_of_one_time_is_finite():
    b = trajectory_crlb([3000.0, 4000.0], [10.0, 0.0], [5.0], TX, RX, SIGMA)
    assert np.isfinite(b.covariance).all() and b.sigma[2:].min() > 1e5  # v unobservable


@pytest.mark.parametrize(
    ("func", "kwargs", "error", "field"),
    [
        (crlb, {"sigma": 0.0}, ParameterError, "sigma"),
        (crlb, {"sigma": [0.5, -0.5, 0.5]}, ParameterError, "sigma"),
        (crlb, {"x": [np.nan, 1.0]}, NonFiniteError, "x"),
        (crlb, {"x": [1.0, 2.0, 3.0]}, ParameterError, "x"),
        (crlb, {"x": np.zeros((2, 2, 2))}, ParameterError, "x"),
        (crlb, {"x": [10000.0, 0.0]}, GeometryError, "x"),
        (crlb, {"rx": RX[:1]}, ParameterError, "rx"),
        (crlb, {"rx": RX[[0, 0, 1]]}, GeometryError, "rx"),
        (difference_crlb, {"rx": RX[:2]}, ParameterError, "rx"),
        (difference_crlb, {"sigma": -1.0}, ParameterError, "sigma"),
    ],
)
def test_bounds_refuse_bad_input(func, kwargs, error, field):
    args = {"x": [3000.0, 4000.0], "tx": TX, "rx": RX, "sigma": SIGMA}
    args.update(kwargs)
    with pytest.raises(error) as info:
        func(**args)
    assert info.value.field == field


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"x0": [1.0, 2.0, 3.0, 4.0]}, "x0"),
        ({"v": [1.0, 2.0, 3.0]}, "v"),
        ({"t": [[0.0, 1.0]]}, "t"),
        ({"t": []}, "t"),
        ({"sigma": 0.0}, "sigma"),
    ],
)
def test_trajectory_crlb_refuses_bad_input(kwargs, field):
    args = {
        "x0": [3000.0, 4000.0],
        "v": [0.0, 80.0],
        "t": [0.0, 1.0, 2.0],
        "tx": TX,
        "rx": RX,
        "sigma": SIGMA,
    }
    args.update(kwargs)
    with pytest.raises(ParameterError) as info:
        trajectory_crlb(**args)
    assert info.value.field == field


def test_closed_form_2x2_eigen_decomposition_matches_lapack():
    rng = np.random.default_rng(21)
    A = rng.normal(size=(500, 2, 2))
    A = A + np.swapaxes(A, 1, 2)
    A[:4] = [
        [[1.0, 0.0], [0.0, 1.0]],
        [[2.0, 0.0], [0.0, 1.0]],
        [[1.0, 0.0], [0.0, 2.0]],
        [[0.0, 0.0], [0.0, 0.0]],
    ]  # repeated, ordered, reversed, zero
    A[4] = [[1.0, 1.0 - 1e-12], [1.0 - 1e-12, 1.0]]  # nearly singular
    w, V = symmetric_eigh(A)
    assert np.abs(w - np.linalg.eigvalsh(A)).max() < 1e-14 * 8
    assert np.abs(np.einsum("nik,nk,njk->nij", V, w, V) - A).max() < 1e-14 * 8
    assert np.abs(np.einsum("nki,nkj->nij", V, V) - np.eye(2)).max() < 1e-15 * 4
