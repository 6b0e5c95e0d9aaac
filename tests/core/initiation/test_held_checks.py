"""Tentative tracks made again from the plots a state carries: initiation's own tracks
agree to rounding under every filter and confirmation rule, and a changed one does not."""

import numpy as np
import pytest

from plotgate.core.errors import CovarianceError, ParameterError
from plotgate.core.initiation import InitiationConfig, initiate
from plotgate.core.initiation.held_checks import REMADE_TOLERANCE, remade_tracks
from plotgate.core.initiation.simulate import mu_scenario, simulate
from plotgate.core.initiation.state_json import check_state

CONFIGS = {
    "polar": InitiationConfig(mode="polar", v_max=30.0),
    "alpha_beta-ring": InitiationConfig(
        v_max=30.0, filter="alpha_beta", capture_gate="ring", association="nearest"
    ),
    "expanded-2/T": InitiationConfig(v_max=30.0, capture_gate="expanded", capture_time=2.5),
    "score": InitiationConfig(
        mode="cartesian",
        capture_gate="combined",
        v_max=30.0,
        confirmation="score",
        P_D=0.8,
        clutter_density=250.0 / 15000.0**2,
    ),
}


def _states(config, clutter=250.0, seed=1):
    state = None
    for scan in simulate(mu_scenario(clutter, scans=6), seed).scans:
        state, _ = initiate(state, [scan], config)
        yield state


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_initiation_s_tentative_tracks_are_made_again_to_rounding(name):
    config, worst, made = CONFIGS[name], 0.0, 0
    for state in _states(config):
        rows, x, P = remade_tracks(state, config)
        if rows.size == 0:
            continue
        sigma = np.sqrt(np.diagonal(P, axis1=1, axis2=2))
        worst = max(
            worst,
            (np.abs(state.tracks.x[rows] - x) / (np.abs(x) + sigma)).max(),
            (
                np.abs(state.tracks.P[rows] - P)
                / (np.abs(P) + sigma[:, :, None] * sigma[:, None, :])
            ).max(),
        )
        made += rows.size
        check_state(state, config)
    assert made > 0
    assert worst < 1e-12 < REMADE_TOLERANCE  # measured: 4.4e-14 at most


def test_a_changed_tentative_track_is_named():
    config = CONFIGS["polar"]
    state = list(_states(config, 20.0, 4))[2]
    row = int(np.flatnonzero(~state.tracks.confirmed)[0])
    for change, field, error in (
        (lambda x, P: (x + [1e4, 0, 0, 0], P), "state.tracks.x", ParameterError),
        (lambda x, P: (x + [0, 0, 45.0, 0], P), "state.tracks.x", ParameterError),
        (lambda x, P: (x, 100.0 * P), "state.tracks.P", CovarianceError),
    ):
        x, P = state.tracks.x.copy(), state.tracks.P.copy()
        x[row], P[row] = change(x[row], P[row])
        hostile = state.replace(
            tracks=state.tracks.__class__(**{**state.tracks.__dict__, "x": x, "P": P})
        )
        with pytest.raises(error) as info:
            check_state(hostile, config)
        assert (info.value.field, info.value.index) == (field, row)
