"""Multistatic range-sum position solves (seed 001; DESIGN section 6).

A transmitter tx and receivers rx_k on moving platforms measure range sums
``l_k = |x - rx_k| + |x - tx|`` (seed 001, eq. 1). :mod:`.model` holds the measurement
model and the shared input checks, :mod:`.closed_form` the sum-range and
difference-range closed-form solves, :mod:`.ml` the maximum-likelihood (Gauss-Newton)
solves, :mod:`.crlb` the Cramer-Rao bounds, :mod:`.noise` the noise estimation and
smoothing, and :mod:`.study` the Monte Carlo accuracy study of Fig. 3. Positions in
metres, D = 2 or 3, batched over N independent problems.
"""

from plotgate.core.multistatic.closed_form import (
    ClosedFormSolution,
    difference_range_solve,
    sum_range_solve,
)
from plotgate.core.multistatic.crlb import (
    CRLB,
    TrajectoryCRLB,
    crlb,
    difference_crlb,
    trajectory_crlb,
)
from plotgate.core.multistatic.model import (
    Problem,
    platform_positions,
    range_sum_jacobian,
    range_sums,
    validate_problem,
)
from plotgate.core.multistatic.noise import NoiseEstimate, range_sum_noise, smooth_positions
from plotgate.core.multistatic.position import MLSolution, ml_solve
from plotgate.core.multistatic.study import AccuracyStudy, accuracy_study
from plotgate.core.multistatic.trajectory import TrajectorySolution, trajectory_solve

__all__ = [
    "CRLB",
    "AccuracyStudy",
    "ClosedFormSolution",
    "MLSolution",
    "NoiseEstimate",
    "Problem",
    "TrajectoryCRLB",
    "TrajectorySolution",
    "accuracy_study",
    "crlb",
    "difference_crlb",
    "difference_range_solve",
    "ml_solve",
    "platform_positions",
    "range_sum_jacobian",
    "range_sum_noise",
    "range_sums",
    "smooth_positions",
    "sum_range_solve",
    "trajectory_crlb",
    "trajectory_solve",
    "validate_problem",
]
