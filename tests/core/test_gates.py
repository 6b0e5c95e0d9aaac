"""Tests of core.gates: hand-computed cases, scalar reference loops, broadcasting, errors."""

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from core import (
    CovarianceError,
    GateResult,
    GateStage,
    GeometryError,
    NonFiniteError,
    ParameterError,
    PlotgateError,
    combined_gate,
    ellipse_gate,
    expanded_gate,
    first_association_gate,
    innovation_covariance,
    rectangular_gate,
    ring_gate,
    sector_gate,
)

GAMMA_09 = stats.chi2.ppf(0.9, 2)
K_G_09 = math.sqrt(-2.0 * math.log(1.0 - 0.9))


# ---------------------------------------------------------------- scalar references


def ring_ref(z1, z2, tau, v_min, v_max):
    dist = math.hypot(z2[0] - z1[0], z2[1] - z1[1])
    return v_min * tau <= dist <= v_max * tau, dist


def expanded_ref(z1, z2, tau, v_max, sigma_r, sigma_az, p, sensor):
    bearing = math.atan2(z1[0] - sensor[0], z1[1] - sensor[1])
    r1 = math.hypot(z1[0] - sensor[0], z1[1] - sensor[1])
    dx, dy = z2[0] - z1[0], z2[1] - z1[1]
    along = dx * math.sin(bearing) + dy * math.cos(bearing)
    across = dx * math.cos(bearing) - dy * math.sin(bearing)
    K_g = math.sqrt(-2.0 * math.log(1.0 - p))
    a = v_max * tau + K_g * sigma_r
    b = v_max * tau + K_g * r1 * sigma_az
    statistic = (along / a) ** 2 + (across / b) ** 2
    return statistic <= 1.0, statistic


def combined_ref(z1, P1, z2, P2, tau, v_min, v_max, P_G):
    B = P1 + P2
    gamma = stats.chi2.ppf(P_G, 2)
    R_min, R_max = v_min * tau, v_max * tau
    d = z2 - z1
    dist = math.hypot(d[0], d[1])
    if R_min <= dist <= R_max:
        return True, 0.0, GateStage.RING
    if dist == 0.0:
        rho = R_min**2 / np.linalg.eigvalsh(B)[-1]
    else:
        u = d / dist
        c = z1 + (R_min if dist < R_min else R_max) * u
        nu = z2 - c
        rho = float(nu @ np.linalg.solve(B, nu))
    stage = GateStage.INNER_ELLIPSE if dist < R_min else GateStage.OUTER_ELLIPSE
    inside = rho <= gamma
    return inside, rho, stage if inside else GateStage.NONE


def ellipse_ref(z, z_pred, S, P_G):
    nu = z - z_pred
    rho = float(nu @ np.linalg.solve(S, nu))
    return rho <= stats.chi2.ppf(P_G, 2), rho


def rectangular_ref(z, z_pred, sigma_x, sigma_y, k):
    statistic = max(abs(z[0] - z_pred[0]) / sigma_x, abs(z[1] - z_pred[1]) / sigma_y)
    return statistic <= k, statistic


def _angle_gap(a, b):
    return abs(math.remainder(a - b, 2.0 * math.pi))


def sector_ref(r, az, r_pred, az_pred, s_r, s_az, s_rp, s_azp, K_R, K_az):
    statistic = max(abs(r - r_pred) / (K_R * math.sqrt(s_r**2 + s_rp**2)),
                    _angle_gap(az, az_pred) / (K_az * math.sqrt(s_az**2 + s_azp**2)))
    return statistic <= 1.0, statistic


def first_association_ref(r1, az1, r2, az2, tau, v_max, s_r1, s_az1, s_r2, s_az2, K_R, K_az):
    W_R = v_max * tau + K_R * math.sqrt(s_r1**2 + s_r2**2)
    turn = math.asin(min(1.0, v_max * tau / r1)) if r1 > 0 else math.pi / 2
    W_az = turn + K_az * math.sqrt(s_az1**2 + s_az2**2)
    statistic = max(abs(r2 - r1) / W_R, _angle_gap(az2, az1) / W_az)
    return statistic <= 1.0, statistic


def random_spd(rng, n, scale):
    A = rng.normal(0.0, scale, (n, 2, 2))
    return A @ A.transpose(0, 2, 1) + 0.05 * scale**2 * np.eye(2)


def assert_matches_reference(result, reference, n):
    inside = np.array([row[0] for row in reference])
    statistic = np.array([row[1] for row in reference])
    assert result.inside.shape == result.statistic.shape == (n,)
    assert result.inside.dtype == bool and result.statistic.dtype == np.float64
    np.testing.assert_allclose(result.statistic, statistic, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(result.inside, inside)
    assert 0 < inside.sum() < n, "random cases should land on both sides of the gate"


# ---------------------------------------------------------------- hand-computed cases


def test_ring_gate_hand_computed():
    # R_min = 20 * 5 = 100 m, R_max = 500 * 5 = 2500 m; both bounds inclusive
    z2 = [[300.0, 400.0], [30.0, 40.0], [3000.0, 4000.0], [60.0, 80.0], [1500.0, 2000.0]]
    res = ring_gate([0.0, 0.0], z2, tau=5.0, v_min=20.0, v_max=500.0)
    np.testing.assert_array_equal(res.inside, [True, False, False, True, True])
    np.testing.assert_allclose(res.statistic, [500.0, 50.0, 5000.0, 100.0, 2500.0])
    assert res.threshold == 2500.0 and res.stage is None


def test_combined_gate_hand_computed_with_correlated_B():
    # B = P1 + P2 = [[1e4, 4e3], [4e3, 6e3]], |B| = 4.4e7; R_min = 100 m, R_max = 500 m
    P = np.array([[5000.0, 2000.0], [2000.0, 3000.0]])
    z2 = np.array([
        [300.0, 0.0],  # |d| = 300: ring
        [600.0, 0.0],  # nu = (100, 0): rho = 6e3 * 1e4 / 4.4e7 = 15/11
        [0.0, 700.0],  # nu = (0, 200): rho = 1e4 * 4e4 / 4.4e7 = 100/11 > gamma
        [30.0, 40.0],  # |d| = 50, nu = -50 (0.6, 0.8) = (-30, -40): rho = 59/220
        [0.0, 0.0],  # d = 0: rho = R_min^2 / lambda_max(B)
    ])
    res = combined_gate([0.0, 0.0], P, z2, P, tau=10.0, v_min=10.0, v_max=50.0, P_G=0.9)
    lambda_max = 8000.0 + math.sqrt(2000.0**2 + 4000.0**2)
    np.testing.assert_allclose(
        res.statistic, [0.0, 15 / 11, 100 / 11, 59 / 220, 100.0**2 / lambda_max], rtol=1e-12)
    np.testing.assert_array_equal(res.inside, [True, True, False, True, True])
    assert res.stage.dtype == np.int8
    assert res.stage.tolist() == [GateStage.RING, GateStage.OUTER_ELLIPSE, GateStage.NONE,
                                  GateStage.INNER_ELLIPSE, GateStage.INNER_ELLIPSE]
    assert res.threshold == pytest.approx(4.605, abs=1e-3)


def test_combined_gate_ring_bounds_are_inclusive_and_d_zero_with_v_min_zero_is_ring():
    P = np.eye(2)
    res = combined_gate([0.0, 0.0], P, [[100.0, 0.0], [0.0, 500.0]], P, 10.0, 10.0, 50.0, 0.9)
    assert res.stage.tolist() == [GateStage.RING, GateStage.RING]
    res = combined_gate([5.0, 5.0], P, [5.0, 5.0], P, 10.0, 0.0, 50.0, 0.9)
    assert res.stage.tolist() == [GateStage.RING] and res.statistic.tolist() == [0.0]


def test_combined_gate_d_zero_far_inside_inner_circle_is_rejected():
    # rho = R_min^2 / lambda_max(B) = 1000^2 / 2 is far above gamma
    res = combined_gate([0.0, 0.0], np.eye(2), [0.0, 0.0], np.eye(2), 10.0, 100.0, 500.0, 0.9)
    assert res.stage.tolist() == [GateStage.NONE]
    assert res.statistic[0] == pytest.approx(1000.0**2 / 2.0)


def test_ellipse_gate_hand_computed():
    # S = [[4, 1], [1, 2]], |S| = 7: nu = (2, 1) gives (2*4 - 2*1*2 + 4*1)/7 = 8/7,
    # nu = (0, 3) gives 4 * 9 / 7 = 36/7 > gamma(0.9) = 4.605
    S = np.array([[4.0, 1.0], [1.0, 2.0]])
    res = ellipse_gate([[12.0, 21.0], [10.0, 23.0]], [10.0, 20.0], S, 0.9)
    np.testing.assert_allclose(res.statistic, [8 / 7, 36 / 7], rtol=1e-14)
    np.testing.assert_array_equal(res.inside, [True, False])
    assert res.threshold == pytest.approx(GAMMA_09, rel=1e-15)


def test_innovation_covariance():
    P = np.diag([100.0, 4.0, 100.0, 4.0])
    R = np.diag([25.0, 25.0])
    H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    np.testing.assert_array_equal(innovation_covariance(P, R, H), np.diag([125.0, 125.0]))
    np.testing.assert_array_equal(innovation_covariance(np.eye(2), 2 * np.eye(2)),
                                  3 * np.eye(2))
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
    res = rectangular_gate([[25.0, 50.0], [31.0, 0.0], [30.0, -60.0]], [0.0, 0.0],
                           10.0, 20.0, 3.0)
    np.testing.assert_allclose(res.statistic, [2.5, 3.1, 3.0])
    np.testing.assert_array_equal(res.inside, [True, False, True])
    assert res.threshold == 3.0


def test_expanded_gate_hand_computed_north():
    # LOS due north: a = 500 + K_g 200 = 929.19 m along it (y), b = 500 + K_g 100 = 714.60 m
    res = expanded_gate([0.0, 10_000.0], [[0.0, 10_900.0], [900.0, 10_000.0]],
                        tau=5.0, v_max=100.0, sigma_r=200.0, sigma_az=0.01, p=0.9)
    expected = [(900.0 / (500.0 + K_G_09 * 200.0)) ** 2, (900.0 / (500.0 + K_G_09 * 100.0)) ** 2]
    np.testing.assert_allclose(res.statistic, expected, rtol=1e-12)
    np.testing.assert_array_equal(res.inside, [True, False])
    assert res.threshold == 1.0


@pytest.mark.parametrize("bearing_deg", [30.0, 135.0, -100.0])
def test_expanded_gate_aligns_with_line_of_sight(bearing_deg):
    # sigma_X = 200 m along the LOS, sigma_Y = 8000 * 0.005 = 40 m across it
    sensor = np.array([1000.0, -2000.0])
    b = math.radians(bearing_deg)
    along, across = np.array([math.sin(b), math.cos(b)]), np.array([math.cos(b), -math.sin(b)])
    z1 = sensor + 8000.0 * along
    z2 = np.stack([z1 + 800.0 * along, z1 + 800.0 * across, z1 - 800.0 * along])
    res = expanded_gate(z1, z2, 5.0, 100.0, 200.0, 0.005, 0.9, sensor=sensor)
    a, b_axis = 500.0 + K_G_09 * 200.0, 500.0 + K_G_09 * 40.0
    expected = [(800.0 / a) ** 2, (800.0 / b_axis) ** 2, (800.0 / a) ** 2]
    np.testing.assert_allclose(res.statistic, expected, rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, True])


def test_sector_gate_hand_computed():
    # W_R = 3 sqrt(3^2 + 4^2) = 15 m, W_az = 3 sqrt(0.003^2 + 0.004^2) = 0.015 rad
    res = sector_gate([10_010.0, 10_020.0, 10_000.0], [0.11, 0.1, 0.13],
                      10_000.0, 0.1, 3.0, 0.003, 4.0, 0.004, K_R=3.0, K_az=3.0)
    np.testing.assert_allclose(res.statistic, [10 / 15, 20 / 15, 0.03 / 0.015], rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, False])


@pytest.mark.parametrize(
    ("az", "az_pred"),
    [(-179.9, 179.9), (179.9, -179.9), (180.0, -180.0), (-180.0, 179.8)],
    ids=["below-seam", "above-seam", "pi-vs-minus-pi", "minus-pi-vs-179.8"],
)
def test_sector_gate_wraps_azimuth_across_180_degrees(az, az_pred):
    sigma = math.radians(0.2)
    res = sector_gate(5000.0, math.radians(az), 5000.0, math.radians(az_pred),
                      5.0, sigma, 5.0, sigma, 3.0, 3.0)
    gap = abs((az - az_pred + 180.0) % 360.0 - 180.0)
    np.testing.assert_allclose(res.statistic, [gap / (3.0 * math.sqrt(2.0) * 0.2)], atol=1e-9)
    assert res.inside.tolist() == [True]


def test_first_association_gate_hand_computed():
    # W_R = 25 + 3 sqrt(50) = 46.21 m; W_az = asin(25 / 10000) + 3 sqrt(2) 3e-4 rad
    W_R = 25.0 + 3.0 * math.sqrt(50.0)
    W_az = math.asin(0.0025) + 3.0 * math.sqrt(2.0) * 3e-4
    res = first_association_gate(10_000.0, 0.5, [10_040.0, 10_000.0, 9_950.0],
                                 [0.5, 0.505, 0.5 - 0.5 * W_az], 1.0, 25.0,
                                 5.0, 3e-4, 5.0, 3e-4, 3.0, 3.0)
    np.testing.assert_allclose(res.statistic, [40.0 / W_R, 0.005 / W_az, 50.0 / W_R],
                               rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, False])


def test_first_association_azimuth_window_is_a_half_turn_near_the_sensor():
    # r1 = 10 m < v_max tau = 25 m: any bearing change up to pi/2 + K sigma is allowed
    res = first_association_gate([10.0, 0.0], 0.0, [20.0, 20.0], [1.5, 1.5], 1.0, 25.0,
                                 5.0, 3e-4, 5.0, 3e-4, 3.0, 3.0)
    np.testing.assert_array_equal(res.inside, [True, True])
    W_az = math.pi / 2 + 3.0 * math.sqrt(2.0) * 3e-4
    np.testing.assert_allclose(res.statistic, max(10.0 / (25.0 + 3.0 * math.sqrt(50.0)),
                                                  1.5 / W_az))


# ---------------------------------------------------------------- vectorized vs reference

N_RANDOM = 1000


def test_ring_gate_matches_reference():
    rng = np.random.default_rng(101)
    z1 = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z2 = z1 + rng.uniform(-3000.0, 3000.0, (N_RANDOM, 2))
    res = ring_gate(z1, z2, 5.0, 100.0, 500.0)
    ref = [ring_ref(a, b, 5.0, 100.0, 500.0) for a, b in zip(z1, z2, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_expanded_gate_matches_reference():
    rng = np.random.default_rng(102)
    sensor = rng.uniform(-5000.0, 5000.0, (N_RANDOM, 2))
    z1 = sensor + rng.uniform(-4e4, 4e4, (N_RANDOM, 2))
    z2 = z1 + rng.uniform(-1500.0, 1500.0, (N_RANDOM, 2))
    sigma_r = rng.uniform(10.0, 300.0, N_RANDOM)
    sigma_az = rng.uniform(1e-3, 2e-2, N_RANDOM)
    res = expanded_gate(z1, z2, 5.0, 200.0, sigma_r, sigma_az, 0.95, sensor=sensor)
    ref = [expanded_ref(*row, 5.0, 200.0, sr, saz, 0.95, s)
           for *row, sr, saz, s in zip(z1, z2, sigma_r, sigma_az, sensor, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def _combined_inputs(rng, n):
    z1 = rng.uniform(-1e4, 1e4, (n, 2))
    heading = rng.uniform(-np.pi, np.pi, n)
    dist = rng.uniform(0.0, 800.0, n)
    z2 = z1 + dist[:, None] * np.stack([np.sin(heading), np.cos(heading)], axis=1)
    z2[:10] = z1[:10]  # exact d = 0
    return z1, random_spd(rng, n, 40.0), z2, random_spd(rng, n, 40.0)


def test_combined_gate_matches_reference():
    rng = np.random.default_rng(103)
    z1, P1, z2, P2 = _combined_inputs(rng, N_RANDOM)
    res = combined_gate(z1, P1, z2, P2, 5.0, 30.0, 100.0, 0.9)
    ref = [combined_ref(*row, 5.0, 30.0, 100.0, 0.9) for row in zip(z1, P1, z2, P2, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)
    np.testing.assert_array_equal(res.stage, [row[2] for row in ref])
    assert set(res.stage.tolist()) == set(GateStage)
    np.testing.assert_array_equal(res.inside, res.statistic <= res.threshold)


def test_ellipse_gate_matches_reference():
    rng = np.random.default_rng(104)
    z_pred = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z = z_pred + rng.normal(0.0, 150.0, (N_RANDOM, 2))
    S = random_spd(rng, N_RANDOM, 60.0)
    res = ellipse_gate(z, z_pred, S, 0.99)
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
    res = ellipse_gate(z, [0.0, 0.0], S, 0.9)
    ref = [ellipse_ref(row, np.zeros(2), s, 0.9) for row, s in zip(z, S, strict=True)]
    np.testing.assert_allclose(res.statistic, [r[1] for r in ref], rtol=1e-6)
    assert np.all(res.statistic >= 0.0)


def test_rectangular_gate_matches_reference():
    rng = np.random.default_rng(106)
    z_pred = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z = z_pred + rng.normal(0.0, 40.0, (N_RANDOM, 2))
    sigma_x, sigma_y = rng.uniform(5.0, 30.0, (2, N_RANDOM))
    res = rectangular_gate(z, z_pred, sigma_x, sigma_y, 2.5)
    ref = [rectangular_ref(*row, 2.5) for row in zip(z, z_pred, sigma_x, sigma_y, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_sector_gate_matches_reference():
    rng = np.random.default_rng(107)
    r_pred = rng.uniform(500.0, 2e4, N_RANDOM)
    az_pred = rng.uniform(-np.pi, np.pi, N_RANDOM)
    r = r_pred + rng.normal(0.0, 20.0, N_RANDOM)
    az = az_pred + rng.normal(0.0, 0.01, N_RANDOM)
    sigmas = [rng.uniform(1.0, 10.0, N_RANDOM), rng.uniform(1e-3, 4e-3, N_RANDOM),
              rng.uniform(1.0, 10.0, N_RANDOM), rng.uniform(1e-3, 4e-3, N_RANDOM)]
    res = sector_gate(r, az, r_pred, az_pred, *sigmas, 2.0, 2.0)
    ref = [sector_ref(*row, 2.0, 2.0) for row in zip(r, az, r_pred, az_pred, *sigmas, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_first_association_gate_matches_reference():
    rng = np.random.default_rng(108)
    r1 = rng.uniform(0.0, 2e4, N_RANDOM)
    r1[:5] = 0.0
    az1 = rng.uniform(-np.pi, np.pi, N_RANDOM)
    r2 = np.abs(r1 + rng.normal(0.0, 40.0, N_RANDOM))
    az2 = az1 + rng.normal(0.0, 0.01, N_RANDOM)
    sigmas = [rng.uniform(1.0, 10.0, N_RANDOM), rng.uniform(1e-4, 1e-3, N_RANDOM),
              rng.uniform(1.0, 10.0, N_RANDOM), rng.uniform(1e-4, 1e-3, N_RANDOM)]
    res = first_association_gate(r1, az1, r2, az2, 1.0, 25.0, *sigmas, 3.0, 3.0)
    ref = [first_association_ref(a, b, c, d, 1.0, 25.0, *s, 3.0, 3.0)
           for a, b, c, d, *s in zip(r1, az1, r2, az2, *sigmas, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


# ---------------------------------------------------------------- broadcasting and purity


def test_one_first_mark_against_many_candidates_equals_tiled_input():
    rng = np.random.default_rng(109)
    _, _, z2, P2 = _combined_inputs(rng, 200)
    z1 = z2[0] + 10.0
    P1 = random_spd(rng, 1, 40.0)[0]
    tiled = combined_gate(np.tile(z1, (200, 1)), np.tile(P1, (200, 1, 1)), z2, P2,
                          5.0, 30.0, 100.0, 0.9)
    broadcast = combined_gate(z1, P1, z2, P2, 5.0, 30.0, 100.0, 0.9)
    for field in ("inside", "statistic", "stage"):
        np.testing.assert_array_equal(getattr(broadcast, field), getattr(tiled, field))
    ring = ring_gate(z1, z2, 5.0, 30.0, 100.0)
    np.testing.assert_array_equal(ring.inside, ring_gate(np.tile(z1, (200, 1)), z2, 5.0,
                                                         30.0, 100.0).inside)
    ellipse = ellipse_gate(z2, z1, P1, 0.9)
    np.testing.assert_array_equal(ellipse.statistic,
                                  ellipse_gate(z2, np.tile(z1, (200, 1)), P1, 0.9).statistic)


def test_per_pair_covariance_with_one_candidate_broadcasts():
    rng = np.random.default_rng(110)
    S = random_spd(rng, 7, 10.0)
    res = ellipse_gate([1.0, 2.0], [0.0, 0.0], S, 0.9)
    assert res.statistic.shape == (7,)
    np.testing.assert_allclose(res.statistic,
                               [ellipse_ref(np.array([1.0, 2.0]), np.zeros(2), s, 0.9)[1]
                                for s in S], rtol=1e-12)


@pytest.mark.parametrize(
    "call",
    [
        lambda: ring_gate([0.0, 0.0], [300.0, 400.0], 5.0, 20.0, 500.0),
        lambda: combined_gate([0.0, 0.0], np.eye(2), [3.0, 4.0], np.eye(2), 1.0, 0.0, 9.0, 0.9),
        lambda: ellipse_gate([1.0, 1.0], [0.0, 0.0], np.eye(2), 0.9),
        lambda: expanded_gate([0.0, 1e4], [0.0, 1e4], 5.0, 100.0, 10.0, 0.001, 0.9),
        lambda: rectangular_gate([1.0, 1.0], [0.0, 0.0], 1.0, 1.0, 3.0),
        lambda: sector_gate(1e3, 0.1, 1e3, 0.1, 1.0, 1e-3, 1.0, 1e-3, 3.0, 3.0),
        lambda: first_association_gate(1e3, 0.1, 1e3, 0.1, 1.0, 5.0, 1.0, 1e-3, 1.0, 1e-3,
                                       3.0, 3.0),
    ],
    ids=["ring", "combined", "ellipse", "expanded", "rectangular", "sector", "first"],
)
def test_unbatched_input_gives_one_pair(call):
    res = call()
    assert isinstance(res, GateResult)
    assert res.inside.shape == res.statistic.shape == (1,)
    assert isinstance(res.threshold, float)
    assert res.inside.tolist() == [True]


@pytest.mark.parametrize(
    "call",
    [
        lambda e, E, o: ring_gate([0.0, 0.0], e, 1.0, 0.0, 1.0),
        lambda e, E, o: combined_gate([0.0, 0.0], np.eye(2), e, E, 1.0, 0.0, 1.0, 0.9),
        lambda e, E, o: ellipse_gate(e, [0.0, 0.0], E, 0.9),
        lambda e, E, o: expanded_gate([0.0, 1.0], e, 1.0, 1.0, 1.0, 0.1, 0.9),
        lambda e, E, o: rectangular_gate(e, [0.0, 0.0], 1.0, 1.0, 3.0),
        lambda e, E, o: sector_gate(o, o, 1.0, 0.0, 1.0, 0.1, 1.0, 0.1, 3.0, 3.0),
        lambda e, E, o: first_association_gate(1.0, 0.0, o, o, 1.0, 1.0, 1.0, 0.1, 1.0, 0.1,
                                               3.0, 3.0),
    ],
    ids=["ring", "combined", "ellipse", "expanded", "rectangular", "sector", "first"],
)
def test_no_candidates_gives_empty_result(call):
    res = call(np.empty((0, 2)), np.empty((0, 2, 2)), np.empty(0))
    assert res.inside.shape == res.statistic.shape == (0,)


def test_gate_result_is_frozen():
    res = ring_gate([0.0, 0.0], [1.0, 0.0], 1.0, 0.0, 2.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.threshold = 3.0


def test_gates_accept_read_only_inputs_and_leave_them_unchanged():
    rng = np.random.default_rng(111)
    inputs = _combined_inputs(rng, 50)
    saved = [a.copy() for a in inputs]
    for a in inputs:
        a.flags.writeable = False
    z1, P1, z2, P2 = inputs
    combined_gate(z1, P1, z2, P2, 5.0, 30.0, 100.0, 0.9)
    ellipse_gate(z2, z1, P1, 0.9)
    expanded_gate(z1, z2, 5.0, 100.0, 10.0, 0.001, 0.9)
    for a, b in zip(inputs, saved, strict=True):
        np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------- validation errors


def _combined_args(**override):
    rng = np.random.default_rng(112)
    z1, P1, z2, P2 = _combined_inputs(rng, 8)
    args = {"z1": z1, "P1": P1, "z2": z2, "P2": P2, "tau": 5.0, "v_min": 30.0,
            "v_max": 100.0, "P_G": 0.9}
    args.update(override)
    return args


def _with(array, index, value):
    out = np.array(array, dtype=float)
    out[index] = value
    return out


@pytest.mark.parametrize(
    ("override", "error", "message", "index"),
    [
        (lambda a: {"P2": _with(a["P2"], (3, 0, 1), np.nan)}, NonFiniteError,
         r"^P2\[3\]: must be finite, got \[\[", 3),
        (lambda a: {"z1": _with(a["z1"], (6, 1), np.inf)}, NonFiniteError,
         r"^z1\[6\]: must be finite, got \[.*inf\]", 6),
        (lambda a: {"z1": [np.nan, 0.0]}, NonFiniteError, r"^z1: must be finite", None),
        (lambda a: {"P1": _with(a["P1"], (2, 0, 1), a["P1"][2, 0, 1] + 1.0)}, CovarianceError,
         r"^P1\[2\]: is not symmetric: \[\[", 2),
        (lambda a: {"P2": _with(a["P2"], (5, 1, 1), -1.0)}, CovarianceError,
         r"^P2\[5\]: is not positive definite \(det = -", 5),
        (lambda a: {"P1": np.array([[1.0, 2.0], [2.0, 1.0]])}, CovarianceError,
         r"^P1: is not positive definite \(det = -3.0\): \[\[1.0, 2.0\], \[2.0, 1.0\]\]", None),
        (lambda a: {"v_min": 600.0, "v_max": 500.0}, ParameterError,
         r"^v_min: v_min \(600.0\) exceeds v_max \(500.0\)$", None),
        (lambda a: {"v_min": -1.0}, ParameterError, r"^v_min: must be non-negative, got -1.0$",
         None),
        (lambda a: {"tau": 0.0}, ParameterError, r"^tau: must be positive, got 0.0$", None),
        (lambda a: {"tau": -5.0}, ParameterError, r"^tau: must be positive, got -5.0$", None),
        (lambda a: {"tau": np.ones(8)}, ParameterError, r"^tau: must be a scalar, got shape",
         None),
        (lambda a: {"tau": np.nan}, NonFiniteError, r"^tau: must be finite", None),
        (lambda a: {"P_G": 1.0}, ParameterError, r"^P_G: must lie in the open interval",
         None),
        (lambda a: {"P_G": np.nan}, ParameterError, r"^P_G: must lie in the open interval",
         None),
        (lambda a: {"P2": a["P2"][:4]}, ParameterError,
         r"^P2: has batch length 4 but z2 has 8$", None),
        (lambda a: {"z2": a["z2"][:1]}, ParameterError,
         r"^z2: has batch length 1 but P1 has 8$", None),
        (lambda a: {"z2": a["z2"][None]}, ParameterError,
         r"^z2: has batch shape \(1, 8\); gates take one leading batch axis", None),
        (lambda a: {"z1": np.zeros((8, 3))}, ParameterError,
         r"^z1: must have shape \(\.\.\., 2\), got shape \(8, 3\)$", None),
        (lambda a: {"P1": np.eye(3)}, ParameterError,
         r"^P1: must have shape \(\.\.\., 2, 2\), got shape \(3, 3\)$", None),
        (lambda a: {"z2": "north"}, ParameterError, r"^z2: must be real numbers", None),
    ],
    ids=["nan-P2", "inf-z1", "nan-unbatched", "asymmetric-P1", "non-pd-P2", "non-pd-unbatched",
         "v_min>v_max", "v_min<0", "tau=0", "tau<0", "tau-array", "tau-nan", "P_G=1", "P_G-nan",
         "length-mismatch", "length-one", "two-batch-axes", "wrong-point-shape",
         "wrong-cov-shape", "not-numbers"],
)
def test_combined_gate_validation_errors(override, error, message, index):
    args = _combined_args()
    args.update(override(args))
    with pytest.raises(error, match=message) as info:
        combined_gate(**args)
    assert info.value.index == index
    assert isinstance(info.value, PlotgateError) and isinstance(info.value, ValueError)


def test_rounding_asymmetry_is_accepted_and_upper_element_read():
    P = np.array([[4.0, 1.0], [1.0 + 1e-12, 3.0]])
    res = ellipse_gate([1.0, 1.0], [0.0, 0.0], P, 0.9)
    S = np.array([[4.0, 1.0], [1.0, 3.0]])
    expected = ellipse_ref(np.ones(2), np.zeros(2), S, 0.9)[1]
    assert res.statistic[0] == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: expanded_gate([0.0, 1e4], [[0.0, 1e4]] * 3, 5.0, 100.0, [10.0, -1.0, 2.0],
                               0.001, 0.9), ParameterError, r"^sigma_r\[1\]: must be positive"),
        (lambda: expanded_gate([0.0, 1e4], [0.0, 1e4], 5.0, 100.0, 10.0, 0.0, 0.9),
         ParameterError, r"^sigma_az: must be positive, got 0.0"),
        (lambda: expanded_gate([0.0, 1e4], [0.0, 1e4], 5.0, -1.0, 10.0, 1e-3, 0.9),
         ParameterError, r"^v_max: must be non-negative"),
        (lambda: expanded_gate([0.0, 1e4], [0.0, 1e4], 5.0, 100.0, 10.0, 1e-3, 1.2),
         ParameterError, r"^p: must lie in the open interval"),
        (lambda: expanded_gate([0.0, 1e4], [0.0, 1e4], 5.0, 100.0, 10.0, 1e-3, [0.9, 0.9]),
         ParameterError, r"^p: must be a scalar"),
        (lambda: expanded_gate([[0.0, 1e4], [5.0, 5.0]], [0.0, 1e4], 5.0, 100.0, 10.0, 1e-3,
                               0.9, sensor=[5.0, 5.0]),
         GeometryError, r"^z1\[1\]: is at the sensor"),
        (lambda: ellipse_gate([0.0, 1.0], [0.0, 0.0], np.zeros((2, 2)), 0.9),
         CovarianceError, r"^S: is not positive definite"),
        (lambda: rectangular_gate([0.0, 1.0], [0.0, 0.0], 1.0, 1.0, 0.0),
         ParameterError, r"^k: must be positive, got 0.0"),
        (lambda: rectangular_gate([0.0, 1.0], [0.0, 0.0], 1.0, [1.0, np.nan], 3.0),
         NonFiniteError, r"^sigma_y\[1\]: must be finite, got nan"),
        (lambda: sector_gate(-1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3, 3.0, 3.0),
         ParameterError, r"^r: must be non-negative, got -1.0"),
        (lambda: sector_gate(1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, -1e-3, 3.0, 3.0),
         ParameterError, r"^sigma_az_pred: must be positive"),
        (lambda: sector_gate(1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3, 3.0, 0.0),
         ParameterError, r"^K_az: must be positive"),
        (lambda: sector_gate(np.ones(3), np.zeros(2), 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3, 3.0, 3.0),
         ParameterError, r"^az: has batch length 2 but r has 3"),
        (lambda: first_association_gate(1.0, 0.0, 1.0, 0.0, 0.0, 5.0, 1.0, 1e-3, 1.0, 1e-3,
                                        3.0, 3.0), ParameterError, r"^tau: must be positive"),
        (lambda: first_association_gate(1.0, 0.0, 1.0, 0.0, 1.0, 5.0, 1.0, 1e-3, 1.0, 1e-3,
                                        -3.0, 3.0), ParameterError, r"^K_R: must be positive"),
        (lambda: ring_gate([0.0, 0.0], [1.0, 1.0], 1.0, 3.0, 2.0),
         ParameterError, r"^v_min: v_min \(3.0\) exceeds v_max \(2.0\)"),
    ],
    ids=["sigma_r-row", "sigma_az-zero", "v_max-negative", "p>1", "p-array", "z1-at-sensor",
         "singular-S", "k=0", "nan-sigma_y", "negative-range", "sigma_az_pred", "K_az=0",
         "sector-lengths", "first-tau", "first-K_R", "ring-speeds"],
)
def test_gate_validation_errors(call, error, message):
    with pytest.raises(error, match=message):
        call()
