"""Existence confirmation over HTTP: the answer is core's, each track's probability of
existence is on the wire, two calls answer as one through the wire state, a tampered
existence is named, and the picture labels tentative tracks with their existence."""

import json
import math
from pathlib import Path

import numpy as np

from plotgate.core.initiation import InitiationConfig, initiate
from plotgate.core.initiation.existence import existence
from plotgate.core.initiation.simulate import mu_scenario, simulate
from plotgate.service.scenes.initiation import track_label
from tests.support.requests import answer

EXAMPLE = Path(__file__).parents[2] / "docs/examples/existence_clutter_250.json"


def _scans(client):
    body = {"scenario": {"clutter": 250.0, "scans": 4}, "seed": 3}
    return answer(client.post("/v1/initiation/simulate", json=body))["scans"]


def test_existence_is_cores_and_on_the_wire(client):
    settings = json.loads(EXAMPLE.read_text())
    scans = _scans(client)
    body = answer(
        client.post("/v1/initiation/initiate", json={"config": settings, "scans": scans})
    )
    state, reports = initiate(
        None, simulate(mu_scenario(250.0), 3).scans, InitiationConfig(**settings)
    )
    assert [s["confirmed"] for s in body["scans"]] == [r.confirmed.tolist() for r in reports]
    np.testing.assert_allclose(
        [t["existence"] for t in body["tracks"]], existence(state.tracks.score), rtol=1e-12
    )
    first = answer(
        client.post("/v1/initiation/initiate", json={"config": settings, "scans": scans[:2]})
    )
    rest = answer(
        client.post(
            "/v1/initiation/initiate",
            json={"config": settings, "state": first["state"], "scans": scans[2:]},
        )
    )
    assert rest["state"] == body["state"]


def test_a_tampered_existence_is_named(client):
    settings = json.loads(EXAMPLE.read_text())
    first = answer(
        client.post(
            "/v1/initiation/initiate", json={"config": settings, "scans": _scans(client)[:2]}
        )
    )
    state = first["state"]
    tentative = state["tracks"]["confirmed"].index(False)
    state["tracks"]["score"][tentative] = math.log(0.001 / 0.999)
    reply = client.post(
        "/v1/initiation/initiate",
        json={"config": settings, "state": state, "scans": _scans(client)[2:]},
    )
    assert reply.status_code == 422
    assert "state.tracks.score" in json.dumps(reply.json())


def test_the_picture_labels_existence_on_tentative_tracks():
    track = {"id": 7, "status": "tentative", "existence": 0.834}
    assert track_label(track) == "T7 tentative P_E 0.83"
    assert track_label({**track, "status": "confirmed"}) == "T7 confirmed"
    assert track_label({"id": 7, "status": "tentative"}) == "T7 tentative"
