"""Track initiation over HTTP: the answer is core's, the state round-trips through the
wire, bad input is named, and a session records and replays."""

import asyncio
import json
from dataclasses import fields
from typing import get_args

import httpx
import numpy as np
from fastapi.testclient import TestClient

from plotgate.clients import AsyncClient
from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.core.errors import ParameterError
from plotgate.core.initiation import InitiationConfig, initiate
from plotgate.core.initiation.config import CHOICES
from plotgate.core.initiation.scan import MIN_SENSOR_RANGE
from plotgate.core.initiation.simulate import Scenario, mu_scenario, simulate
from plotgate.service.app import create_app
from plotgate.service.schemas import MAX_PLOTS, InitiationSettings
from plotgate.service.schemas.common import MIN_RANGE
from plotgate.service.table import ENDPOINTS
from tests.support.requests import answer, invalid_input

POLAR = {"mode": "polar", "v_max": 30.0, "a_max": 10.0, "K_A": 3.0}


def _simulated_body(client, body: dict) -> dict:
    return answer(client.post("/v1/initiation/simulate", json=body))


def _simulated(client, clutter=250.0, seed=3, scans=4) -> dict:
    return answer(
        client.post(
            "/v1/initiation/simulate",
            json={"scenario": {"clutter": clutter, "scans": scans}, "seed": seed},
        )
    )


def test_simulate_and_initiate_are_cores(client):
    sim = _simulated(client)
    core_sim = simulate(mu_scenario(250.0), 3)
    assert sim["labels"] == [lab.tolist() for lab in core_sim.labels]
    body = answer(
        client.post("/v1/initiation/initiate", json={"config": POLAR, "scans": sim["scans"]})
    )
    state, reports = initiate(
        None, core_sim.scans, InitiationConfig(mode="polar", v_max=30.0, a_max=10.0, K_A=3.0)
    )
    assert [s["confirmed"] for s in body["scans"]] == [r.confirmed.tolist() for r in reports]
    assert [s["associated"] for s in body["scans"]] == [r.associated.tolist() for r in reports]
    assert [t["id"] for t in body["tracks"]] == state.tracks.id.tolist()
    np.testing.assert_allclose(
        [t["position"] for t in body["tracks"]], state.tracks.x[:, :2], rtol=1e-9
    )
    confirmed = [t for t in body["tracks"] if t["status"] == "confirmed"]
    assert confirmed and all(len(t["plots"]) >= 3 for t in confirmed)
    # the plots of a confirmed track point back into the request's scans
    scan, index = confirmed[0]["plots"][-1]
    assert body["scans"][scan]["associated"][index] == confirmed[0]["id"]


def test_polar_plots_reach_core_as_measured(client):
    # a polar plot's range, azimuth and sigmas are core's as sent (no round trip through
    # Cartesian coordinates), an azimuth beyond 180 degrees wrapped; a Cartesian plot
    # among them keeps its place and gets its range and azimuth from its position
    polar = {"frame": "polar", "sigma_r": 5.0, "sigma_az_deg": 0.2, "sensor": [10.0, -20.0]}
    plots = [
        {**polar, "r": 12345.678, "az_deg": -170.25},
        {"frame": "cartesian", "x": 3000.0, "y": 4000.0, "covariance": [[4.0, 0.0], [0.0, 4.0]]},
        {**polar, "r": 9000.5, "az_deg": 350.0},
    ]
    body = answer(
        client.post("/v1/initiation/initiate", json={"scans": [{"t": 0.0, "plots": plots}]})
    )
    ini = body["state"]["initiators"]
    assert ini["r"][0] == 12345.678 and ini["r"][2] == 9000.5 and ini["r"][1] == 5000.0
    assert ini["az"][0] == np.radians(-170.25)
    assert abs(ini["az"][2] - np.radians(-10.0)) < 1e-15
    assert ini["sigma_r"][0] == ini["sigma_r"][2] == 5.0
    assert ini["sigma_az"][0] == ini["sigma_az"][2] == np.radians(0.2)
    assert ini["sensor"] == [[10.0, -20.0], [0.0, 0.0], [10.0, -20.0]]


def test_a_polar_plots_least_range_is_cores():
    # the wire refuses the ranges core would refuse, and no more: one value, held here
    # (schemas do not import core)
    assert MIN_RANGE == MIN_SENSOR_RANGE


def test_state_round_trips_through_the_wire(client):
    sim = _simulated(client, scans=6)
    whole = answer(
        client.post("/v1/initiation/initiate", json={"config": POLAR, "scans": sim["scans"]})
    )
    state, outcomes = None, []
    for scan in sim["scans"]:
        body = answer(
            client.post(
                "/v1/initiation/initiate", json={"config": POLAR, "state": state, "scans": [scan]}
            )
        )
        state = json.loads(json.dumps(body["state"]))
        outcomes += body["scans"]
    assert state == whole["state"] and outcomes == whole["scans"]


def test_bad_initiation_input_is_named(client):
    sim = _simulated(client, scans=2)
    post = lambda **body: client.post("/v1/initiation/initiate", json=body)  # noqa: E731
    first = answer(post(config=POLAR, scans=sim["scans"][:1]))
    invalid_input(
        post(config={**POLAR, "v_max": 31.0}, state=first["state"], scans=sim["scans"][1:]),
        "state.config_digest",
    )
    invalid_input(
        post(config=POLAR, state={"version": 1}, scans=sim["scans"]), "state.config_digest"
    )
    broken = dict(first["state"], tracks=dict(first["state"]["tracks"], x=[[1.0]]))
    invalid_input(post(config=POLAR, state=broken, scans=sim["scans"][1:]), "state.tracks.x[0]")
    invalid_input(
        post(config={"gate_widening": [2.0, 1.0]}, scans=sim["scans"]), "config.gate_widening"
    )
    invalid_input(post(config={"v_min": 60.0}, scans=sim["scans"]), "config.v_max")
    invalid_input(post(config={"confirm_k": 5}, scans=sim["scans"]), "config.confirm_k")
    invalid_input(post(config={"mode": "spherical"}, scans=sim["scans"]), "config.mode")
    late = [dict(sim["scans"][1]), dict(sim["scans"][0])]
    invalid_input(post(scans=late), "scans[1]")
    at_sensor = {"frame": "cartesian", "x": 0.5, "y": 0.0, "covariance": [[1.0, 0.0], [0.0, 1.0]]}
    invalid_input(
        post(scans=[{"t": 0.0, "plots": [sim["scans"][0]["plots"][0], at_sensor]}]),
        "scans[0].plots[1]",
    )
    invalid_input(post(scans=[]), "scans")
    plot = sim["scans"][0]["plots"][0]
    many = [{"t": float(i), "plots": [plot] * (MAX_PLOTS // 2 + 1)} for i in range(2)]
    invalid_input(post(scans=many), "scans")


def test_bad_scenarios_are_named(client):
    post = lambda path, **body: client.post(path, json=body)  # noqa: E731
    invalid_input(
        post("/v1/initiation/simulate", scenario={"region": [1.0, 0.0, 0.0, 1.0]}),
        "scenario.region",
    )
    invalid_input(post("/v1/initiation/simulate", scenario={"P_D": 1.5}), "scenario.P_D")
    invalid_input(
        post("/v1/initiation/simulate", scenario={"clutter": 90000, "scans": 2}), "scenario"
    )
    # the default cap on an evaluation's work, then the schema's ceiling on its plots
    work = "runs x scans x plots"
    invalid_input(post("/v1/initiation/evaluate", runs=10_000, scenario={"clutter": 250}), work)
    invalid_input(post("/v1/initiation/evaluate", runs=10_000, scenario={"clutter": 2500}), "runs")
    invalid_input(post("/v1/initiation/evaluate", config={"K_A": 0.5}), "config.K_A")


def test_evaluate_answers_the_means(client):
    body = answer(
        client.post(
            "/v1/initiation/evaluate",
            json={"scenario": {"clutter": 0, "P_D": 1.0}, "config": POLAR, "runs": 3, "seed": 1},
        )
    )
    assert body["mean_true"] == 5.0 and body["mean_false"] == 0.0
    assert body["confirmable"] == 5.0 and body["mean_time_to_confirmation"] == 2.0


SCORE = {**POLAR, "confirmation": "score", "P_D": 0.8, "surveillance_area": 15000.0**2}


def test_a_sweep_answers_each_values_evaluation_on_the_same_scans(client):
    base = {"scenario": {"clutter": 100}, "runs": 4, "seed": 9}
    sweep = {"parameter": "false_confirmation", "values": [0.01, 0.5]}
    body = answer(
        client.post("/v1/initiation/evaluate", json={**base, "config": SCORE, "sweep": sweep})
    )
    alone = answer(client.post("/v1/initiation/evaluate", json={**base, "config": SCORE}))
    assert alone["sweep"] is None
    assert {k: v for k, v in body.items() if k != "sweep"} == {
        k: v for k, v in alone.items() if k != "sweep"
    }
    for value, point in zip(sweep["values"], body["sweep"], strict=True):
        config = {**SCORE, "false_confirmation": value}
        one = answer(client.post("/v1/initiation/evaluate", json={**base, "config": config}))
        assert point == {"value": value, **{k: v for k, v in one.items() if k in point}}
    # k/m as "k/m"
    km = answer(
        client.post(
            "/v1/initiation/evaluate",
            json={**base, "config": POLAR, "sweep": {"parameter": "confirm", "values": ["2/3"]}},
        )
    )
    one = answer(
        client.post(
            "/v1/initiation/evaluate",
            json={**base, "config": {**POLAR, "confirm_k": 2, "confirm_m": 3}},
        )
    )
    assert km["sweep"][0]["mean_true"] == one["mean_true"]
    answer(
        client.post(
            "/v1/initiation/evaluate",
            json={
                **base,
                "config": POLAR,
                "sweep": {"parameter": "capture_scans", "values": [3]},
            },
        )
    )


def test_bad_sweeps_are_named(client):
    post = lambda **body: client.post("/v1/initiation/evaluate", json={"runs": 2, **body})  # noqa: E731
    invalid_input(post(sweep={"parameter": "confirm", "values": ["3/4", "x"]}), "sweep.values[1]")
    invalid_input(post(sweep={"parameter": "confirm", "values": ["5/4"]}), "sweep.values[0]")
    invalid_input(post(sweep={"parameter": "gate_P_G", "values": [0.9, 1.0]}), "sweep.values[1]")
    # each value as strictly as the setting itself; k/m in ASCII digits only
    for parameter, value in [
        ("gate_P_G", "0.9"),
        ("capture_scans", 3.0),
        ("confirm_k", "3"),
        ("gate_P_G", True),
        ("gate_P_G", [0.9]),
        ("gate_P_G", {"a": 1}),
        ("confirm", "\u00b2/4"),
        ("confirm", "\u0661/4"),
        ("confirm", "1" * 5000 + "/4"),
        ("confirm", " 3/4"),
        ("confirm", "3/4/5"),
        ("confirm", 3),
    ]:
        body = invalid_input(
            post(sweep={"parameter": parameter, "values": [value]}), "sweep.values[0]"
        )
        assert [e["field"] for e in body["errors"]] == ["sweep.values[0]"], (parameter, value)
    invalid_input(post(sweep={"parameter": "gate_widening", "values": [1.0]}), "sweep.parameter")
    invalid_input(post(sweep={"parameter": "gate_P_G", "values": []}), "sweep.values")
    invalid_input(
        post(sweep={"parameter": "true_deletion", "values": [0.9995]}, config=SCORE),
        "sweep.values[0]",
    )
    # the work limit counts every evaluation of the sweep
    many = {"parameter": "gate_P_G", "values": [0.9] * 9}
    invalid_input(post(runs=600, scenario={"clutter": 20}, sweep=many), "runs x scans x plots")
    invalid_input(post(config={"confirmation": "score"}), "config.clutter_density")


def test_scenario_plots_stay_within_a_plots_bounds(client):
    # a target within 10 sigma_r of 1e9 m, or one that leaves that reach by its last scan, or
    # clutter beyond it, would draw plots no plot schema takes: refused, naming the part
    far = {"targets": [{"position": [0.0, 999_999_990.0], "velocity": [0.0, 0.0]}]}
    invalid_input(
        client.post("/v1/initiation/simulate", json={"scenario": far}), "scenario.targets[0]"
    )
    leaving = {
        "targets": [{"position": [0.0, 1000.0], "velocity": [1e6, 0.0]}],
        "interval": 1e3,
        "scans": 3,
    }
    invalid_input(
        client.post("/v1/initiation/evaluate", json={"scenario": leaving}), "scenario.targets[0]"
    )
    wide = {"region": [-1e9, 1e9, -1e9, 1e9]}
    invalid_input(
        client.post("/v1/initiation/simulate", json={"scenario": wide}), "scenario.region"
    )
    for field, value in (("sigma_r", 1e-4), ("sigma_az_deg", 1e-7)):
        invalid_input(
            client.post("/v1/initiation/simulate", json={"scenario": {field: value}}),
            f"scenario.{field}",
        )
    fast = {"targets": [{"position": [0.0, 1000.0], "velocity": [2e6, 0.0]}]}
    invalid_input(
        client.post("/v1/initiation/simulate", json={"scenario": fast}),
        "scenario.targets[0].velocity[0]",
    )


def test_simulated_azimuths_are_wrapped_into_a_plots_range(client):
    # azimuth noise of 180 degrees throws az + noise far past +-360: wrapped, the same plot
    body = {
        "scenario": {"sigma_az_deg": 180.0, "clutter": 0.0, "P_D": 1.0, "scans": 50},
        "seed": 5,
    }
    sim = _simulated_body(client, body)
    plots = [p for scan in sim["scans"] for p in scan["plots"]]
    assert all(-360.0 <= p["az_deg"] <= 360.0 for p in plots)
    core_sim = simulate(
        Scenario(**{**vars(mu_scenario(0.0, 50)), "P_D": 1.0, "sigma_az": np.radians(180.0)}),
        5,
    )
    az = np.concatenate([s.az for s in core_sim.scans])
    assert (np.abs(np.degrees(az)) > 360.0).any()  # the case is exercised
    np.testing.assert_allclose(
        np.radians([p["az_deg"] for p in plots]) % (2 * np.pi),
        az % (2 * np.pi),
        rtol=0,
        atol=1e-12,
    )
    answer(client.post("/v1/initiation/initiate", json={"scans": sim["scans"]}))


def test_session_records_and_replays(settings, tmp_path):
    with TestClient(create_app(settings)) as c:
        sim = _simulated(c, clutter=20.0)
        first = answer(
            c.post("/v1/initiation/initiate", json={"config": SCORE, "scans": sim["scans"][:2]})
        )
        answer(
            c.post(
                "/v1/initiation/initiate",
                json={"config": SCORE, "state": first["state"], "scans": sim["scans"][2:]},
            )
        )
        sweep = {"parameter": "false_confirmation", "values": [0.01, 0.5]}
        answer(
            c.post("/v1/initiation/evaluate", json={"runs": 2, "config": SCORE, "sweep": sweep})
        )
        assert c.post("/v1/initiation/initiate", json={"scans": []}).status_code == 422
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    ops = [e.operation for e in read_recording(path).exchanges]
    assert ops == [
        "initiation.simulate",
        "initiation.initiate",
        "initiation.initiate",
        "initiation.evaluate",
        "initiation.initiate",
    ]
    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    assert json.loads(report.read_text())["unchanged"] == 5


def test_client_methods(settings):
    asyncio.run(_client_calls(create_app(settings)))


async def _client_calls(app) -> None:
    transport = httpx.ASGITransport(app=app)
    async with AsyncClient("http://plotgate", transport=transport) as client:
        sim = await client.simulate_scans({"scenario": {"clutter": 5.0}, "seed": 2})
        out = await client.initiate(
            {"config": POLAR, "scans": [s.model_dump() for s in sim.scans]}
        )
        assert len(out.scans) == 4
        ev = await client.evaluate_initiation({"runs": 2, "config": POLAR})
        assert ev.runs == 2 and ev.sweep is None
        sweep = {"parameter": "confirm", "values": ["2/3", "3/4"]}
        ev = await client.evaluate_initiation({"runs": 2, "config": POLAR, "sweep": sweep})
        assert ev.sweep is not None and [p.value for p in ev.sweep] == ["2/3", "3/4"]


def test_every_field_is_described():
    for name in ("initiation.initiate", "initiation.simulate", "initiation.evaluate"):
        endpoint = ENDPOINTS[name]
        assert endpoint.slow
        for model in (endpoint.request, endpoint.response):
            schema = model.model_json_schema()
            for sub in (schema, *schema.get("$defs", {}).values()):
                for field, prop in sub.get("properties", {}).items():
                    assert prop.get("description"), f"{sub['title']}.{field}: no description"


# ------------------------------------------------------------- the settings and core's config

WIRE_CEILINGS = {
    "v_min",
    "v_max",
    "capture_scans",
    "capture_time",
    "q",
    "confirm_k",
    "confirm_m",
    "drop_misses",
    "K_R",
    "K_az",
    "a_max",
    "K_A",
    "history",
    "clutter_density",
    "surveillance_area",
    "new_target_density",
}
"""Settings whose upper bound is the wire's alone: a limit on the work of one request, or
(the score's densities and area) on the magnitudes a request carries, which core (a
library with no request) does not have."""
WIRE_FLOORS = {"K_R", "K_az"}
"""Settings whose lower bound is narrower on the wire (0.01) than in core (> 0)."""


def _core_config(name, value):
    """InitiationConfig with ``name = value`` and the other settings made to fit it."""
    values = {name: value}
    if name == "v_min":
        values["v_max"] = max(50.0, value)
    if name == "confirm_k":
        values = {"confirm_m": max(4, value), "history": max(8, value), **values}
    if name == "confirm_m":
        values = {"confirm_k": max(1, min(3, value)), "history": max(8, value), **values}
    if name in ("P_D", "false_confirmation", "true_deletion", "new_target_density"):
        values["surveillance_area"] = 1e6
        other = {"true_deletion": "false_confirmation", "false_confirmation": "true_deletion"}
        if name in other:  # alpha + beta < 1: the other one made small enough
            values[other[name]] = min(1e-3, max((1.0 - value) / 2, 1e-300))
    if name == "history":
        k, m = max(1, min(3, value)), max(1, min(4, value))
        values = {"confirm_k": k, "confirm_m": m, **values}
    return InitiationConfig(**values)


def _refused(name, value):
    try:
        _core_config(name, value)
    except ParameterError as exc:
        assert exc.field == name, (name, value, exc.field)
        return True
    return False


def test_the_settings_are_cores_config_field_for_field():
    wire = InitiationSettings.model_fields
    assert list(wire) == [f.name for f in fields(InitiationConfig)]
    # defaults: the wire's settings as they are make core's default config
    assert InitiationConfig(**InitiationSettings().model_dump()) == InitiationConfig()
    for name, options in CHOICES.items():
        assert get_args(wire[name].annotation) == options, name
    for name, info in wire.items():
        bounds = {type(m).__name__: m for m in info.metadata}
        if name in CHOICES:
            continue
        if name == "gate_widening":  # at least one factor, on the wire as in core
            assert bounds["MinLen"].min_length == 1 and _refused(name, ())
            continue
        step = 1 if info.annotation is int else None
        # the lower bound is core's: the bound itself (ge) or just above it (gt) passes,
        # just below it (ge) or the bound itself (gt) is refused
        if "Ge" in bounds:
            low = bounds["Ge"].ge
            below = low - 1 if step else np.nextafter(low, -np.inf)
            _core_config(name, low)
            assert _refused(name, below) != (name in WIRE_FLOORS), name
        else:
            low = bounds["Gt"].gt
            _core_config(name, np.nextafter(float(low), np.inf))
            assert _refused(name, low), name
        # the upper bound: core's (lt, or le 1 for a gain floor), or the wire's own ceiling
        if "Lt" in bounds:
            high = bounds["Lt"].lt
            _core_config(name, np.nextafter(float(high), -np.inf))
            assert _refused(name, high), name
        else:
            high = bounds["Le"].le
            above = high + 1 if step else np.nextafter(float(high), np.inf)
            _core_config(name, high)
            assert _refused(name, above) != (name in WIRE_CEILINGS), name


def test_the_documented_score_configuration_is_a_valid_config():
    from pathlib import Path

    text = (Path(__file__).parents[3] / "docs/examples/score_initiation.json").read_text()
    settings = InitiationSettings.model_validate_json(text)
    assert settings.confirmation == "score" and settings.false_confirmation == 0.15
    InitiationConfig(**{**settings.model_dump(), "gate_widening": tuple(settings.gate_widening)})
