"""Identification over HTTP: answers are core's (degrees on the wire), bad input is
named, and a session records and replays."""

import asyncio
import json

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from plotgate.clients import AsyncClient
from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.core.identification import experiment, identify_picture, z_test
from plotgate.service.app import create_app
from plotgate.service.table import ENDPOINTS
from tests.support.requests import answer, invalid_input

RNG = np.random.default_rng(7)
PASSIVE = (359.9 + 0.3 * RNG.standard_normal(50)) % 360.0
ACTIVE = (0.0 + 0.3 * RNG.standard_normal(5)) % 360.0


def test_pair_is_cores_in_degrees(client):
    body = answer(
        client.post(
            "/v1/identification/pair",
            json={
                "passive_bearings_deg": PASSIVE.tolist(),
                "active_bearings_deg": ACTIVE.tolist(),
                "delta_deg": 0.5,
                "beta_max": 0.05,
                "sequential": True,
            },
        )
    )
    t = z_test(np.radians(PASSIVE), np.radians(ACTIVE), delta=np.radians(0.5), beta_max=0.05)
    assert body["identified"] is True and body["z"] == pytest.approx(t.z.tolist(), rel=1e-12)
    assert body["sigma_deg"][0] == pytest.approx(np.degrees(t.sigma[0]), rel=1e-12)
    assert body["m_required"] == t.m_required and body["beta"] == pytest.approx(t.beta)
    assert body["n_over_m"] == 10.0 and body["large_population"] is True
    assert body["history"]["m"] == [2, 3, 4, 5]
    assert body["history"]["z"][-1] == pytest.approx(body["z"][0], rel=1e-9)


def test_picture_is_cores(client):
    passive = [(c + 0.2 * RNG.standard_normal(50)).tolist() for c in (10.0, 20.0, 30.0)]
    active = [(c + 0.2 * RNG.standard_normal(5)).tolist() for c in (30.0, 10.0)]
    body = answer(
        client.post(
            "/v1/identification/picture",
            json={"passive_deg": passive, "active_deg": active, "sigma_deg": 0.2},
        )
    )
    pic = identify_picture(np.radians(passive), np.radians(active), np.radians(0.2))
    assert body["pairs"] == pic.pairs.tolist() == [[0, 1], [2, 0]]
    assert body["unassigned_passive"] == [1] and body["unassigned_active"] == []
    np.testing.assert_allclose(body["z"], pic.z, rtol=1e-12)


def test_simulate_is_cores(client):
    body = answer(client.post("/v1/identification/simulate", json={"runs": 2000, "seed": 4}))
    out = experiment(50, 5, np.radians(1.0), 0.0, np.radians(3.0), 2000, 4)
    assert body["rejected"] == pytest.approx(out.rejected, abs=1e-15)


def test_bad_identification_input_is_named(client):
    pair = {"passive_bearings_deg": PASSIVE.tolist(), "active_bearings_deg": ACTIVE.tolist()}
    post = lambda path, body: client.post(path, json=body)  # noqa: E731
    invalid_input(
        post("/v1/identification/pair", {**pair, "active_bearings_deg": [1.0]}),
        "active_bearings_deg",
    )
    invalid_input(post("/v1/identification/pair", {**pair, "sigma_deg": 0.0}), "sigma_deg")
    invalid_input(post("/v1/identification/pair", {**pair, "alpha": 1.0}), "alpha")
    invalid_input(post("/v1/identification/pair", {**pair, "alpha": 0.0}), "alpha")
    bad = client.post(
        "/v1/identification/pair",
        content=json.dumps(pair).replace(str(PASSIVE[0]), "NaN"),
        headers={"content-type": "application/json"},
    )
    invalid_input(bad, "passive_bearings_deg[0]")
    invalid_input(post("/v1/identification/pair", {**pair, "beta_max": 0.05}), "beta_max")
    invalid_input(
        post("/v1/identification/pair", {**pair, "passive_elevations_deg": [1, 2]}),
        "active_elevations_deg",
    )
    flat = {"passive_bearings_deg": [5.0, 5.0, 5.0], "active_bearings_deg": [5.0, 5.1]}
    invalid_input(post("/v1/identification/pair", flat), "sigma_deg")
    picture = {"passive_deg": [[1.0, 2.0], [3.0]], "active_deg": [[1.0, 1.5]]}
    invalid_input(post("/v1/identification/picture", picture), "passive_deg[1]")
    picture = {"passive_deg": [[1.0, 2.0]], "active_deg": [[1.0, 1.5]], "sigma_deg": [1, 2]}
    invalid_input(post("/v1/identification/picture", picture), "sigma_deg")
    invalid_input(post("/v1/identification/simulate", {"runs": 10_000_000}), "runs")


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"alpha": 1e-13}, "alpha"),  # z_{1 - alpha/2} would be infinite
        ({"normality_alpha": 5e-324}, "normality_alpha"),
        ({"sigma_deg": 1e-7}, "sigma_deg"),  # Z = d sqrt(m) / sigma would overflow
        ({"delta_deg": 1e-300, "beta_max": 0.05}, "beta_max"),  # m needed overflows
        ({"delta_deg": 1e-3, "beta_max": 1e-12}, "beta_max"),
        ({"passive_bearings_deg": [0.0, 5e-324, 0.0]}, "sigma_deg"),  # equal to rounding
    ],
)
def test_levels_and_sigmas_are_bounded_so_z_stays_finite(client, changes, field):
    pair = {"passive_bearings_deg": PASSIVE.tolist(), "active_bearings_deg": ACTIVE.tolist()}
    invalid_input(client.post("/v1/identification/pair", json={**pair, **changes}), field)


def test_session_records_and_replays(settings, tmp_path):
    pair = {"passive_bearings_deg": PASSIVE.tolist(), "active_bearings_deg": ACTIVE.tolist()}
    with TestClient(create_app(settings)) as c:
        answer(c.post("/v1/identification/pair", json=pair))
        answer(
            c.post(
                "/v1/identification/picture",
                json={"passive_deg": [PASSIVE.tolist()], "active_deg": [ACTIVE.tolist()]},
            )
        )
        answer(c.post("/v1/identification/simulate", json={"runs": 100}))
        assert c.post("/v1/identification/pair", json={**pair, "alpha": 2}).status_code == 422
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    assert [e.operation for e in read_recording(path).exchanges] == [
        "identification.pair",
        "identification.picture",
        "identification.simulate",
        "identification.pair",
    ]
    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    assert json.loads(report.read_text())["unchanged"] == 4


def test_client_methods(settings):
    asyncio.run(_client_calls(create_app(settings)))


async def _client_calls(app) -> None:
    transport = httpx.ASGITransport(app=app)
    async with AsyncClient("http://plotgate", transport=transport) as client:
        t = await client.identify_pair(
            {"passive_bearings_deg": PASSIVE.tolist(), "active_bearings_deg": ACTIVE.tolist()}
        )
        assert t.identified
        pic = await client.identify_picture(
            {"passive_deg": [PASSIVE.tolist()], "active_deg": [ACTIVE.tolist()]}
        )
        assert pic.pairs == [[0, 0]]
        sim = await client.simulate_identification({"runs": 50})
        assert sim.runs == 50


def test_every_field_is_described():
    for name in ("identification.pair", "identification.picture", "identification.simulate"):
        endpoint = ENDPOINTS[name]
        for model in (endpoint.request, endpoint.response):
            schema = model.model_json_schema()
            for sub in (schema, *schema.get("$defs", {}).values()):
                for field, prop in sub.get("properties", {}).items():
                    assert prop.get("description"), f"{sub['title']}.{field}: no description"
