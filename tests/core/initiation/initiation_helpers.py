"""Helpers shared by the initiation tests: hand-made scans of Cartesian and polar plots."""

import numpy as np

from plotgate.core.initiation import InitiationConfig, cartesian_scan, initiate, polar_scan

R4 = np.eye(2) * 4.0  # plot covariance, m^2 (2 m sigma)
SR, SAZ = 5.0, np.radians(0.2)  # polar plots' sigmas, m and rad
CONFIG = InitiationConfig(v_max=20.0)  # ring capture, 2/2, branch, Kalman, 3/4, l = 2
POLAR = InitiationConfig(mode="polar", v_max=30.0, a_max=10.0, K_A=3.0)


def scan(t, *points, R=R4):
    """A Cartesian scan at time t with the given plots, each of covariance R."""
    z = np.array(points, dtype=float).reshape(-1, 2)
    return cartesian_scan(t, z, np.broadcast_to(R, (len(z), 2, 2)))


def pscan(t, *ra):
    """A polar scan at time t of (range m, azimuth deg) plots, sigmas SR and SAZ."""
    r = np.array([p[0] for p in ra], dtype=float)
    az = np.radians([p[1] for p in ra])
    return polar_scan(t, r, az, np.full(r.size, SR), np.full(r.size, SAZ))


def target(t):
    """A target at 10 m/s east through (1000, 2000) m at t = 0."""
    return (1000.0 + 10.0 * t, 2000.0)


def run(config, *scans):
    """initiate over the scans from a new session."""
    return initiate(None, list(scans), config)
