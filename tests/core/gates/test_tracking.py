"""Tests of core.gates.tracking: ellipse gate, innovation covariance, rectangular gate."""

import numpy as np
import pytest
from gate_helpers import N_RANDOM, assert_matches_reference, random_spd
from scipy import stats

from plotgate.core import EllipseGate, ParameterError, RectangularGate, innovation_covariance

GAMMA_09 = stats.chi2.ppf(0.9, 2)


# ---------------------------------------------------------------- scalar references


def ellipse_ref(z, z_pred, S, P_G):
    nu = z - z_pred
    rho = float(nu @ np.linalg.solve(S, nu))
    return rho <= stats.chi2.ppf(P_G, 2), rho


def rectangular_ref(z, z_pred, sigma_x, sigma_y, k):
    statistic = max(abs(z[0] - z_pred[0]) / sigma_x, abs(z[1] - z_pred[1]) / sigma_y)
    return statistic <= k, statistic


# ---------------------------------------------------------------- hand-computed cases


def test_ellipse_gate_hand_computed():
    # S = [[4, 1], [1, 2]], |S| = 7: nu = (2, 1) gives (2*4 - 2*1*2 + 4*1)/7 = 8/7,
    # nu = (0, 3) gives 4 * 9 / 7 = 36/7 > gamma(0.9) = 4.605
    S = np.array([[4.0, 1.0], [1.0, 2.0]])
    res = EllipseGate(0.9).test([[12.0, 21.0], [10.0, 23.0]], [10.0, 20.0], S)
    np.testing.assert_allclose(res.statistic, [8 / 7, 36 / 7], rtol=1e-14)
    np.testing.assert_array_equal(res.inside, [True, False])
    assert res.threshold == pytest.approx(GAMMA_09, rel=1e-15)


def test_innovation_covariance():
    P = np.diag([100.0, 4.0, 100.0, 4.0])
    R = np.diag([25.0, 25.0])
    H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    np.testing.assert_array_equal(innovation_covariance(P, R, H), np.diag([125.0, 125.0]))
    np.testing.assert_array_equal(innovation_covariance(np.eye(2), 2 * np.eye(2)), 3 * np.eye(2))
    batch = innovation_covariance(np.stack([np.eye(2)] * 3), np.eye(2))
    assert batch.shape == (3, 2, 2)


def test_innovation_covariance_shape_errors():
    with pytest.raises(ParameterError, match=r"^H: must have shape \(\.\.\., m, 4\)"):
        innovation_covariance(np.eye(4), np.eye(2), np.eye(2))
    with pytest.raises(ParameterError, match=r"^R: must be 2 x 2"):
        innovation_covariance(np.eye(2), np.eye(3))
    with pytest.raises(ParameterError, match=r"^P_pred: must be square"):
        innovation_covariance(np.ones((2, 3)), np.eye(2))


def test_rectangular_gate_hand_computed():
    # sigma_x = 10, sigma_y = 20, k = 3: (25, 50) -> max(2.5, 2.5); (31, 0) -> 3.1;
    # (30, -60) sits exactly on the corner (3, 3) and is inside
    res = RectangularGate(3.0).test(
        [[25.0, 50.0], [31.0, 0.0], [30.0, -60.0]], [0.0, 0.0], 10.0, 20.0
    )
    np.testing.assert_allclose(res.statistic, [2.5, 3.1, 3.0])
    np.testing.assert_array_equal(res.inside, [True, False, True])
    assert res.threshold == 3.0


# ---------------------------------------------------------------- vectorized vs reference


def test_ellipse_gate_matches_reference():
    rng = np.random.default_rng(104)
    z_pred = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z = z_pred + rng.normal(0.0, 150.0, (N_RANDOM, 2))
    S = random_spd(rng, N_RANDOM, 60.0)
    res = EllipseGate(0.99).test(z, z_pred, S)
    ref = [ellipse_ref(*row, 0.99) for row in zip(z, z_pred, S, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)
    np.testing.assert_array_equal(res.inside, res.statistic <= res.threshold)


def test_ellipse_gate_matches_ill_conditioned_reference():
    rng = np.random.default_rng(105)
    angle = rng.uniform(0.0, np.pi, N_RANDOM)
    R = np.stack([np.cos(angle), -np.sin(angle), np.sin(angle), np.cos(angle)], 1)
    R = R.reshape(-1, 2, 2)
    S = R @ (np.eye(2) * [1e6, 1.0]) @ R.transpose(0, 2, 1)
    z = rng.normal(0.0, 30.0, (N_RANDOM, 2))
    res = EllipseGate(0.9).test(z, [0.0, 0.0], S)
    ref = [ellipse_ref(row, np.zeros(2), s, 0.9) for row, s in zip(z, S, strict=True)]
    np.testing.assert_allclose(res.statistic, [r[1] for r in ref], rtol=1e-6)
    assert np.all(res.statistic >= 0.0)


def test_rectangular_gate_matches_reference():
    rng = np.random.default_rng(106)
    z_pred = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z = z_pred + rng.normal(0.0, 40.0, (N_RANDOM, 2))
    sigma_x, sigma_y = rng.uniform(5.0, 30.0, (2, N_RANDOM))
    res = RectangularGate(2.5).test(z, z_pred, sigma_x, sigma_y)
    ref = [rectangular_ref(*row, 2.5) for row in zip(z, z_pred, sigma_x, sigma_y, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_per_pair_covariance_with_one_candidate_broadcasts():
    rng = np.random.default_rng(110)
    S = random_spd(rng, 7, 10.0)
    res = EllipseGate(0.9).test([1.0, 2.0], [0.0, 0.0], S)
    assert res.statistic.shape == (7,)
    np.testing.assert_allclose(
        res.statistic,
        [ellipse_ref(np.array([1.0, 2.0]), np.zeros(2), s, 0.9)[1] for s in S],
        rtol=1e-12,
    )


def test_rounding_asymmetry_is_accepted_and_upper_element_read():
    P = np.array([[4.0, 1.0], [1.0 + 1e-12, 3.0]])
    res = EllipseGate(0.9).test([1.0, 1.0], [0.0, 0.0], P)
    S = np.array([[4.0, 1.0], [1.0, 3.0]])
    expected = ellipse_ref(np.ones(2), np.zeros(2), S, 0.9)[1]
    assert res.statistic[0] == pytest.approx(expected, rel=1e-14)
