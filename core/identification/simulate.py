"""Kvasnov's experiment by Monte Carlo: the realized type I and type II errors.

The paper's simulation (MatLab): the passive station has accumulated n = 50 bearings,
normal N(theta_0, sigma); the active station's m bearings are uniform over a sector
(theta_min, theta_max) around the object's bearing; the zone spans 0-3 degrees. With
``separation`` = 0 the active bearings come from the same object, so the fraction of
runs the test rejects is the realized type I error (the paper reports alpha of about
0.04 at a nominal 0.05); with a separation the active object is another one, and the
fraction identified is the realized type II error beta. ``law="normal"`` draws the
active bearings N(theta_0 + separation, sigma) instead, the case the beta formula of
:func:`plotgate.core.identification.ztest.type_two_error` describes exactly.

Every run is one Z-test, all runs at once (vectorized), seeded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from plotgate.core.errors import ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.identification.ztest import circular_mean, circular_sigma
from plotgate.core.validation import as_probability

__all__ = ["ExperimentRates", "experiment"]


@dataclass(frozen=True)
class ExperimentRates:
    """Outcome of :func:`experiment`.

    Attributes
    ----------
    runs : int
    identified : float
        Fraction of runs the test identified the tracks (one object).
    rejected : float
        1 - identified: the realized type I error when separation is 0.
    standard_error : float
        sqrt(p (1 - p) / runs) of these fractions.
    """

    runs: int
    identified: float
    rejected: float
    standard_error: float


def experiment(
    n: int,
    m: int,
    sigma: float,
    separation: float,
    width: float,
    runs: int,
    seed: int,
    alpha: float = 0.05,
    law: str = "uniform",
    estimate_sigma: bool = False,
    bearing: float = np.radians(1.5),
) -> ExperimentRates:
    """Run Kvasnov's identification experiment ``runs`` times (angles in radians).

    Parameters
    ----------
    n, m : int
        Passive and active samples per run (>= 2).
    sigma : float
        Passive bearing standard deviation, > 0.
    separation : float
        Bearing of the active object minus that of the passive one (0: the same object).
    width : float
        Width of the active bearings' uniform sector (law "uniform"), > 0.
    runs : int
        Monte Carlo runs, >= 1.
    seed : int
        Seed of numpy's default_rng.
    alpha : float, optional
        Level of the test. Default 0.05.
    law : ``"uniform"`` or ``"normal"``
        Distribution of the active bearings about their object.
    estimate_sigma : bool, optional
        Estimate sigma from each run's passive sample (default: use the true sigma).
    bearing : float, optional
        The passive object's bearing (default 1.5 degrees, the middle of the paper's zone).

    Examples
    --------
    >>> r = experiment(50, 5, np.radians(1.0), 0.0, np.radians(1.0) * np.sqrt(12), 20000, 1,
    ...                law="uniform")
    >>> abs(r.rejected - 0.05) < 0.01
    True
    """
    for name, value, low in (("n", n, 2), ("m", m, 2), ("runs", runs, 1)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ParameterError(name, f"must be an integer >= {low}, got {value!r}")
    if law not in ("uniform", "normal"):
        raise ParameterError("law", f"must be 'uniform' or 'normal', got {law!r}")
    for name, angle in (("sigma", sigma), ("width", width)):
        if not angle > 0:
            raise ParameterError(name, f"must be > 0, got {angle!r}")
    alpha = float(as_probability("alpha", alpha))
    rng = np.random.default_rng(seed)
    passive = bearing + sigma * rng.standard_normal((runs, n))
    centre = bearing + separation
    if law == "uniform":
        active = rng.uniform(centre - width / 2, centre + width / 2, (runs, m))
    else:
        active = centre + sigma * rng.standard_normal((runs, m))

    s = circular_sigma(passive, axis=1) if estimate_sigma else sigma
    difference = wrap_finite(circular_mean(active, axis=1) - circular_mean(passive, axis=1))
    z = difference * np.sqrt(m) / s
    ident = float(np.mean(np.abs(z) <= stats.norm.ppf(1.0 - alpha / 2.0)))
    return ExperimentRates(runs, ident, 1.0 - ident, float(np.sqrt(ident * (1 - ident) / runs)))
