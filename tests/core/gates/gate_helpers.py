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
