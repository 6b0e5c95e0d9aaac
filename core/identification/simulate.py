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

Every run is one Z-test, vectorized over the runs of a chunk. The runs are cut into
chunks of :func:`chunk_runs` runs (about :data:`SAMPLES_PER_CHUNK` bearings each: it
depends on n + m alone, never on who runs the chunks), mapped by any ``map`` (a Dask
cluster's spreads them), and the answer is the same bit for bit however they run. Chunk 0
draws from ``default_rng(seed)`` exactly as the unchunked experiment did (all its passive
bearings, then its active ones), so every experiment that fits one chunk (the default
10,000 runs of 50 + 5 bearings, and anything up to 18,181 such runs) keeps the numbers it
always had; chunk c > 0 draws from ``SeedSequence(seed, spawn_key=(c,))``, the child
``SeedSequence(seed).spawn`` would give. Each chunk returns its count of runs identified;
the fraction is their sum over the runs, as the mean over one array of runs was, bit for
bit (sums of ones are exact in floating point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from plotgate.core.chunks import Mapper, mapped, spans
from plotgate.core.errors import ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.identification.ztest import circular_mean, circular_sigma
from plotgate.core.validation import as_probability

__all__ = [
    "SAMPLES_PER_CHUNK",
    "ExperimentChunk",
    "ExperimentRates",
    "chunk_runs",
    "experiment",
    "identified_runs",
]

SAMPLES_PER_CHUNK = 1_000_000
"""Bearings one chunk draws, about (8 MB of doubles; a tenth of a second or two)."""


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
    mapper: Mapper | None = None,
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
    mapper : Mapper, optional
        How the chunks of :func:`chunk_runs` runs are run: a ``map`` (default the
        builtin, in this process; a cluster's to spread them). The result is the same bit
        for bit.

    Examples
    --------
    The realized type I error of m = 5 uniform active bearings at a nominal 0.05 is
    0.0609 +- 0.0004 (400,000 runs); 20,000 runs (two chunks) land within 4 standard
    errors of it:

    >>> r = experiment(50, 5, np.radians(1.0), 0.0, np.radians(1.0) * np.sqrt(12), 20000, 1,
    ...                law="uniform")
    >>> abs(r.rejected - 0.0609) < 4 * r.standard_error
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
    chunks = [
        ExperimentChunk(
            n, m, sigma, separation, width, seed, c, b - a, alpha, law, estimate_sigma, bearing
        )
        for c, (a, b) in enumerate(spans(runs, chunk_runs(n, m)))
    ]
    ident = sum(mapped(mapper, identified_runs, chunks)) / runs
    return ExperimentRates(runs, ident, 1.0 - ident, float(np.sqrt(ident * (1 - ident) / runs)))


def chunk_runs(n: int, m: int) -> int:
    """Runs per chunk of an experiment of n passive and m active bearings a run.

    >>> chunk_runs(50, 5)
    18181
    """
    return max(1, SAMPLES_PER_CHUNK // (n + m))


@dataclass(frozen=True)
class ExperimentChunk:
    """One chunk of :func:`experiment`: its arguments, the chunk's number and its runs."""

    n: int
    m: int
    sigma: float
    separation: float
    width: float
    seed: int
    chunk: int
    runs: int
    alpha: float
    law: str
    estimate_sigma: bool
    bearing: float


def identified_runs(c: ExperimentChunk) -> int:
    """How many of a chunk's runs the test identifies (one object)."""
    seed = c.seed if c.chunk == 0 else np.random.SeedSequence(c.seed, spawn_key=(c.chunk,))
    rng = np.random.default_rng(seed)
    passive = c.bearing + c.sigma * rng.standard_normal((c.runs, c.n))
    centre = c.bearing + c.separation
    if c.law == "uniform":
        active = rng.uniform(centre - c.width / 2, centre + c.width / 2, (c.runs, c.m))
    else:
        active = centre + c.sigma * rng.standard_normal((c.runs, c.m))
    s = circular_sigma(passive, axis=1) if c.estimate_sigma else c.sigma
    difference = wrap_finite(circular_mean(active, axis=1) - circular_mean(passive, axis=1))
    z = difference * np.sqrt(c.m) / s
    return int(np.count_nonzero(np.abs(z) <= stats.norm.ppf(1.0 - c.alpha / 2.0)))
