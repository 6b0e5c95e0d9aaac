"""Tests of core.frames: round trips, Jacobian oracles and angle wrapping."""

import math

import numpy as np
import pytest

from plotgate.core import (
    GeometryError,
    NonFiniteError,
    ParameterError,
    cartesian_covariance_to_polar,
    cartesian_to_polar,
    polar_covariance_to_cartesian,
    polar_to_cartesian,
    wrap_angle,
)


def test_polar_cartesian_round_trip():
    rng = np.random.default_rng(11)
    r = rng.uniform(1.0, 100_000.0, (40, 25))
    az = rng.uniform(-np.pi, np.pi, (40, 25))
    xy = polar_to_cartesian(r, az)
    assert xy.shape == (40, 25, 2)
    r_back, az_back = cartesian_to_polar(xy)
    np.testing.assert_allclose(r_back, r, rtol=1e-12)
    np.testing.assert_allclose(wrap_angle(az_back - az), 0.0, atol=1e-12)
    np.testing.assert_allclose(polar_to_cartesian(r_back, az_back), xy, rtol=1e-12, atol=1e-9)


def test_azimuth_is_clockwise_from_north():
    xy = polar_to_cartesian(np.full(4, 10.0), np.array([0.0, 0.5, 1.0, -0.5]) * np.pi)
    np.testing.assert_allclose(xy, [[0, 10], [10, 0], [0, -10], [-10, 0]], atol=1e-12)
    r, az = cartesian_to_polar(xy.round(12))
    np.testing.assert_allclose(r, 10.0)
    np.testing.assert_allclose(az, np.array([0.0, 0.5, 1.0, -0.5]) * np.pi)


def test_cartesian_to_polar_south_is_plus_pi_even_with_negative_zero():
    _, az = cartesian_to_polar(np.array([[0.0, -1.0], [-0.0, -1.0]]))
    assert az.tolist() == [np.pi, np.pi]


def test_cartesian_to_polar_of_one_position_gives_scalars():
    r, az = cartesian_to_polar([3.0, 4.0])
    assert np.ndim(r) == np.ndim(az) == 0
    assert (float(r), float(az)) == pytest.approx((5.0, math.atan2(3.0, 4.0)))


def _numeric_jacobian(r, az, h_r=1e-3, h_az=1e-7):
    d_r = (polar_to_cartesian(r + h_r, az) - polar_to_cartesian(r - h_r, az)) / (2 * h_r)
    d_az = (polar_to_cartesian(r, az + h_az) - polar_to_cartesian(r, az - h_az)) / (2 * h_az)
    return np.stack([d_r, d_az], axis=-1)


def test_polar_covariance_matches_finite_difference_jacobian():
    rng = np.random.default_rng(12)
    r = rng.uniform(100.0, 50_000.0, 200)
    az = rng.uniform(-np.pi, np.pi, 200)
    sigma_r = rng.uniform(1.0, 300.0, 200)
    sigma_az = rng.uniform(1e-4, 1e-2, 200)
    J = _numeric_jacobian(r, az)
    D = np.zeros((200, 2, 2))
    D[:, 0, 0], D[:, 1, 1] = sigma_r**2, sigma_az**2
    expected = J @ D @ J.transpose(0, 2, 1)
    P = polar_covariance_to_cartesian(r, az, sigma_r, sigma_az)
    scale = np.trace(expected, axis1=1, axis2=2)[:, None, None]
    np.testing.assert_allclose(P / scale, expected / scale, atol=1e-8)
    np.testing.assert_array_equal(P[:, 0, 1], P[:, 1, 0])


def test_polar_covariance_matches_monte_carlo():
    rng = np.random.default_rng(13)
    r, az, sigma_r, sigma_az = 20_000.0, 0.7, 5.0, 2e-4
    samples = 400_000
    xy = polar_to_cartesian(
        r + sigma_r * rng.standard_normal(samples), az + sigma_az * rng.standard_normal(samples)
    )
    sample_cov = np.cov(xy.T)
    P = polar_covariance_to_cartesian(r, az, sigma_r, sigma_az)
    # whitened sample covariance is the identity to within a few standard errors
    L = np.linalg.cholesky(P)
    white = np.linalg.solve(L, np.linalg.solve(L, sample_cov).T)
    np.testing.assert_allclose(white, np.eye(2), atol=4.0 * np.sqrt(2.0 / samples))


def test_cartesian_covariance_to_polar_inverts_the_forward_transform():
    rng = np.random.default_rng(14)
    r = rng.uniform(100.0, 50_000.0, 300)
    az = rng.uniform(-np.pi, np.pi, 300)
    sigma_r = rng.uniform(1.0, 300.0, 300)
    sigma_az = rng.uniform(1e-4, 1e-2, 300)
    P = polar_covariance_to_cartesian(r, az, sigma_r, sigma_az)
    P_polar = cartesian_covariance_to_polar(polar_to_cartesian(r, az), P)
    np.testing.assert_allclose(P_polar[:, 0, 0], sigma_r**2, rtol=1e-8)
    np.testing.assert_allclose(P_polar[:, 1, 1], sigma_az**2, rtol=1e-8)
    np.testing.assert_allclose(P_polar[:, 0, 1] / (sigma_r * sigma_az), 0.0, atol=1e-8)


def test_cartesian_covariance_to_polar_matches_inverse_jacobian():
    rng = np.random.default_rng(15)
    xy = rng.uniform(-30_000.0, 30_000.0, (100, 2))
    A = rng.normal(0.0, 50.0, (100, 2, 2))
    P = A @ A.transpose(0, 2, 1) + np.eye(2)
    r, az = cartesian_to_polar(xy)
    G = np.linalg.inv(_numeric_jacobian(r, az))
    expected = G @ P @ G.transpose(0, 2, 1)
    got = cartesian_covariance_to_polar(xy, P)
    scale = np.sqrt(np.einsum("nii,njj->nij", np.abs(expected), np.abs(expected)))
    np.testing.assert_allclose(got / scale, expected / scale, atol=1e-7)


def test_covariance_transform_broadcasts_one_sigma_over_many_marks():
    # due north (az = 0): x is cross-range with sigma r * sigma_az, y is range
    P = polar_covariance_to_cartesian(np.array([1000.0, 2000.0]), 0.0, 10.0, 0.001)
    expected = [[[1.0, 0.0], [0.0, 100.0]], [[4.0, 0.0], [0.0, 100.0]]]
    np.testing.assert_allclose(P, expected, atol=1e-12)


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [
        (np.pi, np.pi),
        (-np.pi, np.pi),
        (3 * np.pi, np.pi),
        (-3 * np.pi, np.pi),
        (2 * np.pi, 0.0),
        (0.0, 0.0),
        (-0.5, -0.5),
        (7.0, 7.0 - 2 * np.pi),
    ],
    ids=["pi", "-pi", "3pi", "-3pi", "2pi", "0", "-0.5", "7"],
)
def test_wrap_angle_edges(angle, wrapped):
    assert wrap_angle(angle) == pytest.approx(wrapped, abs=1e-15)
    assert isinstance(wrap_angle(angle), float)


def test_wrap_angle_keeps_every_value_in_half_open_interval():
    rng = np.random.default_rng(16)
    a = np.concatenate(
        [
            rng.uniform(-1e4, 1e4, 100_000),
            np.pi + np.arange(-5, 6) * np.spacing(np.pi),
            -np.pi + np.arange(-5, 6) * np.spacing(np.pi),
            2 * np.pi * np.arange(-3, 4) + np.spacing(2 * np.pi),
        ]
    )
    w = wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-11)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-11)


def test_inputs_are_not_modified():
    xy = np.array([[100.0, 200.0], [-300.0, 50.0]])
    P = np.array([[[4.0, 1.0], [1.0, 3.0]]] * 2)
    saved = xy.copy(), P.copy()
    cartesian_covariance_to_polar(xy, P)
    cartesian_to_polar(xy)
    np.testing.assert_array_equal(xy, saved[0])
    np.testing.assert_array_equal(P, saved[1])


def test_non_finite_input_reports_field_and_index():
    with pytest.raises(NonFiniteError, match=r"^az\[2\]: must be finite, got nan") as info:
        polar_to_cartesian(np.ones(4), np.array([0.0, 1.0, np.nan, 2.0]))
    assert (info.value.field, info.value.index) == ("az", 2)
    with pytest.raises(NonFiniteError, match=r"^xy\[1\]: must be finite, got \[inf, 1.0\]"):
        cartesian_to_polar(np.array([[0.0, 1.0], [np.inf, 1.0]]))
    with pytest.raises(NonFiniteError, match=r"^a: must be finite"):
        wrap_angle(np.inf)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"r": -1.0}, r"^r: must be non-negative, got -1.0"),
        ({"sigma_r": 0.0}, r"^sigma_r: must be positive, got 0.0"),
        ({"sigma_az": np.array([1e-3, -1e-3])}, r"^sigma_az\[1\]: must be positive"),
        ({"az": np.zeros(3), "r": np.ones(2)}, r"^az: batch shape \(3,\) does not broadcast"),
    ],
    ids=["negative-range", "zero-sigma", "negative-sigma-row", "shape-mismatch"],
)
def test_polar_covariance_parameter_errors(kwargs, message):
    args = {"r": 1000.0, "az": 0.1, "sigma_r": 10.0, "sigma_az": 1e-3} | kwargs
    with pytest.raises(ParameterError, match=message):
        polar_covariance_to_cartesian(**args)


def test_wrong_trailing_shape_is_a_parameter_error():
    with pytest.raises(ParameterError, match=r"^xy: must have shape \(\.\.\., 2\), got shape"):
        cartesian_to_polar(np.zeros((4, 3)))


def test_polar_covariance_of_mark_at_sensor_is_a_geometry_error():
    xy = np.array([[10.0, 0.0], [0.0, 0.0]])
    with pytest.raises(GeometryError, match=r"^xy\[1\]: is at the sensor") as info:
        cartesian_covariance_to_polar(xy, np.eye(2))
    assert info.value.index == 1


def test_ill_conditioned_covariance_is_refused_not_rotated():
    """An error ellipse 1 mm by 3000 km turned by a few degrees: rounding of the long axis
    (about 1e-16 * 1e13 m^2) would swamp the 1e-6 m^2 short axis, even make it negative."""
    from plotgate.core import (
        CovarianceError,
        cartesian_covariance_to_polar,
        polar_covariance_to_cartesian,
    )

    P = polar_covariance_to_cartesian(1e9, 0.0, 1e-3, 3e-3)
    with pytest.raises(CovarianceError, match=r"^P: is numerically singular"):
        cartesian_covariance_to_polar(np.array([1.7e6, 1e9]), P)
    well_conditioned = polar_covariance_to_cartesian(1e9, 0.0, 1.0, 1e-9)
    C = cartesian_covariance_to_polar(np.array([0.0, 1e9]), well_conditioned)
    np.testing.assert_allclose(np.sqrt(np.diag(C)), [1.0, 1e-9], rtol=1e-9)
