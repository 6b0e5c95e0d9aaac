"""Gate operations over HTTP: good answers, and a problem+json naming the field for bad input."""

import json

import numpy as np
import pytest

from plotgate import core
from tests.support.requests import cartesian, polar

COMBINED = {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0, "P_G": 0.9}


def test_combined_gate_stages(client):
    # First mark at 50 km north; ring 500..2500 m. Candidates: in the ring, just inside the
    # inner circle, just outside the outer circle, and far away.
    first = cartesian(0.0, 50_000.0)
    candidates = [
        cartesian(0.0, 51_000.0),
        cartesian(0.0, 50_450.0),
        cartesian(0.0, 52_600.0),
        cartesian(0.0, 60_000.0),
    ]
    r = client.post(
        "/v1/gates/test", json={"gate": COMBINED, "first": first, "candidates": candidates}
    )
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["stage"] == ["ring", "inner_ellipse", "outer_ellipse", "none"]
    assert body["inside"] == [True, True, True, False]
    assert body["count_inside"] == 3
    assert body["threshold"] == pytest.approx(4.605, abs=1e-3)
    # rho for the outer candidate: nu = 100 m along y, B = 2 * 100^2 I -> 100^2 / 2e4 = 0.5
    assert body["statistic"][2] == pytest.approx(0.5, rel=1e-12)
    assert r.headers["x-request-id"]


def test_pairs_match_core(client):
    rng = np.random.default_rng(7)
    z1 = rng.uniform(-5e4, 5e4, (20, 2))
    z2 = z1 + rng.uniform(-3e3, 3e3, (20, 2))
    pairs = [
        {"first": cartesian(*a), "second": cartesian(*b)} for a, b in zip(z1, z2, strict=True)
    ]
    r = client.post("/v1/gates/pairs", json={"gate": COMBINED, "pairs": pairs})
    assert r.status_code == 200, r.text
    P = np.diag([1e4, 1e4])
    expected = core.CombinedGate(100.0, 500.0, 0.9).test(z1, P, z2, P, 5.0)
    assert r.json()["inside"] == expected.inside.tolist()
    np.testing.assert_allclose(r.json()["statistic"], expected.statistic, rtol=1e-12)


def test_polar_plot_equals_its_cartesian_conversion(client):
    gate = {"kind": "ellipse", "P_G": 0.99}
    first_p = polar(20_000.0, 30.0)
    az = np.radians(30.0)
    z = core.polar_to_cartesian(20_000.0, az)
    P = core.polar_covariance_to_cartesian(20_000.0, az, 200.0, np.radians(0.5))
    first_c = {"frame": "cartesian", "x": z[0], "y": z[1], "covariance": P.tolist()}
    cands = [polar(20_300.0, 30.4), polar(21_000.0, 31.0)]
    a = client.post("/v1/gates/test", json={"gate": gate, "first": first_p, "candidates": cands})
    b = client.post("/v1/gates/test", json={"gate": gate, "first": first_c, "candidates": cands})
    np.testing.assert_allclose(a.json()["statistic"], b.json()["statistic"], rtol=1e-9)


CAPTURE_NEAR = polar(11_000.0, 45.0)  # 1 km from the first mark: inside a 500..2500 m ring
TRACK_NEAR = polar(10_010.0, 45.01)  # within the errors of the first mark


@pytest.mark.parametrize(
    ("gate", "near"),
    [
        ({"kind": "ring", "tau": 5.0, "v_min": 100.0, "v_max": 500.0}, CAPTURE_NEAR),
        ({"kind": "expanded", "tau": 5.0, "v_max": 500.0, "p": 0.95}, CAPTURE_NEAR),
        (COMBINED, CAPTURE_NEAR),
        ({"kind": "ellipse", "P_G": 0.99}, TRACK_NEAR),
        ({"kind": "rectangular", "k": 3.0}, TRACK_NEAR),
        ({"kind": "sector", "K_R": 3.0, "K_az": 3.0}, TRACK_NEAR),
        ({"kind": "first_association", "tau": 1.0, "v_max": 30.0}, TRACK_NEAR),
    ],
    ids=["ring", "expanded", "combined", "ellipse", "rectangular", "sector", "first_assoc"],
)
def test_every_gate_kind_answers(client, gate, near):
    body = {
        "gate": gate,
        "first": polar(10_000.0, 45.0),
        "candidates": [near, polar(30_000.0, 200.0)],
    }
    r = client.post("/v1/gates/test", json=body)
    assert r.status_code == 200, r.text
    assert r.json()["kind"] == gate["kind"]
    assert r.json()["inside"] == [True, False]


def _problem(r, status: int, field: str) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["status"] == status and body["type"].startswith("urn:plotgate:problem:")
    assert field in [e["field"] for e in body["errors"]], body
    assert field in body["detail"]
    return body


def _request(**changes) -> dict:
    body = {
        "gate": COMBINED,
        "first": cartesian(0.0, 50_000.0),
        "candidates": [cartesian(0.0, 51_000.0), cartesian(10.0, 51_000.0)],
    }
    body.update(changes)
    return body


def test_malformed_json(client):
    r = client.post(
        "/v1/gates/test", content=b'{"gate": ', headers={"content-type": "application/json"}
    )
    _problem(r, 400, "body")


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_tokens(client, token):
    text = json.dumps(_request()).replace("51000.0", token, 1)
    r = client.post(
        "/v1/gates/test", content=text.encode(), headers={"content-type": "application/json"}
    )
    assert r.status_code in (400, 422)
    assert r.headers["content-type"].startswith("application/problem+json")
    if r.status_code == 422:
        _problem(r, 422, "candidates[0].cartesian.y")


def test_negative_sigma(client):
    bad = polar(10_000.0, 10.0, sigma_r=-5.0)
    _problem(
        client.post("/v1/gates/test", json=_request(candidates=[bad])),
        422,
        "candidates[0].polar.sigma_r",
    )


@pytest.mark.parametrize(
    ("cov", "where"),
    [
        ([[1e4, 0.0], [0.0, -1e4]], ".cartesian.covariance[1][1]"),  # schema: variance > 0
        ([[1e4, 2e4], [2e4, 1e4]], ".covariance"),  # core: indefinite
        ([[1e4, 5.0], [0.0, 1e4]], ".covariance"),
    ],  # core: not symmetric
    ids=["negative", "indefinite", "asymmetric"],
)
def test_bad_covariance(client, cov, where):
    bad = {"frame": "cartesian", "x": 0.0, "y": 51_000.0, "covariance": cov}
    good = cartesian(0.0, 51_000.0)
    _problem(
        client.post("/v1/gates/test", json=_request(candidates=[good, bad])),
        422,
        "candidates[1]" + where,
    )
    pair = {"first": good, "second": bad}
    r = client.post("/v1/gates/pairs", json={"gate": COMBINED, "pairs": [pair, pair]})
    _problem(r, 422, "pairs[0].second" + where)


def test_bad_first_covariance(client):
    bad = {"frame": "cartesian", "x": 0.0, "y": 5e4, "covariance": [[1e4, 2e4], [2e4, 1e4]]}
    _problem(client.post("/v1/gates/test", json=_request(first=bad)), 422, "first.covariance")


def test_v_min_above_v_max(client):
    gate = dict(COMBINED, v_min=600.0)
    body = _problem(client.post("/v1/gates/test", json=_request(gate=gate)), 422, "gate.v_min")
    assert "600" in body["detail"]


@pytest.mark.parametrize("P_G", [0.0, 1.0, 1.5, -0.1])
def test_probability_outside_unit_interval(client, P_G):
    gate = dict(COMBINED, P_G=P_G)
    _problem(client.post("/v1/gates/test", json=_request(gate=gate)), 422, "gate.combined.P_G")


def test_missing_field(client):
    body = _request()
    del body["first"]
    _problem(client.post("/v1/gates/test", json=body), 422, "first")


def test_wrong_type(client):
    _problem(client.post("/v1/gates/test", json=_request(candidates="many")), 422, "candidates")
    _problem(client.post("/v1/gates/test", json=_request(gate={"kind": "hexagon"})), 422, "gate")


def test_unknown_field(client):
    body = _request()
    body["frist"] = body["first"]
    _problem(client.post("/v1/gates/test", json=body), 422, "frist")


def test_oversize_array(client):
    from plotgate.service.schemas import MAX_PLOTS

    one = cartesian(0.0, 51_000.0)
    r = client.post("/v1/gates/test", json=_request(candidates=[one] * (MAX_PLOTS + 1)))
    _problem(r, 422, "candidates")


def test_empty_candidates(client):
    _problem(client.post("/v1/gates/test", json=_request(candidates=[])), 422, "candidates")


def test_expanded_gate_at_the_sensor(client):
    gate = {"kind": "expanded", "tau": 5.0, "v_max": 500.0}
    _problem(
        client.post("/v1/gates/test", json=_request(gate=gate, first=cartesian(0.0, 0.0))),
        422,
        "first",
    )


def test_unknown_route_and_method(client):
    r = client.get("/v1/nothing", headers={"x-request-id": "lost-1"})
    assert r.status_code == 404 and r.headers["x-request-id"] == "lost-1"
    assert r.json()["request_id"] == "lost-1"
    assert r.headers["content-type"].startswith("application/problem+json")
    r = client.get("/v1/gates/test")
    assert r.status_code == 405 and r.json()["status"] == 405


def test_health_and_readiness(client):
    assert client.get("/healthz").json() == {"status": "ok"}
    assert client.get("/readyz").status_code == 200


def test_openapi_documents_every_operation(client):
    from plotgate.service.registry import OPERATIONS

    spec = client.get("/openapi.json").json()
    for op in OPERATIONS.values():
        post = spec["paths"][op.path]["post"]
        ref = post["requestBody"]["content"]["application/json"]["schema"]["$ref"]
        assert ref.rsplit("/", 1)[1] in spec["components"]["schemas"]
        assert "application/problem+json" in post["responses"]["422"]["content"]


def test_request_id_is_echoed(client):
    r = client.post("/v1/gates/test", json=_request(), headers={"x-request-id": "abc-123"})
    assert r.headers["x-request-id"] == "abc-123"


def test_out_of_range_magnitudes(client):
    far = dict(cartesian(0.0, 51_000.0), x=2e9)
    _problem(client.post("/v1/gates/test", json=_request(first=far)), 422, "first.cartesian.x")
    close = polar(0.5, 10.0)
    _problem(
        client.post("/v1/gates/test", json=_request(candidates=[close])),
        422,
        "candidates[0].polar.r",
    )


def test_numerically_singular_covariance(client):
    thin = {
        "frame": "cartesian",
        "x": 0.0,
        "y": 51_000.0,
        "covariance": [[1e-6, 0.0], [0.0, 1e12]],
    }
    body = _problem(
        client.post("/v1/gates/test", json=_request(candidates=[thin])),
        422,
        "candidates[0].covariance",
    )
    assert "numerically singular" in body["detail"]


def test_sector_gate_refuses_a_plot_on_the_sensor(client):
    body = {
        "gate": {"kind": "sector"},
        "first": polar(10_000.0, 45.0),
        "candidates": [cartesian(0.0, 0.2)],
    }
    _problem(client.post("/v1/gates/test", json=body), 422, "candidates[0]")
