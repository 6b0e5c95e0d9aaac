"""The guards in front of the routes: the body-size limit (413) and authentication (401)."""

import re

import pytest
from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS
from plotgate.service.table import work_caps

KEY, TOKEN = "k3y-0f-the-day", "t0ken-0f-the-day"


def _problem(r, status: int, kind: str, field: str) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["status"] == status and body["type"] == f"urn:plotgate:problem:{kind}"
    assert [e["field"] for e in body["errors"]] == [field] and field in body["detail"]
    return body


def _client(tmp_path, **settings) -> TestClient:
    return TestClient(
        create_app(Settings(log_dir=tmp_path / "rec", git_commit="test", **settings))
    )


def test_a_body_over_the_limit_is_refused_before_it_is_read(tmp_path):
    with _client(tmp_path, max_body_bytes=1000) as c:
        r = c.post(
            "/v1/gates/test",
            content=b"x" * 2000,
            headers={"content-type": "application/json", "x-request-id": "big-1"},
        )
        body = _problem(r, 413, "payload-too-large", "body")
        assert "at most 1000" in body["errors"][0]["reason"]
        assert r.headers["x-request-id"] == "big-1"
        # streamed without a Content-Length: refused as soon as it passes the limit
        chunks = (b"x" * 300 for _ in range(10))
        r = c.post("/v1/gates/test", content=chunks, headers={"content-type": "application/json"})
        _problem(r, 413, "payload-too-large", "body")
        # under the limit the operation answers as usual (here: 422, not JSON)
        assert c.post("/v1/gates/test", content=b"{}").status_code == 422


@pytest.mark.parametrize("op", sorted(OPERATIONS))
def test_every_operation_refuses_missing_or_wrong_credentials(tmp_path, op):
    path = OPERATIONS[op].path
    with _client(tmp_path, api_key=KEY, bearer_token=TOKEN) as c:
        for headers in (
            {},
            {"x-api-key": "wrong"},
            {"authorization": "Bearer wrong"},
            {"authorization": f"Basic {TOKEN}"},
        ):
            r = c.post(path, json={}, headers=headers)
            _problem(r, 401, "unauthorized", "credentials")
            assert r.headers["www-authenticate"].startswith("Bearer")
        # the right key or token reaches the operation (which refuses the field: 422)
        odd = {"no_such_field": 1}
        assert c.post(path, json=odd, headers={"x-api-key": KEY}).status_code == 422
        assert (
            c.post(path, json=odd, headers={"authorization": f"Bearer {TOKEN}"}).status_code == 422
        )


def test_health_stays_open_and_the_key_is_never_recorded(tmp_path):
    with _client(tmp_path, api_key=KEY) as c:
        assert c.get("/healthz").status_code == 200
        assert c.get("/readyz").status_code == 200
        assert c.get("/openapi.json").status_code == 200
        assert c.get("/metrics").status_code == 401
        r = c.post("/v1/gates/test", json={}, headers={"x-api-key": KEY})
        assert r.status_code == 422
    written = b"".join(p.read_bytes() for p in (tmp_path / "rec").glob("*.mcap"))
    assert b"gates.test" in written and KEY.encode() not in written


def test_metrics_count_requests_latencies_and_the_recorder(tmp_path):
    with _client(tmp_path) as c:
        for _ in range(3):
            c.post("/v1/gates/test", json={}, headers={"x-request-id": "m"})
        text = c.get("/metrics").text
    assert 'plotgate_requests_total{operation="gates.test",status="422"} 3.0' in text
    assert 'plotgate_request_duration_seconds_count{operation="gates.test"} 3.0' in text
    assert "plotgate_recorder_records_total 6.0" in text  # a request and a response each
    assert "plotgate_recorder_queue_depth 0.0" in text
    assert "plotgate_recorder_ready 1.0" in text
    assert "plotgate_recorder_flush_seconds_count" in text
    written = [
        line for line in text.splitlines() if line.startswith("plotgate_recorder_bytes_total")
    ]
    assert float(written[0].split()[-1]) > 0


def test_every_response_carries_a_request_id(tmp_path):
    with _client(tmp_path, api_key=KEY, max_body_bytes=100) as c:
        for method, path, kwargs in (
            ("get", "/healthz", {}),
            ("get", "/metrics", {}),
            ("get", "/nowhere", {}),
            ("post", "/v1/gates/test", {"json": {}}),
            ("post", "/v1/gates/test", {"content": b"x" * 200, "headers": {"x-api-key": KEY}}),
        ):
            r = getattr(c, method)(path, **kwargs)
            assert len(r.headers["x-request-id"]) == 32  # a new id: none was sent
            r = getattr(c, method)(
                path,
                **{**kwargs, "headers": {**kwargs.get("headers", {}), "x-request-id": "given-1"}},
            )
            assert r.headers["x-request-id"] == "given-1"
            if r.status_code >= 400 and path != "/nowhere":
                assert r.json()["request_id"] == "given-1"
        r = c.get("/healthz", headers={"x-request-id": "bad id with spaces"})
        assert r.headers["x-request-id"] != "bad id with spaces"


def test_operators_cap_work_per_operation(tmp_path):
    limits = {"initiation.evaluate": {"runs": 10}, "gates.test": {"candidates": 1}}
    with _client(tmp_path, limits=limits) as c:
        r = c.post("/v1/initiation/evaluate", json={"runs": 20})
        body = _problem(r, 422, "invalid-input", "runs")
        assert "at most 10" in body["errors"][0]["reason"]
        one = {
            "gate": {"kind": "ring", "tau": 5.0, "v_min": 0.0, "v_max": 100.0},
            "first": {
                "frame": "cartesian",
                "x": 0.0,
                "y": 1000.0,
                "covariance": [[1.0, 0.0], [0.0, 1.0]],
            },
        }
        two = dict(one, candidates=[one["first"], one["first"]])
        _problem(c.post("/v1/gates/test", json=two), 422, "invalid-input", "candidates")
        single = c.post("/v1/gates/test", json=dict(one, candidates=[one["first"]]))
        assert single.status_code == 200
        spec = c.get("/openapi.json").json()["paths"]
        assert spec["/v1/initiation/evaluate"]["post"]["x-plotgate-limits"] == {
            "runs": 10,
            "scenario.scans": None,
            "scenario.clutter": None,
            "sweep.values": None,
            "runs x scans x plots": 1_200_000,
        }
        assert spec["/v1/gates/pairs"]["post"]["x-plotgate-limits"] == {"pairs": None}
    for bad in (
        {"no.such": {"runs": 1}},
        {"initiation.evaluate": {"plots": 1}},
        {"initiation.evaluate": {"runs": 0}},
    ):
        with pytest.raises(ValueError, match="PLOTGATE_LIMITS"):
            create_app(Settings(log_dir=tmp_path, limits=bad))


DERIVED_FACTORS = {
    ("gates.probability_curve", "cost"): "a gate kind's cost, GATE_COST of the request's gate",
    ("initiation.evaluate", "scans"): "the request's scenario.scans",
    ("initiation.evaluate", "plots"): "the scenario's plots a scan, weighted (its work())",
}
"""Factors of time estimates that are derived from the request rather than one field."""


def test_work_sizes_are_request_fields():
    """A size names the field it counts, or the fields of a product (``runs x (n + m)``),
    or a quantity derived from them that the estimate documents (:data:`DERIVED_FACTORS`)."""
    for op in OPERATIONS.values():
        for size in op.endpoint.work:
            for factor in re.findall(r"[A-Za-z_][\w.]*", size.replace(" x ", " ")):
                if (op.name, factor) not in DERIVED_FACTORS:
                    assert factor.split(".")[0] in op.request.model_fields, (op.name, size)


def test_limits_come_from_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("PLOTGATE_LIMITS", '{"solves.position": {"problems": 5}}')
    assert Settings(log_dir=tmp_path).limits == {
        **work_caps({}),
        "solves.position": {"problems": 5},
    }


NOT_PUBLIC = [
    ("POST", "/v1/gates/test/"),  # an operation's path with a trailing slash: 307 otherwise
    ("POST", "/v1/gates/test//"),
    ("POST", "/v1/gates/test/?x=1"),
    ("GET", "/v1/gates/test"),  # another method on an operation: 405 otherwise
    ("DELETE", "/v1/gates/test/"),
    ("POST", "/v1/no/such/operation"),  # 404 otherwise
    ("GET", "/metrics/"),
    ("GET", "/healthz/"),
    ("POST", "/docs/assets"),
]


@pytest.mark.parametrize(("method", "path"), NOT_PUBLIC, ids=[f"{m} {p}" for m, p in NOT_PUBLIC])
@pytest.mark.parametrize("root", ["", "/api"])
def test_401_before_any_redirect_404_or_405(tmp_path, method, path, root):
    """Without credentials, a path that is not public answers 401 whatever the routes would
    have answered: nobody learns which paths exist, or is sent on, before showing a key."""
    app = create_app(Settings(log_dir=tmp_path / "rec", record=False, api_key=KEY))
    with TestClient(app, root_path=root) as c:
        r = c.request(method, root + path, follow_redirects=False)
        _problem(r, 401, "unauthorized", "credentials")
        authorized = c.request(method, root + path, headers={"x-api-key": KEY})
        assert authorized.status_code != 401


def test_401_before_a_redirect_when_mounted(tmp_path):
    from starlette.applications import Starlette
    from starlette.routing import Mount

    app = create_app(Settings(log_dir=tmp_path / "rec", record=False, bearer_token=TOKEN))
    with TestClient(Starlette(routes=[Mount("/api", app=app)])) as c:
        r = c.post("/api/v1/gates/test/", json={}, follow_redirects=False)
        _problem(r, 401, "unauthorized", "credentials")
        r = c.post(
            "/api/v1/gates/test/",
            json={},
            headers={"authorization": f"Bearer {TOKEN}"},
            follow_redirects=False,
        )
        assert r.status_code == 307 and r.headers["location"] == "/api/v1/gates/test"
