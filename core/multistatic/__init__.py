"""Multistatic range-sum position solves (Fadeev et al.).

A transmitter tx and receivers rx_k on moving platforms measure range sums
``l_k = |x - rx_k| + |x - tx|`` (Fadeev et al., eq. 1). :mod:`.model` holds the
measurement model and the shared input checks, :mod:`.closed_form` the sum-range and
difference-range closed-form solves, :mod:`.gauss_newton` the batched Gauss-Newton
engine of the maximum-likelihood solves, :mod:`.position` the single-shot solve,
:mod:`.trajectory` the constant-velocity track solve and :mod:`.track_start` its start,
:mod:`.information` the algebra of information matrices, :mod:`.crlb` the Cramer-Rao
bounds, :mod:`.noise` the noise estimation and smoothing, and :mod:`.study` the Monte
Carlo accuracy study of Fig. 3. Positions in metres, D = 2 or 3, batched over N
independent problems.
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
