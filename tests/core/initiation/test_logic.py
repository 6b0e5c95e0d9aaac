"""Track initiation on hand-made scans: every criterion, drop rule and plot-reuse rule.

Scans are built by hand so each test knows exactly which plot should do what.
"""

import numpy as np
import pytest
from initiation_helpers import CONFIG, POLAR, R4, pscan, run, scan, target

from plotgate.core.errors import ParameterError
from plotgate.core.initiation import (
    InitiationConfig,
    cartesian_scan,
    empty_state,
    initiate,
    search,
    state_from_json,
)
from plotgate.core.initiation.filter import SPEED_SIGMAS, predict, speed_excess
from plotgate.core.initiation.simulate import mu_scenario, simulate

# ---------------------------------------------------------------- criteria


def test_three_of_four_confirms_on_the_third_plot_and_two_of_four_on_the_second():
    scans = [scan(t, target(t)) for t in range(4)]
    _, reports = run(CONFIG, *scans)
    assert [r.confirmed.tolist() for r in reports] == [[], [], [0], []]
    assert [r.started.tolist() for r in reports] == [[], [0], [], []]
    _, reports = run(InitiationConfig(v_max=20.0, confirm_k=2, confirm_m=4), *scans)
    assert reports[1].confirmed.tolist() == [0]


def test_a_tentative_track_is_dropped_when_k_is_out_of_reach():
    # plots in scans 0 and 1, then nothing: after scan 3 a third plot can no longer fall
    # within the first 4 scans (l = 3 so the miss rule does not fire first)
    config = InitiationConfig(v_max=20.0, drop_misses=3)
    state, reports = run(config, scan(0, target(0)), scan(1, target(1)), scan(2), scan(3))
    assert reports[2].dropped.size == 0
    assert reports[3].dropped.tolist() == [0] and reports[3].reasons.tolist() == ["window"]
    assert state.tracks.size == 0


def test_l_misses_in_a_row_drop_tentative_and_confirmed_tracks():
    state, reports = run(CONFIG, scan(0, target(0)), scan(1, target(1)), scan(2), scan(3))
    assert reports[3].reasons.tolist() == ["misses"]  # tentative, l = 2
    scans = [scan(t, target(t)) for t in range(4)] + [scan(4), scan(5)]
    state, reports = run(CONFIG, *scans)
    assert reports[2].confirmed.tolist() == [0]
    assert reports[4].dropped.size == 0  # one miss: the wider gate waits
    assert reports[5].dropped.tolist() == [0] and reports[5].reasons.tolist() == ["misses"]


def test_two_of_n_capture_across_a_missed_scan():
    scans = [scan(0, target(0)), scan(1), scan(2, target(2)), scan(3, target(3))]
    _, reports = run(InitiationConfig(v_max=20.0, capture_scans=3), *scans)
    assert reports[2].started.tolist() == [0]  # tau = 2 s
    assert reports[3].confirmed.tolist() == [0]
    _, reports = run(CONFIG, *scans)  # 2/2: the initiator expired after scan 1
    assert reports[2].started.size == 0 and reports[2].initiators == 1
    assert reports[3].started.size == 1 and not any(r.confirmed.size for r in reports)


def test_two_of_t_capture_counts_seconds():
    scans = [scan(0, target(0)), scan(1), scan(2, target(2))]
    _, reports = run(InitiationConfig(v_max=20.0, capture_time=2.5), *scans)
    assert reports[2].started.tolist() == [0]
    _, reports = run(InitiationConfig(v_max=20.0, capture_time=1.5), *scans)
    assert reports[2].started.size == 0


def test_the_ring_refuses_plots_too_far_or_too_slow():
    far = (target(1)[0] + 15.0, 2000.0)  # 25 m in 1 s > v_max = 20 m/s
    _, reports = run(CONFIG, scan(0, target(0)), scan(1, far))
    assert reports[1].started.size == 0
    _, reports = run(
        InitiationConfig(v_min=15.0, v_max=20.0), scan(0, target(0)), scan(1, target(1))
    )  # 10 m/s < v_min
    assert reports[1].started.size == 0


def test_gates_widen_after_a_miss():
    # a plot 3.4 gate-sigmas off is outside the narrow 99% gate (3.03) but inside the
    # medium one after a miss (gamma x 2: 4.29)
    state, _ = run(CONFIG, *[scan(t, target(t)) for t in range(3)])
    tr = state.tracks
    xp, Pp = predict(tr.x, tr.P, np.array([1.0]), CONFIG.q)
    sd = np.sqrt(Pp[0, 1, 1] + 4.0)
    off = (xp[0, 0], xp[0, 1] + 3.4 * sd)
    _, (narrow,) = initiate(state, [scan(3, off)], CONFIG)
    assert narrow.associated.tolist() == [-1]
    missed, _ = initiate(state, [scan(3)], CONFIG)
    xp, Pp = predict(missed.tracks.x, missed.tracks.P, np.array([1.0]), CONFIG.q)
    sd = np.sqrt(Pp[0, 1, 1] + 4.0)
    _, (wide,) = initiate(missed, [scan(4, (xp[0, 0], xp[0, 1] + 3.4 * sd))], CONFIG)
    assert wide.associated.tolist() == [0]


def test_scans_from_two_sensors_with_their_own_times_build_one_track():
    # radar A at the origin and radar B 20 km east, scanning half a second apart
    def from_b(t, xy):
        return cartesian_scan(t, [xy], [R4], sensor=(20000.0, 0.0))

    scans = [
        scan(0.0, target(0.0)),
        from_b(0.5, target(0.5)),
        scan(1.0, target(1.0)),
        from_b(1.5, target(1.5)),
    ]
    state, reports = run(InitiationConfig(v_max=20.0, confirm_k=3, confirm_m=3), *scans)
    assert reports[1].started.tolist() == [0] and reports[2].confirmed.tolist() == [0]
    assert reports[3].associated.tolist() == [0]
    np.testing.assert_allclose(state.tracks.x[0], [1015.0, 2000.0, 10.0, 0.0], atol=1e-6)


# ---------------------------------------------------------------- association


def test_branch_starts_a_track_per_candidate_and_nearest_only_one():
    candidates = [target(1), (1000.0, 2015.0)]  # 10 m and 15 m from the initiator
    _, reports = run(CONFIG, scan(0, target(0)), scan(1, *candidates))
    assert reports[1].started.tolist() == [0, 1]
    state, reports = run(
        InitiationConfig(v_max=20.0, association="nearest"),
        scan(0, target(0)),
        scan(1, *candidates),
    )
    assert reports[1].started.tolist() == [0]
    np.testing.assert_allclose(state.tracks.x[0], [1010.0, 2000.0, 10.0, 0.0])
    assert reports[1].associated.tolist() == [0, -1]  # the far candidate is an initiator
    assert state.initiators.plot.tolist() == [(1 << 20) + 1]


def test_a_confirmed_track_owns_its_plots_and_prunes_tentative_branches():
    # two branches from one initiator share the initiator's plot; both take the third
    # plot, so both could confirm: the better one does, the other shares two plots
    scans = [
        scan(0, target(0)),
        scan(1, target(1), (1011.0, 2001.5)),
        scan(2, target(2)),
        scan(3, target(3)),
    ]
    state, reports = run(CONFIG, *scans)
    assert reports[1].started.tolist() == [0, 1]
    assert reports[2].confirmed.tolist() == [0]
    assert reports[2].dropped.tolist() == [1] and reports[2].reasons.tolist() == ["pruned"]
    # the confirmed track's plots started nothing else
    assert reports[2].initiators == 0 and reports[3].initiators == 0
    assert state.tracks.id.tolist() == [0] and state.tracks.n.tolist() == [4]


def test_confirmed_tracks_take_plots_one_to_one():
    # two parallel confirmed tracks 30 m apart and one vague plot between them, in
    # both gates: only one track takes it
    a = [scan(t, target(t), (1000.0 + 10.0 * t, 2030.0)) for t in range(3)]
    state, reports = run(CONFIG, *a)
    assert sorted(reports[2].confirmed.tolist()) == [0, 1]
    vague = cartesian_scan(3.0, [[1030.0, 2015.0]], [np.eye(2) * 100.0])
    state, (report,) = initiate(state, [vague], CONFIG)
    assert report.associated.tolist() in ([0], [1])
    assert sorted(state.tracks.misses.tolist()) == [0, 1]


def test_plots_too_dense_for_the_gates_are_refused_naming_the_scan(monkeypatch):
    # 30 plots at one spot: 30 initiators x 30 plots = 900 capture pairs in scan 1; with
    # at most 500 pairs a search (10^9 pairs for 1000 such plots would exhaust memory)
    monkeypatch.setattr(search, "MAX_CANDIDATES", 500)
    z = np.full((30, 2), 5000.0)
    scans = [cartesian_scan(float(t), z, np.broadcast_to(R4, (30, 2, 2))) for t in range(3)]
    with pytest.raises(ParameterError) as info:
        initiate(None, scans, CONFIG)
    assert info.value.field == "scans" and info.value.index == 1
    assert "900 candidate" in info.value.reason
    # 20 plots (400 pairs) pass
    initiate(None, [cartesian_scan(s.t, s.z[:20], s.R[:20]) for s in scans[:2]], CONFIG)


# ---------------------------------------------------------------- polar mode


def test_polar_first_association_windows():
    # range window v_max tau + K_R sqrt(2) sigma_r = 30 + 3.03 * 7.07 = 51.4 m
    _, reports = run(POLAR, pscan(0, (10000.0, 45.0)), pscan(1, (10050.0, 45.0)))
    assert reports[1].started.size == 1
    _, reports = run(POLAR, pscan(0, (10000.0, 45.0)), pscan(1, (10053.0, 45.0)))
    assert reports[1].started.size == 0
    # azimuth window asin(30 / 10000) + K_az sqrt(2) sigma_az = 0.172 + 0.857 = 1.03 deg
    _, reports = run(POLAR, pscan(0, (10000.0, 45.0)), pscan(1, (10000.0, 46.0)))
    assert reports[1].started.size == 1
    _, reports = run(POLAR, pscan(0, (10000.0, 45.0)), pscan(1, (10000.0, 46.1)))
    assert reports[1].started.size == 0


def test_polar_tracks_extrapolate_range_only():
    first = [pscan(0, (10000.0, 45.0)), pscan(1, (10020.0, 45.3))]
    # predicted range 10040 m, window 3.03 sqrt(25 + 4 * 25 + 25) = 37 m; the azimuth
    # window (1.03 deg) stays about the last azimuth, 45.3 deg, not extrapolated to 45.6
    _, reports = run(POLAR, *first, pscan(2, (10065.0, 45.3)))  # 25 m: in
    assert reports[2].confirmed.size == 1
    _, reports = run(POLAR, *first, pscan(2, (10080.0, 45.3)))  # 40 m: out
    assert reports[2].confirmed.size == 0 and reports[2].associated.tolist() == [-1]
    _, reports = run(POLAR, *first, pscan(2, (10040.0, 44.4)))  # 1.2 deg from 45.6
    assert reports[2].confirmed.size == 1


def test_polar_acceleration_check_drops_jerky_tracks():
    # second difference 30 m in 1 s: 30 m/s^2 = K_A a_max passes, 36 m/s^2 does not
    ok = [pscan(0, (10000.0, 45.0)), pscan(1, (10000.0, 45.0)), pscan(2, (10030.0, 45.0))]
    jerk = [pscan(0, (10000.0, 45.0)), pscan(1, (10000.0, 45.0)), pscan(2, (10036.0, 45.0))]
    wide = InitiationConfig(mode="polar", v_max=30.0, a_max=10.0, K_A=3.0, K_R=6.0)
    _, reports = run(wide, *ok)
    assert reports[2].confirmed.size == 1
    _, reports = run(wide, *jerk)
    assert reports[2].confirmed.size == 0 and reports[2].reasons.tolist() == ["acceleration"]


# ---------------------------------------------------------------- state


def _clutter_session(seed=3):
    sim = simulate(mu_scenario(250.0, scans=6), seed)
    return sim.scans


def test_scans_one_by_one_equal_scans_all_at_once():
    scans = _clutter_session()
    score = {"confirmation": "score", "P_D": 0.8, "surveillance_area": 15000.0**2}
    for config in (
        InitiationConfig(mode="cartesian", capture_gate="combined", v_max=30.0),
        POLAR,
        InitiationConfig(mode="cartesian", capture_gate="combined", v_max=30.0, **score),
        InitiationConfig(mode="polar", v_max=30.0, capture_scans=3, **score),
    ):
        whole, reports = initiate(None, scans, config)
        state, pieces = None, []
        for s in scans:
            state, (report,) = initiate(state, [s], config)
            state = state_from_json(state.to_json(), config)  # through JSON each time
            pieces.append(report)
        assert state.to_json() == whole.to_json()
        for a, b in zip(reports, pieces, strict=True):
            assert a.started.tolist() == b.started.tolist()
            assert a.confirmed.tolist() == b.confirmed.tolist()
            assert a.associated.tolist() == b.associated.tolist()
        assert whole.tracks.size > 0


def test_foreign_or_malformed_states_are_refused():
    state, _ = initiate(None, _clutter_session()[:2], CONFIG)
    data = state.to_json()
    with pytest.raises(ParameterError, match="other settings") as info:
        state_from_json(data, InitiationConfig(v_max=21.0))
    assert info.value.field == "state.config_digest"
    for change, field in (
        ({"version": 99}, "state.version"),
        ({"scans": -1}, "state.scans"),
        ({"t": None}, "state.t"),
        ({"tracks": dict(data["tracks"], x=[[1.0]])}, "state.tracks.x"),
        ({"initiators": dict(data["initiators"], z="nope")}, "state.initiators.z"),
        ({"tracks": {"id": []}}, "state.tracks.confirmed"),
    ):
        with pytest.raises(ParameterError) as info:
            state_from_json({**data, **change}, CONFIG)
        assert info.value.field == field
    with pytest.raises(ParameterError, match="other settings"):
        initiate(empty_state(CONFIG), [], POLAR)


def test_max_tracks_stops_at_the_scan_that_passes_it():
    candidates = [target(1), (1000.0, 2015.0)]  # two branches from one initiator
    scans = [scan(0, target(0)), scan(1, *candidates)]
    state, _ = initiate(None, scans, CONFIG, max_tracks=2)
    assert state.tracks.size == 2
    with pytest.raises(ParameterError, match="leaves 2 live tracks") as info:
        initiate(None, scans, CONFIG, max_tracks=1)
    assert info.value.field == "scans" and info.value.index == 1


def test_scans_must_come_in_time_order():
    with pytest.raises(ParameterError) as info:
        initiate(None, [scan(1.0, target(1)), scan(0.5, target(0))], CONFIG)
    assert info.value.field == "scans" and info.value.index == 1


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"mode": "spherical"}, "mode"),
        ({"v_max": -1.0}, "v_max"),
        ({"v_min": 60.0}, "v_max"),
        ({"confirm_k": 5}, "confirm_k"),
        ({"gate_widening": (2.0, 1.0)}, "gate_widening"),
        ({"K_A": 1.0}, "K_A"),
        ({"capture_scans": 1}, "capture_scans"),
        ({"history": 2}, "history"),
        ({"gate_P_G": 1.0}, "gate_P_G"),
        ({"capture_time": 0.0}, "capture_time"),
    ],
)
def test_bad_settings_are_named(change, field):
    with pytest.raises(ParameterError) as info:
        InitiationConfig(**change)
    assert info.value.field == field


# ---------------------------------------------------------------- speed


@pytest.mark.parametrize(
    ("config", "clutter", "scans", "seed"),
    [
        (InitiationConfig(v_max=30.0, capture_gate="combined", capture_scans=3), 250.0, 15, 0),
        (InitiationConfig(v_max=30.0, capture_gate="expanded", filter="alpha_beta"), 250.0, 15, 1),
    ],
    ids=["kalman", "alpha-beta"],
)
def test_a_track_faster_than_v_max_allows_is_dropped(config, clutter, scans, seed):
    """In dense clutter the filter runs away with some tracks (the landed logic kept them
    at up to 31 of their velocity sigmas above v_max, 490 m/s for a v_max of 30): each is
    dropped, reason "speed", so no state carries one and every state passes its check."""
    reasons: set[str] = set()
    state = None
    for plots in simulate(mu_scenario(clutter, scans=scans), seed).scans:
        state, (report,) = initiate(state, [plots], config)
        reasons.update(report.reasons.tolist())
        excess = speed_excess(state.tracks.x, state.tracks.P, config.v_max)
        assert (excess <= SPEED_SIGMAS).all()
    assert "speed" in reasons
