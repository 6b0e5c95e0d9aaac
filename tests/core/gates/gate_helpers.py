"""Helpers shared by the gate tests: random covariances, pair inputs, reference checks."""

import numpy as np

N_RANDOM = 1000


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


def combined_inputs(rng, n):
    z1 = rng.uniform(-1e4, 1e4, (n, 2))
    heading = rng.uniform(-np.pi, np.pi, n)
    dist = rng.uniform(0.0, 800.0, n)
    z2 = z1 + dist[:, None] * np.stack([np.sin(heading), np.cos(heading)], axis=1)
    z2[:10] = z1[:10]  # exact d = 0
    return z1, random_spd(rng, n, 40.0), z2, random_spd(rng, n, 40.0)


def assert_kernel_matches_reference(result, reference):
    """A gate's compiled test against its numpy reference: decisions and stages identical."""
    assert result.inside.shape == result.statistic.shape == reference.inside.shape
    assert result.inside.dtype == bool and result.statistic.dtype == np.float64
    np.testing.assert_allclose(result.statistic, reference.statistic, rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(result.inside, reference.inside)
    assert result.threshold == reference.threshold
    if reference.stage is None:
        assert result.stage is None
    else:
        assert result.stage.dtype == reference.stage.dtype == np.int8
        np.testing.assert_array_equal(result.stage, reference.stage)


def polar_inputs(rng, n):
    """Ranges (some 0), azimuths across the +-pi seam, and sigmas of n pairs."""
    r1 = rng.uniform(0.0, 2e4, n)
    r1[:5] = 0.0  # a mark on the sensor
    r1[5:10] = rng.uniform(0.0, 50.0, n)[5:10]  # within v_max tau of the sensor
    az1 = rng.uniform(-np.pi, np.pi, n)
    r2 = np.abs(r1 + rng.normal(0.0, 60.0, n))
    az2 = az1 + rng.normal(0.0, 0.02, n)
    az1[10:20] = (np.pi - np.abs(rng.normal(0.0, 0.01, n)))[10:20]  # across the seam
    az2[10:20] = (np.abs(rng.normal(0.0, 0.01, n)) - np.pi)[10:20]
    az2[20:25] = az1[20:25] + 2.0 * np.pi  # one turn apart
    sigmas = [rng.uniform(1.0, 30.0, n), rng.uniform(1e-4, 5e-3, n)]
    sigmas += [rng.uniform(1.0, 30.0, n), rng.uniform(1e-4, 5e-3, n)]
    return r1, az1, r2, az2, sigmas
