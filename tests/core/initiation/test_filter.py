"""The track filters, through initiation: the textbook Kalman filter and alpha-beta gains."""

import numpy as np
from initiation_helpers import CONFIG, R4, run, scan

from plotgate.core.initiation import InitiationConfig


def test_kalman_track_is_the_textbook_filter():
    zs = [(1000.0, 2000.0), (1011.0, 2001.0), (1019.0, 1999.0), (1031.0, 2002.0)]
    state, _ = run(CONFIG, *[scan(t, z) for t, z in enumerate(zs)])
    x = np.array([zs[1][0], zs[1][1], 11.0, 1.0])
    P = np.zeros((4, 4))
    P[:2, :2], P[:2, 2:], P[2:, :2], P[2:, 2:] = R4, R4, R4, 2 * R4
    F = np.eye(4)
    F[0, 2] = F[1, 3] = 1.0
    Q = np.kron([[1 / 3, 1 / 2], [1 / 2, 1.0]], np.eye(2)) * CONFIG.q
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    for z in zs[2:]:
        x, P = F @ x, F @ P @ F.T + Q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R4)
        x, P = x + K @ (np.array(z) - H @ x), (np.eye(4) - K @ H) @ P
    np.testing.assert_allclose(state.tracks.x[0], x, rtol=1e-12)
    np.testing.assert_allclose(state.tracks.P[0], P, rtol=1e-9)


def test_alpha_beta_gains_of_the_secondary_processing_textbook():
    zs = [(1000.0, 2000.0), (1010.0, 2000.0), (1026.0, 2006.0)]
    config = InitiationConfig(v_max=20.0, filter="alpha_beta")
    state, _ = run(config, *[scan(t, z) for t, z in enumerate(zs)])
    alpha, beta = 2 * (2 * 3 - 1) / (3 * 4), 6 / (3 * 4)  # n = 3: 5/6 and 1/2
    pred = np.array([1020.0, 2000.0])
    nu = np.array(zs[2]) - pred
    np.testing.assert_allclose(state.tracks.x[0, :2], pred + alpha * nu)
    np.testing.assert_allclose(state.tracks.x[0, 2:], np.array([10.0, 0.0]) + beta * nu)
