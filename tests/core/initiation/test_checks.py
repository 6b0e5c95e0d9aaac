"""The compiled acceleration check against its numpy reference (checks.py)."""

from dataclasses import replace

import numpy as np
import pytest

from plotgate.core.initiation import InitiationConfig, empty_state
from plotgate.core.initiation.checks import acceleration_ok, acceleration_ok_reference

CONFIG = InitiationConfig(mode="polar", v_max=30.0, a_max=10.0, K_A=3.0)


def tracks_with(ranges, times):
    """Tracks (all else empty) holding these range and time histories."""
    m = ranges.shape[0]
    empty = empty_state(replace(CONFIG, history=ranges.shape[1])).tracks
    return replace(empty, id=np.arange(m), ranges=ranges, times=times)


@pytest.mark.parametrize("seed", range(5))
def test_random_histories_match_the_reference(seed):
    rng = np.random.default_rng(seed)
    m, H = 4000, int(rng.integers(4, 10))
    times = np.cumsum(rng.choice([0.0, 0.5, 1.0, 2.0], (m, H)), axis=1)  # equal times too
    ranges = 1e4 + 25.0 * times + rng.normal(0.0, rng.uniform(1.0, 20.0), (m, H))
    ranges[rng.random((m, H)) < 0.2] = np.nan  # missing plots
    times[np.isnan(ranges)] = np.nan
    tracks = tracks_with(ranges, times)
    got, want = acceleration_ok(tracks, CONFIG), acceleration_ok_reference(tracks, CONFIG)
    assert 0 < got.sum() < m
    np.testing.assert_array_equal(got, want)


def test_the_bound_itself_passes():
    # second difference 30 m in 1 s: 30 m/s^2 = K_A a_max passes, a hair more does not
    ranges = np.array([[np.nan, 1e4, 1e4, 10030.0], [np.nan, 1e4, 1e4, 10030.001]])
    tracks = tracks_with(ranges, np.tile([np.nan, 0.0, 1.0, 2.0], (2, 1)))
    assert acceleration_ok(tracks, CONFIG).tolist() == [True, False]
    assert acceleration_ok_reference(tracks, CONFIG).tolist() == [True, False]
