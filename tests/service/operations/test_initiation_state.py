"""A hostile client's states: every field of a real state, mutated in turn, answers 422
naming the state's own field, never 500; the state's size counts against a work cap and
its schema ceiling; and a state a call returns is always one the next call takes."""

import copy
import json
import random

import numpy as np
import pytest
from fastapi.testclient import TestClient

from plotgate.core.frames import polar_covariance_to_cartesian, polar_to_cartesian
from plotgate.core.initiation import (
    PLOT_STRIDE,
    InitiationConfig,
    Initiators,
    check_state,
    empty_state,
    initiate,
)
from plotgate.core.initiation import state as core_state
from plotgate.core.initiation.filter import SPEED_SIGMAS
from plotgate.core.initiation.filter import speed_excess as core_speed_excess
from plotgate.core.initiation.simulate import mu_scenario, simulate
from plotgate.core.initiation.state_json import state_from_json
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.operations.initiation import PLOT_BOUNDS
from plotgate.service.schemas import MAX_STATE_INITIATORS, MAX_STATE_TRACKS, SessionState
from plotgate.service.schemas import initiation_state as wire
from tests.support.requests import answer, cartesian, invalid_input

POLAR = {"mode": "polar", "v_max": 30.0}
TRACK, INI = 1, 3  # the track row and the initiator row mutated


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = Settings(log_dir=tmp_path_factory.mktemp("recordings"), git_commit="test")
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


@pytest.fixture(scope="module")
def session(client) -> tuple[dict, list[dict]]:
    """A real state after 3 scans of Mu et al.'s scene (clutter 20), and the next scans."""
    sim = answer(
        client.post(
            "/v1/initiation/simulate", json={"scenario": {"clutter": 20.0, "scans": 5}, "seed": 4}
        )
    )
    body = answer(
        client.post("/v1/initiation/initiate", json={"config": POLAR, "scans": sim["scans"][:3]})
    )
    state = body["state"]
    assert len(state["tracks"]["id"]) >= 3 and len(state["initiators"]["plot"]) > INI
    assert not state["tracks"]["confirmed"][TRACK] and any(state["tracks"]["confirmed"])
    return state, sim["scans"][3:]


def _post(client, state, scans, config=POLAR):
    return client.post(
        "/v1/initiation/initiate", json={"config": config, "state": state, "scans": scans}
    )


def _set(part: str, name: str, row: int, value) -> callable:
    def change(s: dict) -> None:
        s[part][name][row] = value(s[part][name][row]) if callable(value) else value

    return change


def _top(name: str, value) -> callable:
    def change(s: dict) -> None:
        s[name] = value(s) if callable(value) else value

    return change


def _drop(name: str) -> callable:
    return lambda s: s.pop(name)


def _shorten(part: str, name: str) -> callable:
    return lambda s: s[part][name].pop()


def _track_plot(s: dict) -> None:
    """Make initiator INI's plot one that track TRACK holds (no track took an initiator)."""
    plot = s["tracks"]["plots"][TRACK][-1]
    s["initiators"]["plot"][INI], s["initiators"]["scan"][INI] = plot, plot // PLOT_STRIDE


def _hole(s: dict) -> None:
    """A plot, then -1s, in track TRACK's history."""
    row = s["tracks"]["plots"][TRACK]
    row[0] = row[-2]


def _not_spd(s: dict) -> None:
    P = s["tracks"]["P"][TRACK]
    P[0][0] = -P[0][0]


def _asymmetric(s: dict) -> None:
    s["tracks"]["P"][TRACK][0][1] += 1.0


MUTATIONS = [
    # top level: counters, version, digest, time, keys
    ("scans negative", _top("scans", -1), "state.scans"),
    ("scans 2**63", _top("scans", 2**63), "state.scans"),
    ("scans past the session bound", _top("scans", 2**32 + 1), "state.scans"),
    ("scans absurd but in bounds", _top("scans", 2**32), "state.tracks.misses[0]"),
    ("scans not an integer", _top("scans", 3.5), "state.scans"),
    ("scans a string", _top("scans", "3"), "state.scans"),
    ("scans a boolean", _top("scans", True), "state.scans"),
    ("scans behind its initiators", _top("scans", 2), "state.initiators.scan[0]"),
    ("next_track negative", _top("next_track", -1), "state.next_track"),
    ("next_track 2**63", _top("next_track", 2**63), "state.next_track"),
    ("next_track below the ids", _top("next_track", 1), "state.tracks.id[1]"),
    ("t null after scans", _top("t", None), "state.t"),
    ("t huge", _top("t", 1e300), "state.t"),
    ("t before its plots", _top("t", lambda s: s["t"] - 10.0), "state.initiators.t[0]"),
    ("foreign version", _top("version", 1), "state.version"),
    ("version a string", _top("version", "2"), "state.version"),
    ("foreign digest", _top("config_digest", "0123456789abcdef"), "state.config_digest"),
    ("digest not hex", _top("config_digest", "not a digest!!!!"), "state.config_digest"),
    ("missing key", _drop("tracks"), "state.tracks"),
    ("extra key", _top("extra", 1), "state.extra"),
    ("part a list", _top("initiators", []), "state.initiators"),
    # initiators
    ("initiator plot negative", _set("initiators", "plot", INI, -1), "state.initiators.plot[3]"),
    ("initiator plot 2**63", _set("initiators", "plot", INI, 2**63), "state.initiators.plot[3]"),
    (
        "initiator plot of another scan",
        _set("initiators", "plot", INI, lambda v: v + PLOT_STRIDE),
        "state.initiators.plot[3]",
    ),
    (
        "initiator plot twice",
        lambda s: s["initiators"]["plot"].__setitem__(INI, s["initiators"]["plot"][INI - 1]),
        "state.initiators.plot[3]",
    ),
    ("initiator plot a track holds", _track_plot, "state.initiators.plot[3]"),
    ("initiator scan negative", _set("initiators", "scan", INI, -1), "state.initiators.scan[3]"),
    (
        "initiator scan after the counter",
        _set("initiators", "scan", INI, 3),
        "state.initiators.scan[3]",
    ),
    ("initiator time a string", _set("initiators", "t", INI, "now"), "state.initiators.t[3]"),
    (
        "initiator time after the state",
        _set("initiators", "t", INI, lambda v: v + 1.0),
        "state.initiators.t[3]",
    ),
    ("initiator z short", _set("initiators", "z", INI, [1.0]), "state.initiators.z[3]"),
    ("initiator z huge", _set("initiators", "z", INI, [1e20, 0.0]), "state.initiators.z[3][0]"),
    (
        "initiator R indefinite",
        _set("initiators", "R", INI, [[1.0, 2.0], [2.0, 1.0]]),
        "state.initiators.R[3]",
    ),
    (
        "initiator R asymmetric",
        _set("initiators", "R", INI, [[1.0, 0.5], [0.0, 1.0]]),
        "state.initiators.R[3]",
    ),
    (
        "initiator R thin",
        _set("initiators", "R", INI, [[1e-6, 0.0], [0.0, 1e12]]),
        "state.initiators.R[3]",
    ),
    (
        "initiator sensor far",
        _set("initiators", "sensor", INI, [2e9, 0.0]),
        "state.initiators.sensor[3][0]",
    ),
    ("initiator range at the sensor", _set("initiators", "r", INI, 0.5), "state.initiators.r[3]"),
    (
        "initiator azimuth out of [-pi, pi]",
        _set("initiators", "az", INI, 4.0),
        "state.initiators.az[3]",
    ),
    (
        "initiator sigma_r zero",
        _set("initiators", "sigma_r", INI, 0.0),
        "state.initiators.sigma_r[3]",
    ),
    (
        "initiator sigma_az negative",
        _set("initiators", "sigma_az", INI, -1.0),
        "state.initiators.sigma_az[3]",
    ),
    ("initiator times one short", _shorten("initiators", "t"), "state.initiators.t"),
    # tracks
    ("track id negative", _set("tracks", "id", TRACK, -1), "state.tracks.id[1]"),
    (
        "track id repeated",
        lambda s: s["tracks"]["id"].__setitem__(TRACK, s["tracks"]["id"][0]),
        "state.tracks.id[1]",
    ),
    ("track id 2**63", _set("tracks", "id", TRACK, 2**63), "state.tracks.id[1]"),
    ("confirmed an integer", _set("tracks", "confirmed", TRACK, 1), "state.tracks.confirmed[1]"),
    (
        "confirmed without a confirmation scan",
        _set("tracks", "confirmed", TRACK, True),
        "state.tracks.confirmed_scan[1]",
    ),
    ("x short", _set("tracks", "x", TRACK, [0.0, 0.0, 0.0]), "state.tracks.x[1]"),
    ("x huge", _set("tracks", "x", TRACK, [1e200, 0.0, 0.0, 0.0]), "state.tracks.x[1][0]"),
    ("P not positive definite", _not_spd, "state.tracks.P[1]"),
    ("P asymmetric", _asymmetric, "state.tracks.P[1]"),
    ("P a 3 x 3", _set("tracks", "P", TRACK, [[1.0, 0.0, 0.0]] * 3), "state.tracks.P[1][0]"),
    (
        "track time off the state's",
        _set("tracks", "t", TRACK, lambda v: v - 1.0),
        "state.tracks.t[1]",
    ),
    ("n negative", _set("tracks", "n", TRACK, -1), "state.tracks.n[1]"),
    ("n 2**63", _set("tracks", "n", TRACK, 2**63), "state.tracks.n[1]"),
    ("n more than its plots", _set("tracks", "n", TRACK, lambda v: v + 1), "state.tracks.n[1]"),
    ("first_scan negative", _set("tracks", "first_scan", TRACK, -1), "state.tracks.first_scan[1]"),
    (
        "first_scan after the counter",
        _set("tracks", "first_scan", TRACK, 7),
        "state.tracks.first_scan[1]",
    ),
    (
        "first_scan off its first plot",
        _set("tracks", "first_scan", TRACK, lambda v: v - 1),
        "state.tracks.first_scan[1]",
    ),
    (
        "confirmed_scan below -1",
        _set("tracks", "confirmed_scan", TRACK, -2),
        "state.tracks.confirmed_scan[1]",
    ),
    (
        "confirmed_scan on a tentative track",
        _set("tracks", "confirmed_scan", TRACK, 2),
        "state.tracks.confirmed_scan[1]",
    ),
    ("misses negative", _set("tracks", "misses", TRACK, -5), "state.tracks.misses[1]"),
    ("misses 2**63", _set("tracks", "misses", TRACK, 2**63), "state.tracks.misses[1]"),
    ("misses beyond drop_misses", _set("tracks", "misses", TRACK, 5), "state.tracks.misses[1]"),
    (
        "misses off its last plot",
        _set("tracks", "misses", TRACK, lambda v: v + 1),
        "state.tracks.misses[1]",
    ),
    ("cost negative", _set("tracks", "cost", TRACK, -1.0), "state.tracks.cost[1]"),
    ("score under k/m", _set("tracks", "score", TRACK, 5.0), "state.tracks.score[1]"),
    ("score a string", _set("tracks", "score", TRACK, "high"), "state.tracks.score[1]"),
    ("score huge", _set("tracks", "score", TRACK, 1e300), "state.tracks.score[1]"),
    (
        "initiator score under k/m",
        _set("initiators", "score", INI, -3.0),
        "state.initiators.score[3]",
    ),
    (
        "plot id beyond 2**52",
        _set("tracks", "plots", TRACK, lambda row: [*row[:-1], 2**60]),
        "state.tracks.plots[1][7]",
    ),
    (
        "plot id below -1",
        _set("tracks", "plots", TRACK, lambda row: [-2, *row[1:]]),
        "state.tracks.plots[1][0]",
    ),
    (
        "plot from a future scan",
        _set("tracks", "plots", TRACK, lambda row: [*row[:-1], 9 * PLOT_STRIDE]),
        "state.tracks.plots[1]",
    ),
    (
        "plots not from increasing scans",
        _set("tracks", "plots", TRACK, lambda row: [*row[:-2], row[-1], row[-2]]),
        "state.tracks.plots[1]",
    ),
    ("a -1 after the first plot", _hole, "state.tracks.plots[1]"),
    (
        "history one short",
        _set("tracks", "plots", TRACK, lambda row: row[1:]),
        "state.tracks.plots[1]",
    ),
    (
        "history one wide",
        _set("tracks", "ranges", TRACK, lambda row: [None, *row]),
        "state.tracks.ranges[1]",
    ),
    (
        "range null where a plot is",
        _set("tracks", "ranges", TRACK, lambda row: [*row[:-1], None]),
        "state.tracks.ranges[1]",
    ),
    (
        "range at the sensor",
        _set("tracks", "ranges", TRACK, lambda row: [*row[:-1], 0.5]),
        "state.tracks.ranges[1][7]",
    ),
    (
        "time after the state's",
        _set("tracks", "times", TRACK, lambda row: [*row[:-1], row[-1] + 5.0]),
        "state.tracks.times[1]",
    ),
    (
        "sigma_r zero",
        _set("tracks", "sigma_r", TRACK, lambda row: [*row[:-1], 0.0]),
        "state.tracks.sigma_r[1][7]",
    ),
    ("azimuth out of [-pi, pi]", _set("tracks", "az", TRACK, 7.0), "state.tracks.az[1]"),
    ("sigma_az zero", _set("tracks", "sigma_az", TRACK, 0.0), "state.tracks.sigma_az[1]"),
    ("sensor short", _set("tracks", "sensor", TRACK, [0.0]), "state.tracks.sensor[1]"),
    ("misses one short", _shorten("tracks", "misses"), "state.tracks.misses"),
    ("misses a string", lambda s: s["tracks"].__setitem__("misses", "3"), "state.tracks.misses"),
]


# ---------------------------------------------------------------- issue 24, finding 10
# Each tampered state below passed every check of the landed main.


def _confirmed_row(state: dict) -> int:
    return state["tracks"]["confirmed"].index(True)


def _copy_rows(state: dict, row: int, copies: int) -> None:
    """Append ``copies`` copies of track ``row`` under fresh ids (a forged duplicate)."""
    tracks = state["tracks"]
    for c in range(copies):
        for column in tracks.values():
            column.append(copy.deepcopy(column[row]))
        tracks["id"][-1] = state["next_track"] + c
    state["next_track"] += copies


def _velocity(s: dict) -> None:
    s["tracks"]["x"][TRACK][2] = 1e7


def _tiny_covariance(s: dict) -> None:
    s["tracks"]["P"][TRACK] = (np.eye(4) * 1e-300).tolist()


def _confirmed_at_0(s: dict) -> None:
    s["tracks"]["confirmed_scan"][_confirmed_row(s)] = 0


def _index_past_its_scan(s: dict) -> None:
    scan = s["initiators"]["scan"][INI]
    s["initiators"]["plot"][INI] = scan * PLOT_STRIDE + 500_000


TAMPERED = [
    ("velocity 1e7 m/s", _velocity, "state.tracks.x[1]"),
    ("P = 1e-300 I", _tiny_covariance, "state.tracks.P[1]"),
    ("track sigma_az 1e9", _set("tracks", "sigma_az", TRACK, 1e9), "state.tracks.sigma_az[1]"),
    (
        "initiator sigma_az 1e9",
        _set("initiators", "sigma_az", INI, 1e9),
        "state.initiators.sigma_az[3]",
    ),
    (
        "confirmed_scan 0",
        _confirmed_at_0,
        lambda s: f"state.tracks.confirmed_scan[{_confirmed_row(s)}]",
    ),
    ("plot index past its scan", _index_past_its_scan, "state.initiators.plot[3]"),
    (
        "initiator moved off its range and azimuth",
        _set("initiators", "z", INI, lambda z: [z[0] + 100.0, z[1]]),
        "state.initiators.r[3]",
    ),
    (
        "initiator sensor moved",
        _set("initiators", "sensor", INI, [0.0, 50.0]),
        "state.initiators.r[3]",
    ),
    (
        "initiator azimuth turned",
        _set("initiators", "az", INI, lambda az: az + 0.01),
        "state.initiators.az[3]",
    ),
    (
        "initiator sigma_r off its R",
        _set("initiators", "sigma_r", INI, lambda v: 2.0 * v),
        "state.initiators.sigma_r[3]",
    ),
    (
        "initiator R widened",
        _set("initiators", "R", INI, lambda R: [[4.0 * v for v in row] for row in R]),
        "state.initiators.sigma_r[3]",
    ),
    (
        "initiator time off its scan's",
        _set("initiators", "t", INI, lambda v: v - 0.5),
        "state.initiators.t[3]",
    ),
    (
        "track plot index past its scan",
        _set("tracks", "plots", TRACK, lambda row: [*row[:-1], row[-1] + 500_000]),
        "state.tracks.plots[1][7]",
    ),
]


@pytest.mark.parametrize(
    ("change", "field"),
    [m[1:] for m in MUTATIONS + TAMPERED],
    ids=[m[0] for m in MUTATIONS + TAMPERED],
)
def test_each_mutated_field_is_named(client, session, change, field):
    state, scans = session
    hostile = copy.deepcopy(state)
    change(hostile)
    field = field(state) if callable(field) else field
    problem = invalid_input(_post(client, hostile, scans), field)
    assert all(e["field"].startswith("state") for e in problem["errors"]), problem


def test_the_unmutated_state_continues(client, session):
    state, scans = session
    answer(_post(client, copy.deepcopy(state), scans))


def test_non_finite_tokens_in_a_state_are_refused(client, session):
    state, scans = session
    for token in ("NaN", "Infinity", "-Infinity"):
        text = json.dumps({"config": POLAR, "state": state, "scans": scans})
        cost = json.dumps(state["tracks"]["cost"][0])
        text = text.replace(f'"cost": [{cost}', f'"cost": [{token}', 1)
        r = client.post(
            "/v1/initiation/initiate",
            content=text.encode(),
            headers={"content-type": "application/json"},
        )
        assert r.status_code in (400, 422), r.text
        if r.status_code == 422:
            invalid_input(r, "state.tracks.cost[0]")


def test_random_mutations_never_fail_the_server(client, session):
    """Seeded: any field, any row, values from the edges; 422 naming a state field, or 200."""
    state, scans = session
    rnd = random.Random(12)
    values = [
        -1,
        0,
        1,
        2,
        3,
        2**31,
        2**32,
        2**52,
        2**53,
        2**63,
        -(2**63),
        1e-300,
        -0.0,
        0.5,
        3.15,
        1e9,
        1e100,
        1e300,
        -1e300,
        None,
        True,
        "x",
        [],
        [1.0],
        {},
    ]
    statuses = set()
    for _ in range(150):
        hostile = copy.deepcopy(state)
        part = rnd.choice(["initiators", "tracks"])
        name = rnd.choice(sorted(hostile[part]))
        column = hostile[part][name]
        row = rnd.randrange(len(column))
        if isinstance(column[row], list) and rnd.random() < 0.7:
            inner = column[row]
            k = rnd.randrange(len(inner))
            if isinstance(inner[k], list):
                inner[k][rnd.randrange(len(inner[k]))] = rnd.choice(values)
            else:
                inner[k] = rnd.choice(values)
        else:
            column[row] = rnd.choice(values)
        r = _post(client, hostile, scans)
        statuses.add(r.status_code)
        assert r.status_code in (200, 422), r.text
        if r.status_code == 422:
            assert all(e["field"].startswith("state") for e in r.json()["errors"]), r.text
    assert 422 in statuses


def test_the_state_counts_against_the_work_cap(session, tmp_path):
    """PLOTGATE_LIMITS caps initiation.initiate's size "state": tracks plus initiators."""
    state, scans = session
    size = len(state["tracks"]["id"]) + len(state["initiators"]["plot"])
    assert size > 20
    settings = Settings(
        log_dir=tmp_path, git_commit="test", limits={"initiation.initiate": {"state": 20}}
    )
    with TestClient(create_app(settings), raise_server_exceptions=False) as capped:
        body = invalid_input(_post(capped, state, scans), "state")
        assert f"is {size}" in body["detail"] and "at most 20" in body["detail"]
        small = copy.deepcopy(state)
        keep = range(20 - len(small["tracks"]["id"]))
        small["initiators"] = {k: [v[i] for i in keep] for k, v in small["initiators"].items()}
        small["seal"] = core_state.seal(small)  # a state these settings could have made
        answer(_post(capped, small, scans))


def test_the_schema_ceiling_bounds_a_state(client, session):
    state, scans = session
    hostile = copy.deepcopy(state)
    hostile["tracks"]["id"] = list(range(MAX_STATE_TRACKS + 1))
    invalid_input(_post(client, hostile, scans), "state.tracks.id")
    hostile = copy.deepcopy(state)
    hostile["initiators"]["plot"] = list(range(MAX_STATE_INITIATORS + 1))
    invalid_input(_post(client, hostile, scans), "state.initiators.plot")
    hostile = copy.deepcopy(state)
    wide = [-1] * (wire.MAX_HISTORY - 2) + [0, 1]
    hostile["tracks"]["plots"] = [wide] * (wire.MAX_HISTORY_CELLS // wire.MAX_HISTORY + 1)
    body = invalid_input(_post(client, hostile, scans), "state.tracks.plots")
    assert str(wire.MAX_HISTORY_CELLS) in body["detail"]
    schema = SessionState.model_json_schema()
    tracks = schema["$defs"]["SessionTracks"]["properties"]
    assert all(prop["maxItems"] == MAX_STATE_TRACKS for prop in tracks.values())


def test_a_call_that_would_hold_too_many_tracks_is_refused(client):
    """One initiator and MAX_STATE_TRACKS + 1 plots in its ring (branch): the scan would
    leave more live tracks than a state may carry, so the call stops there, naming it,
    rather than work on (or answer a state the next call could not take)."""
    first = answer(
        client.post(
            "/v1/initiation/initiate",
            json={"config": {"v_max": 1e4}, "scans": [{"t": 0.0, "plots": [cartesian(0.0, 5e4)]}]},
        )
    )
    rng = np.random.default_rng(1)
    xy = rng.uniform(-1000.0, 1000.0, (MAX_STATE_TRACKS + 1, 2)) + [0.0, 5e4]
    plots = [cartesian(float(x), float(y), 1.0, 1.0) for x, y in xy]
    r = client.post(
        "/v1/initiation/initiate",
        json={
            "config": {"v_max": 1e4},
            "state": first["state"],
            "scans": [{"t": 1.0, "plots": plots}],
        },
    )
    body = invalid_input(r, "scans[0]")
    assert f"leaves {MAX_STATE_TRACKS + 1} live tracks" in body["detail"]


def test_a_call_that_would_answer_too_many_initiators_is_refused(client):
    """A state at the initiators' ceiling less 50, and a scan of 100 plots no initiator
    captures: the answer's state would carry 50 initiators too many."""
    config = InitiationConfig(v_max=50.0, capture_scans=3)
    m = MAX_STATE_INITIATORS - 50
    xy = np.column_stack([np.arange(m) % 1000 * 100.0 + 1e4, np.arange(m) // 1000 * 100.0 + 1e4])
    r = np.hypot(*xy.T)
    ini = Initiators(
        plot=np.arange(m, dtype=np.int64),
        scan=np.zeros(m, dtype=np.int64),
        t=np.zeros(m),
        z=xy,
        R=np.tile(np.eye(2) * 100.0, (m, 1, 1)),
        sensor=np.zeros((m, 2)),
        r=r,
        az=np.arctan2(*xy.T),
        sigma_r=np.full(m, 10.0),
        sigma_az=10.0 / r,
        score=np.zeros(m),
    )
    state = empty_state(config).replace(scans=1, t=0.0, initiators=ini)
    check_state(state, config)
    far = [cartesian(-5e5 + 1000.0 * j, -5e5) for j in range(100)]
    body = invalid_input(
        client.post(
            "/v1/initiation/initiate",
            json={
                "config": {"v_max": 50.0, "capture_scans": 3},
                "state": state.to_json(),
                "scans": [{"t": 1.0, "plots": far}],
            },
        ),
        "scans",
    )
    assert "state.initiators.plot" in body["detail"]
    assert str(MAX_STATE_INITIATORS) in body["detail"]


@pytest.mark.parametrize(
    ("interval", "field", "says"),
    [
        (1e-300, "scans[1]", "beyond double precision"),  # tau^2 underflows: P_vv = inf
        (1e-150, "scans", "state.tracks.x[0][2]"),  # v = 10 m / tau = 1e151 m/s: finite, absurd
    ],
)
def test_plots_too_close_in_time_for_a_velocity_are_refused(client, interval, field, says):
    """Two plots 10 m apart, tau seconds apart, in the expanded gate (10 m sigma): no
    numpy warning escapes, and no state beyond the schema's magnitudes is answered."""
    scans = [
        {"t": 0.0, "plots": [cartesian(1000.0, 2000.0, 100.0, 100.0)]},
        {"t": interval, "plots": [cartesian(1010.0, 2000.0, 100.0, 100.0)]},
    ]
    body = invalid_input(
        client.post(
            "/v1/initiation/initiate",
            json={"config": {"capture_gate": "expanded"}, "scans": scans},
        ),
        field,
    )
    assert says in body["detail"]


def test_schema_bounds_match_core():
    assert wire.MAX_SESSION_SCANS == core_state.MAX_SESSION_SCANS
    assert wire.MAX_TRACK_ID == core_state.MAX_TRACK_ID
    assert wire.MAX_PLOT_ID == core_state.MAX_SESSION_SCANS * PLOT_STRIDE
    assert wire.PLOT_STRIDE == PLOT_STRIDE


@pytest.mark.parametrize(
    "config",
    [
        InitiationConfig(mode="polar", v_max=30.0),
        InitiationConfig(v_max=30.0, capture_gate="combined"),
        InitiationConfig(
            v_max=30.0, capture_gate="expanded", filter="alpha_beta", association="nearest"
        ),
        InitiationConfig(
            v_max=30.0,
            capture_scans=4,
            history=4,
            confirm_k=2,
            confirm_m=4,
            drop_misses=5,
            capture_time=None,
        ),
        InitiationConfig(
            mode="polar",
            v_max=30.0,
            capture_time=2.5,
            confirm_k=4,
            confirm_m=6,
            history=6,
            drop_misses=3,
        ),
        InitiationConfig(v_max=30.0, capture_scans=3, confirm_k=1, confirm_m=1, history=2),
        InitiationConfig(v_max=30.0, confirmation="score", surveillance_area=15000.0**2),
        InitiationConfig(
            mode="polar",
            v_max=30.0,
            confirmation="score",
            clutter_density=1e-6,
            history=4,
            capture_scans=3,
        ),
    ],
    ids=[
        "polar",
        "combined",
        "expanded-alpha-beta-nearest",
        "long-history",
        "polar-2-over-T",
        "1-of-1",
        "score",
        "polar-score-short-history",
    ],
)
def test_every_state_initiation_produces_passes_every_check(config):
    """After each of 12 scans of a cluttered scene (clutter 250, two seeds), the state
    passes the invariants under the service's plot bounds and the wire schema: what a
    call answers, the next takes."""
    for seed in (0, 1):
        sim = simulate(mu_scenario(250.0, scans=12), seed)
        state = None
        for scan in sim.scans:
            state, _ = initiate(state, [scan], config)
            check_state(state, config, PLOT_BOUNDS)
            data = SessionState.model_validate(state.to_json()).model_dump()
            assert state_from_json(data, config, PLOT_BOUNDS).to_json() == state.to_json()
        assert state.tracks.size > 0


def _as_cartesian(plot: dict) -> dict:
    """A simulated polar plot as the Cartesian plot of the same position and covariance."""
    az, saz = np.radians(plot["az_deg"]), np.radians(plot["sigma_az_deg"])
    (x, y), R = (
        polar_to_cartesian(plot["r"], az),
        polar_covariance_to_cartesian(plot["r"], az, plot["sigma_r"], saz),
    )
    return cartesian(float(x), float(y), float(R[0, 0]), float(R[1, 1]), float(R[0, 1]))


@pytest.mark.parametrize("frame", ["polar", "cartesian"])
@pytest.mark.parametrize(
    "config",
    [
        {"v_max": 30.0},
        {"mode": "polar", "v_max": 30.0},
        {"v_max": 30.0, "confirmation": "score", "surveillance_area": 15000.0**2},
        {"mode": "polar", "v_max": 30.0, "confirmation": "score", "clutter_density": 1e-6},
    ],
    ids=["k-of-m", "polar-k-of-m", "score", "polar-score"],
)
def test_the_service_takes_back_every_state_it_answers(client, frame, config):
    """Seeded sessions sent one scan a call, each call passing back the state the last
    answered: the new checks refuse nothing the service itself produces."""
    for seed in (2, 3):
        sim = answer(
            client.post(
                "/v1/initiation/simulate",
                json={"scenario": {"clutter": 100.0, "scans": 8}, "seed": seed},
            )
        )
        state = None
        for scan in sim["scans"]:
            if frame == "cartesian":
                scan = {**scan, "plots": [_as_cartesian(p) for p in scan["plots"]]}
            body = answer(
                client.post(
                    "/v1/initiation/initiate",
                    json={"config": config, "state": state, "scans": [scan]},
                )
            )
            state = body["state"]
        assert state["tracks"]["id"], "the session ends with live tracks"


@pytest.mark.parametrize("copies", [2, 100])
@pytest.mark.parametrize("confirmed", [True, False], ids=["confirmed", "tentative"])
def test_duplicated_tracks_are_refused(client, session, copies, confirmed):
    """A track copied under fresh ids, its history identical: refused naming the first
    copy's plots (the original row stays valid)."""
    state, scans = session
    hostile = copy.deepcopy(state)
    row = _confirmed_row(state) if confirmed else TRACK
    first_copy = len(state["tracks"]["id"])
    _copy_rows(hostile, row, copies)
    invalid_input(_post(client, hostile, scans), f"state.tracks.plots[{first_copy}]")


def _state_under(client, config: dict, scans: list[dict]) -> dict:
    return answer(client.post("/v1/initiation/initiate", json={"config": config, "scans": scans}))[
        "state"
    ]


def test_a_state_of_other_settings_under_a_forged_digest_is_refused(client, session):
    """The digest is a fingerprint anyone can recompute, so a forged one is caught by the
    contents: initiators older than the settings' capture window, tracks confirmed
    sooner than their k allows."""
    state, scans = session
    sim = answer(
        client.post(
            "/v1/initiation/simulate", json={"scenario": {"clutter": 20.0, "scans": 4}, "seed": 4}
        )
    )["scans"]
    wide = _state_under(client, {**POLAR, "capture_scans": 3}, sim[:3])
    forged = {**wide, "config_digest": state["config_digest"]}
    body = invalid_input(_post(client, forged, sim[3:]), "state.initiators.scan[0]")
    assert "capture" in body["detail"]

    stricter = {**POLAR, "confirm_k": 4, "confirm_m": 4}
    digest = _state_under(client, stricter, sim[:1])["config_digest"]
    forged = {**state, "config_digest": digest}
    row = _confirmed_row(state)
    invalid_input(_post(client, forged, scans, stricter), f"state.tracks.confirmed_scan[{row}]")


def test_a_two_point_start_from_a_thin_plot_is_taken_back(client):
    """A wide plot, then a thin one (both within the wire's limits) start a track whose
    covariance is singular in exact arithmetic; eigvalsh rounds its smallest eigenvalue to
    -6e-12, and the landed check refused the state the service had just answered."""
    wide = cartesian(0.0, 10000.0, 1e6, 1e6)
    thin = cartesian(
        1.0, 10001.0, 0.006935750499211673, 0.0030642495008522046, -0.00461008351384289
    )
    config = {"v_max": 30.0}
    first = answer(
        client.post(
            "/v1/initiation/initiate",
            json={
                "config": config,
                "scans": [{"t": 0.0, "plots": [wide]}, {"t": 1.0, "plots": [thin]}],
            },
        )
    )
    assert len(first["tracks"]) == 1
    answer(
        client.post(
            "/v1/initiation/initiate",
            json={"config": config, "state": first["state"], "scans": [{"t": 2.0, "plots": []}]},
        )
    )


# ---------------------------------------------------------------- issue 35, defect 7
# A tentative track moved, sped up or widened, and a digest moved from a state of other
# settings: each was answered 200 by the landed main (the moved track silently dropped).


def _tentative_velocity(delta: float) -> callable:
    def change(s: dict) -> None:
        s["tracks"]["x"][TRACK][2] += delta

    return change


def _moved(metres: float) -> callable:
    def change(s: dict) -> None:
        s["tracks"]["x"][TRACK][0] += metres

    return change


def _widened(s: dict) -> None:
    s["tracks"]["P"][TRACK] = [[100.0 * v for v in row] for row in s["tracks"]["P"][TRACK]]


@pytest.mark.parametrize("metres", [1e4, 1e6, 1e10, 1e15])
def test_a_tentative_track_moved_off_its_plots_is_refused(client, session, metres):
    state, scans = session
    hostile = copy.deepcopy(state)
    _moved(metres)(hostile)
    body = invalid_input(_post(client, hostile, scans), f"state.tracks.x[{TRACK}]")
    assert "its plots" in body["detail"]


def test_a_tentative_track_sped_up_within_six_sigma_is_refused(client, session):
    """45 m/s more: within v_max = 30 m/s but for 6 of the track's own velocity sigmas,
    so the speed check alone lets it through."""
    state, scans = session
    P = np.array(state["tracks"]["P"][TRACK])
    x = np.array(state["tracks"]["x"][TRACK]) + [0.0, 0.0, 45.0, 0.0]
    assert core_speed_excess(x[None], P[None], POLAR["v_max"])[0] <= SPEED_SIGMAS
    hostile = copy.deepcopy(state)
    _tentative_velocity(45.0)(hostile)
    invalid_input(_post(client, hostile, scans), f"state.tracks.x[{TRACK}]")


def test_a_tentative_track_s_covariance_times_100_is_refused(client, session):
    state, scans = session
    hostile = copy.deepcopy(state)
    _widened(hostile)
    invalid_input(_post(client, hostile, scans), f"state.tracks.P[{TRACK}]")


def test_a_digest_moved_from_a_state_of_other_settings_is_refused(client, session):
    """A state of v_max 30 under the digest of a state made with v_max 300, sent with
    v_max 300: its values are ones v_max 300 could have made, so only the seal, which
    binds the digest to the values it was answered with, tells it apart."""
    state, scans = session
    wider = {**POLAR, "v_max": 300.0}
    sim = answer(
        client.post(
            "/v1/initiation/simulate", json={"scenario": {"clutter": 20.0, "scans": 2}, "seed": 4}
        )
    )["scans"]
    digest = _state_under(client, wider, sim[:1])["config_digest"]
    forged = {**copy.deepcopy(state), "config_digest": digest}
    body = invalid_input(_post(client, forged, scans, wider), "state.config_digest")
    assert "seal" in body["detail"]


HELD = [
    (
        "held plot dropped",
        lambda s: [s["plots"][k].pop(0) for k in ("plot", "z", "R")],
        "state.tracks.plots",
    ),
    (
        "held plot moved",
        _set("plots", "z", 0, lambda z: [z[0] + 50.0, z[1]]),
        "state.tracks",
    ),
    ("held plot id not increasing", _set("plots", "plot", 1, 0), "state.plots.plot[1]"),
    ("seal changed", _top("seal", "0123456789abcdef"), "state.config_digest"),
    ("seal missing", _drop("seal"), "state.seal"),
]


@pytest.mark.parametrize(("change", "field"), [h[1:] for h in HELD], ids=[h[0] for h in HELD])
def test_held_plots_tampered_are_named(client, session, change, field):
    state, scans = session
    hostile = copy.deepcopy(state)
    change(hostile)
    r = _post(client, hostile, scans)
    assert r.status_code == 422, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    assert r.json()["errors"][0]["field"].startswith(field), r.text
