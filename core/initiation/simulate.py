"""Seeded simulator of radar scans: targets, detection probability, Poisson clutter.

Mu et al.'s evaluation scenario in general form: constant-velocity
targets seen by one radar with detection probability P_D and polar noise (sigma_r,
sigma_az), plus clutter: a Poisson number of plots per scan (mean ``clutter``) uniform
over a rectangle. Every plot is labelled with its source (the target's index, or -1 for
clutter); the plots of a scan are in random order. Reproducible bit for bit for a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plotgate.core.errors import ParameterError
from plotgate.core.frames import cartesian_to_polar
from plotgate.core.initiation.scan import MIN_SENSOR_RANGE, Scan, polar_scan
from plotgate.core.validation import as_array, as_points

__all__ = ["Scenario", "SimulatedScans", "mu_scenario", "simulate"]


@dataclass(frozen=True)
class Scenario:
    """Targets, sensor and clutter of a simulation (SI units, angles in radians).

    Attributes
    ----------
    x0 : (k, 2) ndarray
        Target positions at the first scan, m.
    v : (k, 2) ndarray
        Target velocities, m/s.
    scans : int
        Number of scans, >= 1.
    interval : float
        Time between scans, s, > 0.
    P_D : float
        Detection probability of each target in each scan, in [0, 1].
    clutter : float
        Mean number of clutter plots per scan, >= 0.
    region : (4,) ndarray
        Clutter rectangle (x_min, x_max, y_min, y_max), m.
    sensor : (2,) ndarray
        Radar position, m.
    sigma_r, sigma_az : float
        Range (m) and azimuth (rad) noise standard deviations, > 0.
    """

    x0: np.ndarray
    v: np.ndarray
    scans: int
    interval: float
    P_D: float
    clutter: float
    region: np.ndarray
    sensor: np.ndarray
    sigma_r: float
    sigma_az: float

    def __post_init__(self) -> None:
        x0 = as_points("x0", self.x0).reshape(-1, 2)
        v = as_points("v", self.v).reshape(-1, 2)
        if v.shape != x0.shape:
            raise ParameterError("v", f"must have the shape of x0 {x0.shape}, got {v.shape}")
        object.__setattr__(self, "x0", x0)
        object.__setattr__(self, "v", v)
        region = as_array("region", self.region)
        if region.shape != (4,) or not (region[0] < region[1] and region[2] < region[3]):
            raise ParameterError(
                "region",
                f"must be (x_min, x_max, y_min, y_max) with min < max, got {region.tolist()}",
            )
        object.__setattr__(self, "region", region)
        object.__setattr__(self, "sensor", as_points("sensor", self.sensor).reshape(2))
        if isinstance(self.scans, bool) or not isinstance(self.scans, int) or self.scans < 1:
            raise ParameterError("scans", f"must be an integer >= 1, got {self.scans!r}")
        for name, ok, rule in (
            ("interval", self.interval > 0, "> 0"),
            ("P_D", 0 <= self.P_D <= 1, "in [0, 1]"),
            ("clutter", self.clutter >= 0, ">= 0"),
            ("sigma_r", self.sigma_r > 0, "> 0"),
            ("sigma_az", self.sigma_az > 0, "> 0"),
        ):
            value = float(as_array(name, getattr(self, name)))
            if not ok:
                raise ParameterError(name, f"must be {rule}, got {value}")
            object.__setattr__(self, name, value)

    def truth(self) -> np.ndarray:
        """(scans, k, 2) true target positions at every scan, m."""
        t = self.interval * np.arange(self.scans)
        truth: np.ndarray = self.x0[None] + t[:, None, None] * self.v[None]
        return truth


def mu_scenario(clutter: float, scans: int = 4) -> Scenario:
    """Mu et al.'s test: 5 ground targets at 25 m/s east, P_D 0.8, a 15 km square.

    Examples
    --------
    >>> s = mu_scenario(250.0)
    >>> s.x0[0].tolist(), s.v[0].tolist(), round(float(np.degrees(s.sigma_az)), 6)
    ([5000.0, 10000.0], [25.0, 0.0], 0.2)
    """
    x0 = [
        [5000.0, 10000.0],
        [6000.0, 9000.0],
        [7000.0, 8000.0],
        [8000.0, 7000.0],
        [9000.0, 6000.0],
    ]
    return Scenario(
        x0=np.array(x0),
        v=np.tile([25.0, 0.0], (5, 1)),
        scans=scans,
        interval=1.0,
        P_D=0.8,
        clutter=clutter,
        region=np.array([0.0, 15000.0, 0.0, 15000.0]),
        sensor=np.zeros(2),
        sigma_r=5.0,
        sigma_az=np.radians(0.2),
    )


@dataclass(frozen=True)
class SimulatedScans:
    """Simulated scans and the source of every plot.

    Attributes
    ----------
    scans : list of Scan
    labels : list of (n_i,) ndarray of int
        Per scan, the target index of each plot, -1 for clutter.
    truth : (scans, k, 2) ndarray
        True target positions, m.
    """

    scans: list[Scan]
    labels: list[np.ndarray]
    truth: np.ndarray


def simulate(scenario: Scenario, rng: np.random.Generator | int) -> SimulatedScans:
    """Draw the scans of a scenario (targets detected with P_D, polar noise, clutter).

    Parameters
    ----------
    scenario : Scenario
    rng : numpy.random.Generator or int
        The generator, or a seed for ``numpy.random.default_rng``.

    Returns
    -------
    simulated : SimulatedScans

    Notes
    -----
    Clutter falling within MIN_SENSOR_RANGE of the sensor (no azimuth) is left out.

    Examples
    --------
    >>> sim = simulate(mu_scenario(20.0), 1)
    >>> len(sim.scans), sim.truth.shape, np.unique(np.concatenate(sim.labels))[:2].tolist()
    (4, (4, 5, 2), [-1, 0])
    """
    rng = np.random.default_rng(rng)
    s = scenario
    truth = s.truth()
    k = s.x0.shape[0]
    x_min, x_max, y_min, y_max = s.region
    scans, labels = [], []
    for i in range(s.scans):  # each scan draws its own detections and clutter
        seen = np.flatnonzero(rng.random(k) < s.P_D)
        r, az = cartesian_to_polar(truth[i, seen] - s.sensor)
        r = np.atleast_1d(r) + s.sigma_r * rng.standard_normal(seen.size)
        az = np.atleast_1d(az) + s.sigma_az * rng.standard_normal(seen.size)
        count = rng.poisson(s.clutter)
        xy = np.column_stack([rng.uniform(x_min, x_max, count), rng.uniform(y_min, y_max, count)])
        cr, caz = cartesian_to_polar(xy - s.sensor)
        cr, caz = np.atleast_1d(cr), np.atleast_1d(caz)
        far = cr >= MIN_SENSOR_RANGE
        r = np.concatenate([r, cr[far]])
        az = np.concatenate([az, caz[far]])
        label = np.concatenate([seen, np.full(far.sum(), -1)])
        order = rng.permutation(r.size)
        r, az, label = np.maximum(r[order], MIN_SENSOR_RANGE), az[order], label[order]
        scans.append(
            polar_scan(
                i * s.interval,
                r,
                az,
                np.full(r.size, s.sigma_r),
                np.full(r.size, s.sigma_az),
                s.sensor,
            )
        )
        labels.append(label)
    return SimulatedScans(scans, labels, truth)
