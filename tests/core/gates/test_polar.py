"""Tests of core.gates.polar (Mu et al.; the secondary-processing textbook): sector and
first-association gates."""

import math

import numpy as np
import pytest
from gate_helpers import N_RANDOM, assert_matches_reference

from plotgate.core import FirstAssociationGate, SectorGate

# ---------------------------------------------------------------- scalar references


def _angle_gap(a, b):
    return abs(math.remainder(a - b, 2.0 * math.pi))


def sector_ref(r, az, r_pred, az_pred, s_r, s_az, s_rp, s_azp, K_R, K_az):
    statistic = max(
        abs(r - r_pred) / (K_R * math.sqrt(s_r**2 + s_rp**2)),
        _angle_gap(az, az_pred) / (K_az * math.sqrt(s_az**2 + s_azp**2)),
    )
    return statistic <= 1.0, statistic


def first_association_ref(r1, az1, r2, az2, tau, v_max, s_r1, s_az1, s_r2, s_az2, K_R, K_az):
    W_R = v_max * tau + K_R * math.sqrt(s_r1**2 + s_r2**2)
    turn = math.asin(min(1.0, v_max * tau / r1)) if r1 > 0 else math.pi / 2
    W_az = turn + K_az * math.sqrt(s_az1**2 + s_az2**2)
    statistic = max(abs(r2 - r1) / W_R, _angle_gap(az2, az1) / W_az)
    return statistic <= 1.0, statistic


# ---------------------------------------------------------------- hand-computed cases


def test_sector_gate_hand_computed():
    # W_R = 3 sqrt(3^2 + 4^2) = 15 m, W_az = 3 sqrt(0.003^2 + 0.004^2) = 0.015 rad
    res = SectorGate(3.0, 3.0).test(
        [10_010.0, 10_020.0, 10_000.0], [0.11, 0.1, 0.13], 10_000.0, 0.1, 3.0, 0.003, 4.0, 0.004
    )
    np.testing.assert_allclose(res.statistic, [10 / 15, 20 / 15, 0.03 / 0.015], rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, False])


@pytest.mark.parametrize(
    ("az", "az_pred"),
    [(-179.9, 179.9), (179.9, -179.9), (180.0, -180.0), (-180.0, 179.8)],
    ids=["below-seam", "above-seam", "pi-vs-minus-pi", "minus-pi-vs-179.8"],
)
def test_sector_gate_wraps_azimuth_across_180_degrees(az, az_pred):
    sigma = math.radians(0.2)
    res = SectorGate(3.0, 3.0).test(
        5000.0, math.radians(az), 5000.0, math.radians(az_pred), 5.0, sigma, 5.0, sigma
    )
    gap = abs((az - az_pred + 180.0) % 360.0 - 180.0)
    np.testing.assert_allclose(res.statistic, [gap / (3.0 * math.sqrt(2.0) * 0.2)], atol=1e-9)
    assert res.inside.tolist() == [True]


def test_first_association_gate_hand_computed():
    # W_R = 25 + 3 sqrt(50) = 46.21 m; W_az = asin(25 / 10000) + 3 sqrt(2) 3e-4 rad
    W_R = 25.0 + 3.0 * math.sqrt(50.0)
    W_az = math.asin(0.0025) + 3.0 * math.sqrt(2.0) * 3e-4
    res = FirstAssociationGate(25.0, 3.0, 3.0).test(
        10_000.0,
        0.5,
        [10_040.0, 10_000.0, 9_950.0],
        [0.5, 0.505, 0.5 - 0.5 * W_az],
        1.0,
        5.0,
        3e-4,
        5.0,
        3e-4,
    )
    np.testing.assert_allclose(res.statistic, [40.0 / W_R, 0.005 / W_az, 50.0 / W_R], rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, False])


def test_first_association_azimuth_window_is_a_half_turn_near_the_sensor():
    # r1 = 10 m < v_max tau = 25 m: any bearing change up to pi/2 + K sigma is allowed
    res = FirstAssociationGate(25.0, 3.0, 3.0).test(
        [10.0, 0.0], 0.0, [20.0, 20.0], [1.5, 1.5], 1.0, 5.0, 3e-4, 5.0, 3e-4
    )
    np.testing.assert_array_equal(res.inside, [True, True])
    W_az = math.pi / 2 + 3.0 * math.sqrt(2.0) * 3e-4
    np.testing.assert_allclose(
        res.statistic, max(10.0 / (25.0 + 3.0 * math.sqrt(50.0)), 1.5 / W_az)
    )


# ---------------------------------------------------------------- vectorized vs reference


def test_sector_gate_matches_reference():
    rng = np.random.default_rng(107)
    r_pred = rng.uniform(500.0, 2e4, N_RANDOM)
    az_pred = rng.uniform(-np.pi, np.pi, N_RANDOM)
    r = r_pred + rng.normal(0.0, 20.0, N_RANDOM)
    az = az_pred + rng.normal(0.0, 0.01, N_RANDOM)
    sigmas = [
        rng.uniform(1.0, 10.0, N_RANDOM),
        rng.uniform(1e-3, 4e-3, N_RANDOM),
        rng.uniform(1.0, 10.0, N_RANDOM),
        rng.uniform(1e-3, 4e-3, N_RANDOM),
    ]
    res = SectorGate(2.0, 2.0).test(r, az, r_pred, az_pred, *sigmas)
    ref = [sector_ref(*row, 2.0, 2.0) for row in zip(r, az, r_pred, az_pred, *sigmas, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_first_association_gate_matches_reference():
    rng = np.random.default_rng(108)
    r1 = rng.uniform(0.0, 2e4, N_RANDOM)
    r1[:5] = 0.0
    az1 = rng.uniform(-np.pi, np.pi, N_RANDOM)
    r2 = np.abs(r1 + rng.normal(0.0, 40.0, N_RANDOM))
    az2 = az1 + rng.normal(0.0, 0.01, N_RANDOM)
    sigmas = [
        rng.uniform(1.0, 10.0, N_RANDOM),
        rng.uniform(1e-4, 1e-3, N_RANDOM),
        rng.uniform(1.0, 10.0, N_RANDOM),
        rng.uniform(1e-4, 1e-3, N_RANDOM),
    ]
    res = FirstAssociationGate(25.0, 3.0, 3.0).test(r1, az1, r2, az2, 1.0, *sigmas)
    ref = [
        first_association_ref(a, b, c, d, 1.0, 25.0, *s, 3.0, 3.0)
        for a, b, c, d, *s in zip(r1, az1, r2, az2, *sigmas, strict=True)
    ]
    assert_matches_reference(res, ref, N_RANDOM)
