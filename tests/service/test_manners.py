"""What the service shows its callers besides answers: the OpenAPI security schemes, the
docs served with no network, the process and Python metrics, 405 on an operation path,
and files rotated by size, each compacted off the event loop."""

import re

from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.guards import OPEN_PATHS
from plotgate.service.recording import Recorder
from plotgate.service.registry import OPERATIONS
from tests.support.requests import GOOD

KEY, TOKEN = "k3y-0f-the-day", "t0ken-0f-the-day"
EXTERNAL = re.compile(r"(?:https?:)?//[A-Za-z0-9.-]+\.[A-Za-z]{2,}")
"""An absolute or protocol-relative URL to another host."""


def _client(tmp_path, **settings) -> TestClient:
    return TestClient(create_app(Settings(log_dir=tmp_path / "rec", record=False, **settings)))


def test_the_schemes_are_declared_with_fastapis_security_classes(tmp_path):
    with _client(tmp_path, api_key=KEY, bearer_token=TOKEN) as c:
        spec = c.get("/openapi.json").json()
    schemes = spec["components"]["securitySchemes"]
    assert schemes == {
        "ApiKey": {
            "type": "apiKey",
            "in": "header",
            "name": "X-API-Key",
            "description": "The key set as PLOTGATE_API_KEY.",
        },
        "Bearer": {
            "type": "http",
            "scheme": "bearer",
            "description": "The token set as PLOTGATE_BEARER_TOKEN.",
        },
    }
    for path, item in spec["paths"].items():
        for operation in item.values():
            if path in OPEN_PATHS:
                assert "security" not in operation, path
            else:  # either scheme will do, and a 401 is documented
                assert operation["security"] == [{"ApiKey": []}, {"Bearer": []}], path
                assert "401" in operation["responses"], path
    assert {op.path for op in OPERATIONS.values()} | {"/metrics"} <= set(spec["paths"])


def test_only_the_schemes_this_server_checks_are_declared(tmp_path):
    with _client(tmp_path, bearer_token=TOKEN) as c:
        spec = c.get("/openapi.json").json()
    assert set(spec["components"]["securitySchemes"]) == {"Bearer"}
    assert spec["paths"]["/v1/gates/test"]["post"]["security"] == [{"Bearer": []}]
    with _client(tmp_path) as c:
        spec = c.get("/openapi.json").json()
    assert "securitySchemes" not in spec["components"]
    assert all("security" not in op for item in spec["paths"].values() for op in item.values())


def test_the_docs_load_nothing_from_another_host(tmp_path):
    with _client(tmp_path, api_key=KEY) as c:  # open paths, even with a key set
        for page in ("/docs", "/redoc"):
            r = c.get(page)
            assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
            assert EXTERNAL.search(r.text) is None, EXTERNAL.search(r.text)
            assets = re.findall(r'(?:src|href)="(/docs/assets/[^"]+)"', r.text)
            assert assets, page
            for asset in assets:
                served = c.get(asset)
                assert served.status_code == 200 and len(served.content) > 1000, asset
        assert c.get("/docs/oauth2-redirect").status_code == 200
        assert c.get("/docs/assets/swagger-ui-bundle.js").status_code == 200
        assert c.get("/metrics").status_code == 401  # the prefix opens the assets only


def test_metrics_carry_the_process_and_python_collectors(tmp_path):
    with _client(tmp_path) as c:
        assert c.post("/v1/gates/test", json=GOOD).status_code == 200
        text = c.get("/metrics").text
    for name in (
        "process_cpu_seconds_total",
        "process_resident_memory_bytes",
        "process_open_fds",
        "python_info",
        'python_gc_collections_total{generation="2"}',
        'plotgate_requests_total{operation="gates.test",status="200"} 1.0',
    ):
        assert name in text, name


def test_another_method_on_an_operation_path_is_405_with_allow(tmp_path):
    with _client(tmp_path) as c:
        for method in ("GET", "PUT", "DELETE", "PATCH"):
            r = c.request(method, "/v1/gates/test", headers={"x-request-id": "m-1"})
            assert r.status_code == 405 and r.headers["allow"] == "POST"
            assert r.headers["content-type"] == "application/problem+json"
            assert r.headers["x-request-id"] == "m-1"
            assert r.json()["type"] == "urn:plotgate:problem:method-not-allowed"
            assert r.json()["instance"] == "/v1/gates/test"


def test_files_rotate_each_compacted_by_a_child_process(tmp_path, mcap_check):
    """Every rotated file, and the last one on shutdown, is compacted off the loop into an
    indexed, chunked MCAP with a summary, every record kept; bytes_written counts what was
    written (before compaction)."""
    settings = Settings(log_dir=tmp_path / "rec", rotate_age_s=1e-9)  # one commit a file
    with TestClient(create_app(settings)) as c:
        for i in range(4):
            r = c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": f"r-{i}"})
            assert r.status_code == 200
        recorder: Recorder = c.app.state.recorder  # type: ignore[attr-defined]
    files = sorted(settings.log_dir.glob("*.mcap"))
    # a fast operation's request and response share one commit: one file an exchange
    assert len(files) == 4 and recorder.rotations == 3 and recorder.compacting == []
    assert sorted(p.name for p in settings.log_dir.iterdir()) == [f.name for f in files]
    reports = [mcap_check(f) for f in files]
    assert all(code == 0 and report["summary_present"] for code, report in reports)
    assert [report["total_messages"] for _, report in reports] == [2] * 4
    assert recorder.bytes_written > 0


def test_operations_answer_under_a_root_path_and_when_mounted(tmp_path):
    """Behind a proxy that strips a prefix (``--root-path /api``) or mounted in another
    app, the operations are found as FastAPI's router found them; the docs point under the
    prefix; a trailing slash is redirected (307) as before."""
    from starlette.applications import Starlette
    from starlette.routing import Mount

    app = create_app(Settings(log_dir=tmp_path / "rec", record=False))
    with TestClient(app, root_path="/api") as c:
        assert c.post("/api/v1/gates/test", json=GOOD).status_code == 200
        r = c.post("/api/v1/gates/test/?x=1", json=GOOD, follow_redirects=False)
        assert r.status_code == 307 and r.headers["location"] == "/api/v1/gates/test?x=1"
        page = c.get("/api/docs").text
        assert "/api/openapi.json" in page and "/api/docs/assets/swagger-ui.css" in page
        assert c.get("/api/docs/assets/swagger-ui.css").status_code == 200
    outer = Starlette(routes=[Mount("/pg", create_app(Settings(record=False)))])
    with TestClient(outer) as c:
        assert c.post("/pg/v1/gates/test", json=GOOD).status_code == 200
        assert c.get("/pg/v1/gates/test").status_code == 405
    with _client(tmp_path) as c:
        assert c.post("/v1/gates/test/", json=GOOD).status_code == 200  # followed
