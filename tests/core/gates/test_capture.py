"""Tests of core.gates.capture (Konovalov): ring, expanded and combined gates."""

import math

import numpy as np
import pytest
from gate_helpers import N_RANDOM, assert_matches_reference, combined_inputs
from scipy import stats

from plotgate.core import (
    CombinedGate,
    CovarianceError,
    ExpandedGate,
    GateStage,
    NonFiniteError,
    ParameterError,
    PlotgateError,
    RingGate,
)

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


# ---------------------------------------------------------------- hand-computed cases


def test_ring_gate_hand_computed():
    # R_min = 20 * 5 = 100 m, R_max = 500 * 5 = 2500 m; both bounds inclusive
    z2 = [[300.0, 400.0], [30.0, 40.0], [3000.0, 4000.0], [60.0, 80.0], [1500.0, 2000.0]]
    res = RingGate(20.0, 500.0).test([0.0, 0.0], z2, tau=5.0)
    np.testing.assert_array_equal(res.inside, [True, False, False, True, True])
    np.testing.assert_allclose(res.statistic, [500.0, 50.0, 5000.0, 100.0, 2500.0])
    assert res.threshold == 2500.0 and res.stage is None


def test_combined_gate_hand_computed_with_correlated_B():
    # B = P1 + P2 = [[1e4, 4e3], [4e3, 6e3]], |B| = 4.4e7; R_min = 100 m, R_max = 500 m
    P = np.array([[5000.0, 2000.0], [2000.0, 3000.0]])
    z2 = np.array(
        [
            [300.0, 0.0],  # |d| = 300: ring
            [600.0, 0.0],  # nu = (100, 0): rho = 6e3 * 1e4 / 4.4e7 = 15/11
            [0.0, 700.0],  # nu = (0, 200): rho = 1e4 * 4e4 / 4.4e7 = 100/11 > gamma
            [30.0, 40.0],  # |d| = 50, nu = -50 (0.6, 0.8) = (-30, -40): rho = 59/220
            [0.0, 0.0],  # d = 0: rho = R_min^2 / lambda_max(B)
        ]
    )
    res = CombinedGate(10.0, 50.0, 0.9).test([0.0, 0.0], P, z2, P, tau=10.0)
    lambda_max = 8000.0 + math.sqrt(2000.0**2 + 4000.0**2)
    np.testing.assert_allclose(
        res.statistic, [0.0, 15 / 11, 100 / 11, 59 / 220, 100.0**2 / lambda_max], rtol=1e-12
    )
    np.testing.assert_array_equal(res.inside, [True, True, False, True, True])
    assert res.stage.dtype == np.int8
    assert res.stage.tolist() == [
        GateStage.RING,
        GateStage.OUTER_ELLIPSE,
        GateStage.NONE,
        GateStage.INNER_ELLIPSE,
        GateStage.INNER_ELLIPSE,
    ]
    assert res.threshold == pytest.approx(4.605, abs=1e-3)


def test_combined_gate_ring_bounds_are_inclusive_and_d_zero_with_v_min_zero_is_ring():
    P = np.eye(2)
    res = CombinedGate(10.0, 50.0, 0.9).test([0.0, 0.0], P, [[100.0, 0.0], [0.0, 500.0]], P, 10.0)
    assert res.stage.tolist() == [GateStage.RING, GateStage.RING]
    res = CombinedGate(0.0, 50.0, 0.9).test([5.0, 5.0], P, [5.0, 5.0], P, 10.0)
    assert res.stage.tolist() == [GateStage.RING] and res.statistic.tolist() == [0.0]


def test_combined_gate_d_zero_far_inside_inner_circle_is_rejected():
    # rho = R_min^2 / lambda_max(B) = 1000^2 / 2 is far above gamma
    res = CombinedGate(100.0, 500.0, 0.9).test([0.0, 0.0], np.eye(2), [0.0, 0.0], np.eye(2), 10.0)
    assert res.stage.tolist() == [GateStage.NONE]
    assert res.statistic[0] == pytest.approx(1000.0**2 / 2.0)


def test_expanded_gate_hand_computed_north():
    # LOS due north: a = 500 + K_g 200 = 929.19 m along it (y), b = 500 + K_g 100 = 714.60 m
    res = ExpandedGate(100.0, 0.9).test(
        [0.0, 10_000.0],
        [[0.0, 10_900.0], [900.0, 10_000.0]],
        tau=5.0,
        sigma_r=200.0,
        sigma_az=0.01,
    )
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
    res = ExpandedGate(100.0, 0.9).test(z1, z2, 5.0, 200.0, 0.005, sensor=sensor)
    a, b_axis = 500.0 + K_G_09 * 200.0, 500.0 + K_G_09 * 40.0
    expected = [(800.0 / a) ** 2, (800.0 / b_axis) ** 2, (800.0 / a) ** 2]
    np.testing.assert_allclose(res.statistic, expected, rtol=1e-9)
    np.testing.assert_array_equal(res.inside, [True, False, True])


# ---------------------------------------------------------------- vectorized vs reference


def test_ring_gate_matches_reference():
    rng = np.random.default_rng(101)
    z1 = rng.uniform(-1e4, 1e4, (N_RANDOM, 2))
    z2 = z1 + rng.uniform(-3000.0, 3000.0, (N_RANDOM, 2))
    res = RingGate(100.0, 500.0).test(z1, z2, 5.0)
    ref = [ring_ref(a, b, 5.0, 100.0, 500.0) for a, b in zip(z1, z2, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)


def test_expanded_gate_matches_reference():
    rng = np.random.default_rng(102)
    sensor = rng.uniform(-5000.0, 5000.0, (N_RANDOM, 2))
    z1 = sensor + rng.uniform(-4e4, 4e4, (N_RANDOM, 2))
    z2 = z1 + rng.uniform(-1500.0, 1500.0, (N_RANDOM, 2))
    sigma_r = rng.uniform(10.0, 300.0, N_RANDOM)
    sigma_az = rng.uniform(1e-3, 2e-2, N_RANDOM)
    res = ExpandedGate(200.0, 0.95).test(z1, z2, 5.0, sigma_r, sigma_az, sensor=sensor)
    ref = [
        expanded_ref(*row, 5.0, 200.0, sr, saz, 0.95, s)
        for *row, sr, saz, s in zip(z1, z2, sigma_r, sigma_az, sensor, strict=True)
    ]
    assert_matches_reference(res, ref, N_RANDOM)


def test_combined_gate_matches_reference():
    rng = np.random.default_rng(103)
    z1, P1, z2, P2 = combined_inputs(rng, N_RANDOM)
    res = CombinedGate(30.0, 100.0, 0.9).test(z1, P1, z2, P2, 5.0)
    ref = [combined_ref(*row, 5.0, 30.0, 100.0, 0.9) for row in zip(z1, P1, z2, P2, strict=True)]
    assert_matches_reference(res, ref, N_RANDOM)
    np.testing.assert_array_equal(res.stage, [row[2] for row in ref])
    assert set(res.stage.tolist()) == set(GateStage)
    np.testing.assert_array_equal(res.inside, res.statistic <= res.threshold)


# ---------------------------------------------------------------- validation errors


def _combined_args(**override):
    rng = np.random.default_rng(112)
    z1, P1, z2, P2 = combined_inputs(rng, 8)
    args = {
        "z1": z1,
        "P1": P1,
        "z2": z2,
        "P2": P2,
        "tau": 5.0,
        "v_min": 30.0,
        "v_max": 100.0,
        "P_G": 0.9,
    }
    args.update(override)
    return args


def _with(array, index, value):
    out = np.array(array, dtype=float)
    out[index] = value
    return out


@pytest.mark.parametrize(
    ("override", "error", "message", "index"),
    [
        (
            lambda a: {"P2": _with(a["P2"], (3, 0, 1), np.nan)},
            NonFiniteError,
            r"^P2\[3\]: must be finite, got \[\[",
            3,
        ),
        (
            lambda a: {"z1": _with(a["z1"], (6, 1), np.inf)},
            NonFiniteError,
            r"^z1\[6\]: must be finite, got \[.*inf\]",
            6,
        ),
        (lambda a: {"z1": [np.nan, 0.0]}, NonFiniteError, r"^z1: must be finite", None),
        (
            lambda a: {"P1": _with(a["P1"], (2, 0, 1), a["P1"][2, 0, 1] + 1.0)},
            CovarianceError,
            r"^P1\[2\]: is not symmetric: \[\[",
            2,
        ),
        (
            lambda a: {"P2": _with(a["P2"], (5, 1, 1), -1.0)},
            CovarianceError,
            r"^P2\[5\]: is not positive definite \(det = -",
            5,
        ),
        (
            lambda a: {"P1": np.array([[1.0, 2.0], [2.0, 1.0]])},
            CovarianceError,
            r"^P1: is not positive definite \(det = -3.0\): \[\[1.0, 2.0\], \[2.0, 1.0\]\]",
            None,
        ),
        (
            lambda a: {"v_min": 600.0, "v_max": 500.0},
            ParameterError,
            r"^v_min: v_min \(600.0\) exceeds v_max \(500.0\)$",
            None,
        ),
        (
            lambda a: {"v_min": -1.0},
            ParameterError,
            r"^v_min: must be non-negative, got -1.0$",
            None,
        ),
        (lambda a: {"tau": 0.0}, ParameterError, r"^tau: must be positive, got 0.0$", None),
        (lambda a: {"tau": -5.0}, ParameterError, r"^tau: must be positive, got -5.0$", None),
        (
            lambda a: {"tau": np.ones(8)},
            ParameterError,
            r"^tau: must be a scalar, got shape",
            None,
        ),
        (lambda a: {"tau": np.nan}, NonFiniteError, r"^tau: must be finite", None),
        (lambda a: {"P_G": 1.0}, ParameterError, r"^P_G: must lie in the open interval", None),
        (lambda a: {"P_G": np.nan}, ParameterError, r"^P_G: must lie in the open interval", None),
        (
            lambda a: {"P2": a["P2"][:4]},
            ParameterError,
            r"^P2: has batch length 4 but z2 has 8$",
            None,
        ),
        (
            lambda a: {"z2": a["z2"][:1]},
            ParameterError,
            r"^z2: has batch length 1 but P1 has 8$",
            None,
        ),
        (
            lambda a: {"z2": a["z2"][None]},
            ParameterError,
            r"^z2: has batch shape \(1, 8\); gates take one leading batch axis",
            None,
        ),
        (
            lambda a: {"z1": np.zeros((8, 3))},
            ParameterError,
            r"^z1: must have shape \(\.\.\., 2\), got shape \(8, 3\)$",
            None,
        ),
        (
            lambda a: {"P1": np.eye(3)},
            ParameterError,
            r"^P1: must have shape \(\.\.\., 2, 2\), got shape \(3, 3\)$",
            None,
        ),
        (lambda a: {"z2": "north"}, ParameterError, r"^z2: must be real numbers", None),
    ],
    ids=[
        "nan-P2",
        "inf-z1",
        "nan-unbatched",
        "asymmetric-P1",
        "non-pd-P2",
        "non-pd-unbatched",
        "v_min>v_max",
        "v_min<0",
        "tau=0",
        "tau<0",
        "tau-array",
        "tau-nan",
        "P_G=1",
        "P_G-nan",
        "length-mismatch",
        "length-one",
        "two-batch-axes",
        "wrong-point-shape",
        "wrong-cov-shape",
        "not-numbers",
    ],
)
def test_combined_gate_validation_errors(override, error, message, index):
    args = _combined_args()
    args.update(override(args))
    gate = CombinedGate(args.pop("v_min"), args.pop("v_max"), args.pop("P_G"))
    with pytest.raises(error, match=message) as info:
        gate.test(**args)
    assert info.value.index == index
    assert isinstance(info.value, PlotgateError) and isinstance(info.value, ValueError)
