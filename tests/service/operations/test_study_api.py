"""``solves.study`` over HTTP and ``plotgate study``: the answer is core's study, bad
input is named, the session records and replays, the command writes a table and a PNG."""

import asyncio
import json

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient
from pydantic import ValidationError

from plotgate.clients import AsyncClient
from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.clients.study import DEFAULT_REQUEST
from plotgate.core.multistatic import accuracy_study, platform_positions
from plotgate.service.app import create_app
from plotgate.service.schemas import MAX_STUDY_RUNS, StudyRequest
from tests.support.requests import answer, assert_finite, invalid_input

TIMES = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]
BODY = {
    "transmitter": {"position": [9900.0, 1000.0], "velocity": [-5.0, 8.66]},
    "receivers": [
        {"position": [150.0, -500.0], "velocity": [5.0, 8.66]},
        {"position": [600.0, 1000.0]},
        {"positions": [[150.0, 2500.0 + 10.0 * k] for k in range(6)]},
    ],
    "target": {"position": [5000.0, 500.0], "velocity": [0.0, 80.0]},
    "sample_times": [100.0 + t for t in TIMES],
    "sigma": 0.5,
    "runs": 50,
    "seed": 3,
}


def test_study_is_cores_study(client):
    body = answer(client.post("/v1/solves/study", json=BODY))
    assert_finite(body)
    t = np.array(BODY["sample_times"])
    tx = platform_positions([9900.0, 1000.0], [-5.0, 8.66], t, t0=t[0])[:, None]
    rx = np.stack(
        [
            platform_positions([150.0, -500.0], [5.0, 8.66], t, t0=t[0]),
            np.broadcast_to([600.0, 1000.0], (6, 2)),
            np.array(BODY["receivers"][2]["positions"]),
        ],
        axis=1,
    )
    s = accuracy_study(t, tx, rx, [5000.0, 500.0], [0.0, 80.0], 0.5, 50, 3)
    samples = body["samples"]
    assert body["runs"] == 50 and body["seed"] == 3 and len(samples) == 6
    assert body["noise_sigma"] == pytest.approx(s.noise_sigma[0], rel=1e-12)
    for key in ("ml_single", "sum_range", "difference_range", "linearised"):
        np.testing.assert_allclose([r[key] for r in samples], s.rmse[key], rtol=1e-12)
    np.testing.assert_allclose(
        [r["ml_track"] for r in samples[1:]], s.rmse["ml_track"][1:], rtol=1e-12
    )
    assert samples[0]["ml_track"] is None and samples[0]["max_track_distance"] is None
    np.testing.assert_allclose(
        [r["crlb_accumulated"] for r in samples], s.crlb_accumulated, rtol=1e-12
    )
    assert [r["inconsistent"] for r in samples] == s.inconsistent.tolist()


def test_study_without_tracks_leaves_them_null(client):
    samples = answer(client.post("/v1/solves/study", json=dict(BODY, tracks=False)))["samples"]
    assert all(r["ml_track"] is None and r["full_track"] is None for r in samples)


def test_bad_studies_are_named(client):
    post = lambda **changes: client.post("/v1/solves/study", json=dict(BODY, **changes))  # noqa: E731
    invalid_input(post(runs=1), "runs")
    invalid_input(
        post(
            runs=MAX_STUDY_RUNS,
            sample_times=[0.1 * k for k in range(100)],
            tracks=False,
            receivers=[{"position": [150.0 * k, 0.0]} for k in range(1, 4)],
        ),
        "runs",
    )
    invalid_input(
        post(
            runs=400,
            sample_times=[0.1 * k for k in range(500)],
            receivers=BODY["receivers"][:2] + [{"position": [150.0, 2500.0]}],
        ),
        "runs",
    )  # 400 x 500 x 3 range sums, but with tracks x 500 is too much
    invalid_input(post(sigma=0.0), "sigma")
    invalid_input(post(sample_times=TIMES[:5]), "receivers[2].positions")
    invalid_input(post(sample_times=TIMES[::-1]), "sample_times")
    invalid_input(
        post(target={"position": [5000.0, 500.0, 0.0], "velocity": [0.0, 80.0]}), "target.position"
    )
    invalid_input(post(receivers=BODY["receivers"][:2]), "receivers")  # P < D + 1
    through = {"position": [600.0, 1000.0], "velocity": [0.0, 0.0]}
    invalid_input(post(target=through), "target")


def test_study_session_records_replays_and_the_client_calls_it(settings, tmp_path):
    with TestClient(create_app(settings)) as c:
        assert c.post("/v1/solves/study", json=BODY).status_code == 200
        assert c.post("/v1/solves/study", json=dict(BODY, runs=1)).status_code == 422
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    assert [e.operation for e in read_recording(path).exchanges] == ["solves.study"] * 2
    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    assert json.loads(report.read_text())["unchanged"] == 2


def test_client_methods(settings):
    asyncio.run(_client_calls(create_app(settings)))


async def _client_calls(app) -> None:
    transport = httpx.ASGITransport(app=app)
    async with AsyncClient("http://plotgate", transport=transport) as client:
        result = await client.accuracy_study(dict(BODY, tracks=False))
    assert len(result.samples) == 6 and result.runs == 50


def test_default_request_is_valid_and_within_the_work_limits():
    request = StudyRequest.model_validate(DEFAULT_REQUEST)
    assert request.sample_times[112] == 11.2 and request.runs == 1000
    StudyRequest.model_validate(dict(DEFAULT_REQUEST, runs=4000, tracks=False))
    with pytest.raises(ValidationError, match="runs"):
        StudyRequest.model_validate(dict(DEFAULT_REQUEST, runs=1001))  # with tracks
    with pytest.raises(ValidationError, match="runs"):
        StudyRequest.model_validate(dict(DEFAULT_REQUEST, runs=4001, tracks=False))


def test_plotgate_study_writes_table_and_png(tmp_path, capsys):
    request = tmp_path / "study.json"
    request.write_text(json.dumps(BODY))
    md, png = tmp_path / "out" / "t.md", tmp_path / "out" / "f.png"
    assert (
        main(["study", str(request), "--runs", "40", "--table", str(md), "--png", str(png)]) == 0
    )
    printed = capsys.readouterr().out
    assert "no ML solution more than 10 CRLB away" in printed and str(png) in printed
    text = md.read_text()
    assert "40 runs, seed 3" in text and text.count("\n| 5 | ") == 1
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
