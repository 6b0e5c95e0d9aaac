"""One radar scan of plots, in the Cartesian and the polar form the initiation logic uses.

A plot (mark) is a position z with its 2x2 covariance R, measured by a sensor at a known
position; polar plots carry range r, azimuth az and their sigmas about that sensor
(az clockwise from north, x = r sin az, y = r cos az). Each form is derived from the
other once, when the scan is made: Cartesian plots get r, az and the sigmas of the
diagonal of their polar covariance, polar plots get z and R = J diag(sigma_r^2,
sigma_az^2) J^T. A scan of both kinds is the two merged (:func:`merged_scan`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import GeometryError, ParameterError
from plotgate.core.frames import (
    cartesian_covariance_to_polar,
    cartesian_to_polar,
    polar_covariance_to_cartesian,
    polar_to_cartesian,
)
from plotgate.core.validation import as_array, as_covariance, as_points, first_index

__all__ = ["MIN_SENSOR_RANGE", "Scan", "cartesian_scan", "merged_scan", "polar_scan"]

MIN_SENSOR_RANGE = 1.0
"""A plot closer than this (m) to its sensor has no usable azimuth and is refused (the
wire's least polar range, ``MIN_RANGE`` of the service's schemas, is held equal to it by
a test)."""


@dataclass(frozen=True)
class Scan:
    """The n plots of one scan at time t (arrays of length n; units m, rad, s).

    Attributes
    ----------
    t : float
        Scan time, s.
    z : (n, 2) ndarray
        Plot positions, m.
    R : (n, 2, 2) ndarray
        Their covariances, m^2.
    sensor : (n, 2) ndarray
        Position of the sensor that measured each plot, m.
    r, az : (n,) ndarray
        Range (m) and azimuth (rad) of each plot about its sensor.
    sigma_r, sigma_az : (n,) ndarray
        Their standard deviations, m and rad.
    """

    t: float
    z: np.ndarray
    R: np.ndarray
    sensor: np.ndarray
    r: np.ndarray
    az: np.ndarray
    sigma_r: np.ndarray
    sigma_az: np.ndarray

    @property
    def size(self) -> int:
        """Number of plots."""
        return int(self.z.shape[0])


def _time(t: float) -> float:
    a = as_array("t", t)
    if a.ndim:
        raise ParameterError("t", f"must be a scalar time in seconds, got shape {a.shape}")
    return float(a)


def _sensors(sensor: ArrayLike, n: int) -> np.ndarray:
    s = as_points("sensor", sensor)
    if s.ndim > 2 or (s.ndim == 2 and s.shape[0] != n):
        raise ParameterError("sensor", f"must have shape (2,) or ({n}, 2), got {s.shape}")
    return np.array(np.broadcast_to(s, (n, 2)))


def _far_from_sensor(r: np.ndarray) -> None:
    near = r < MIN_SENSOR_RANGE
    if near.any():
        i = first_index(near)
        raise GeometryError(
            "z",
            f"is {r[i]:.3g} m from its sensor; plots must be at least "
            f"{MIN_SENSOR_RANGE} m away to have an azimuth",
            i,
        )


def cartesian_scan(t: float, z: ArrayLike, R: ArrayLike, sensor: ArrayLike = (0.0, 0.0)) -> Scan:
    """A scan of Cartesian plots z (n, 2) with covariances R (n, 2, 2), m and m^2.

    Raises
    ------
    NonFiniteError, ParameterError, CovarianceError
        On non-finite values, wrong shapes or covariances that are not SPD.
    GeometryError
        If a plot is closer than MIN_SENSOR_RANGE to its sensor (field ``"z"``).

    Examples
    --------
    >>> s = cartesian_scan(0.0, [[3000.0, 4000.0]], [[[100.0, 0.0], [0.0, 100.0]]])
    >>> float(s.r[0]), round(float(s.sigma_r[0]), 6)
    (5000.0, 10.0)
    """
    t = _time(t)
    z = as_points("z", z)
    if z.ndim != 2:
        raise ParameterError("z", f"must have shape (n, 2), got {z.shape}")
    R = as_covariance("R", R)
    if R.shape != (z.shape[0], 2, 2):
        raise ParameterError("R", f"must have shape ({z.shape[0]}, 2, 2), got {R.shape}")
    sensor = _sensors(sensor, z.shape[0])
    rel = z - sensor
    r, az = cartesian_to_polar(rel)
    r, az = np.atleast_1d(r), np.atleast_1d(az)
    _far_from_sensor(r)
    polar = cartesian_covariance_to_polar(rel, R) if z.shape[0] else np.zeros((0, 2, 2))
    return Scan(t, z, R, sensor, r, az, np.sqrt(polar[:, 0, 0]), np.sqrt(polar[:, 1, 1]))


def polar_scan(
    t: float,
    r: ArrayLike,
    az: ArrayLike,
    sigma_r: ArrayLike,
    sigma_az: ArrayLike,
    sensor: ArrayLike = (0.0, 0.0),
) -> Scan:
    """A scan of polar plots: range r (m), azimuth az (rad) and their sigmas, (n,) each.

    Raises
    ------
    NonFiniteError, ParameterError
        On non-finite values, shapes that differ, or sigmas <= 0.
    GeometryError
        If a range is below MIN_SENSOR_RANGE (field ``"z"``).

    Examples
    --------
    >>> s = polar_scan(1.0, [5000.0], [0.0], [5.0], [np.radians(0.2)])
    >>> s.z.round(6).tolist(), float(np.sqrt(s.R[0, 0, 0])).__round__(3)
    ([[0.0, 5000.0]], 17.453)
    """
    t = _time(t)
    arrays = {
        name: np.atleast_1d(as_array(name, v))
        for name, v in (("r", r), ("az", az), ("sigma_r", sigma_r), ("sigma_az", sigma_az))
    }
    n = arrays["r"].shape
    for name, a in arrays.items():
        if a.ndim != 1 or a.shape != n:
            raise ParameterError(name, f"must have shape {n} like r, got {a.shape}")
    for name in ("sigma_r", "sigma_az"):
        bad = arrays[name] <= 0
        if bad.any():
            raise ParameterError(name, "must be > 0", first_index(bad))
    r, az, s_r, s_az = arrays.values()
    _far_from_sensor(r)
    sensor = _sensors(sensor, r.size)
    z = sensor + polar_to_cartesian(r, az).reshape(-1, 2)
    R = polar_covariance_to_cartesian(r, az, s_r, s_az).reshape(-1, 2, 2)
    return Scan(t, z, R, sensor, r, az, s_r, s_az)


def merged_scan(cartesian: Scan, polar: Scan, is_polar: ArrayLike) -> Scan:
    """One scan of the Cartesian and the polar plots of a scan, in the order they came.

    Each kind is made by its own function (:func:`cartesian_scan`, :func:`polar_scan`),
    so a polar plot keeps the range, azimuth and sigmas it was measured with.

    Parameters
    ----------
    cartesian, polar : Scan
        The scan's Cartesian plots and its polar plots, made at the same time.
    is_polar : (n,) array_like of bool
        Per plot of the merged scan, n = cartesian.size + polar.size: True where it is
        the next polar plot, False where it is the next Cartesian one.

    Raises
    ------
    ParameterError
        ``"t"`` if the two scans' times differ; ``"is_polar"`` if it does not count
        polar.size polar plots among cartesian.size + polar.size.

    Examples
    --------
    >>> c = cartesian_scan(2.0, [[0.0, 1000.0]], [np.eye(2)])
    >>> p = polar_scan(2.0, [5000.0], [np.pi / 2], [5.0], [1e-3])
    >>> s = merged_scan(c, p, [True, False])
    >>> s.r.tolist(), s.z.round(6).tolist()
    ([5000.0, 1000.0], [[5000.0, 0.0], [0.0, 1000.0]])
    """
    if cartesian.t != polar.t:
        raise ParameterError("t", f"the scans' times differ: {cartesian.t} and {polar.t} s")
    mask = np.asarray(is_polar, dtype=bool)
    if mask.shape != (cartesian.size + polar.size,) or int(mask.sum()) != polar.size:
        raise ParameterError(
            "is_polar",
            f"must mark {polar.size} polar plots among {cartesian.size + polar.size}, "
            f"got {int(mask.sum())} of {mask.size}",
        )

    def merge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = np.empty((mask.size, *a.shape[1:]), dtype=np.result_type(a, b))
        out[~mask], out[mask] = a, b
        return out

    return Scan(
        cartesian.t,
        *(
            merge(getattr(cartesian, f), getattr(polar, f))
            for f in ("z", "R", "sensor", "r", "az", "sigma_r", "sigma_az")
        ),
    )
