"""Passive/active mark identification by Fisher's Z-test (Kvasnov).

:mod:`.ztest` tests one passive against one active track (bearings, optionally
elevations; beta, the required m, the paper's conditions), :mod:`.picture` whole
pictures (the Z matrix and a one-to-one assignment) and the sequential mode, and
:mod:`.simulate` the paper's experiment by Monte Carlo (realized alpha and beta).
"""

from plotgate.core.identification.picture import Picture, Sequence, identify_picture, sequential
from plotgate.core.identification.simulate import ExperimentRates, experiment
from plotgate.core.identification.ztest import (
    ZTest,
    circular_mean,
    circular_sigma,
    required_samples,
    type_two_error,
    z_test,
)

__all__ = [
    "ExperimentRates",
    "Picture",
    "Sequence",
    "ZTest",
    "circular_mean",
    "circular_sigma",
    "experiment",
    "identify_picture",
    "required_samples",
    "sequential",
    "type_two_error",
    "z_test",
]
