"""The typed clients: in-process against the app, and their error paths via MockTransport."""

import asyncio
import math

import httpx
import pytest

from plotgate.clients import (
    AsyncClient,
    Client,
    ClusterUnavailable,
    InvalidInputError,
    RecordingUnavailable,
    ServerError,
    ServiceUnavailable,
    TransportError,
)
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.schemas import CartesianPlot, EllipseGate, GatePair, RingGate


def _plot(x: float, y: float) -> CartesianPlot:
    return CartesianPlot(frame="cartesian", x=x, y=y, covariance=((1e4, 0.0), (0.0, 1e4)))


@pytest.fixture
def app(tmp_path):
    return create_app(Settings(log_dir=tmp_path, record=False))


def test_async_client_in_process(app):
    asyncio.run(_async_calls(app))


async def _async_calls(app) -> None:
    transport = httpx.ASGITransport(app=app)
    async with AsyncClient("http://plotgate", transport=transport) as client:
        result = await client.test_gate(
            RingGate(kind="ring", tau=5.0, v_min=100.0, v_max=500.0),
            _plot(0.0, 0.0),
            [_plot(0.0, 1000.0), _plot(0.0, 100.0)],
        )
        assert result.inside == [True, False]
        assert result.statistic == pytest.approx([1000.0, 100.0])
        pairs = [GatePair(first=_plot(0.0, 0.0), second=_plot(3.0, 4.0))]
        result = await client.test_gate_pairs(EllipseGate(kind="ellipse", P_G=0.99), pairs)
        assert result.statistic == pytest.approx([25.0 / 2e4])
        with pytest.raises(InvalidInputError) as err:
            await client.test_gate(
                RingGate(kind="ring", tau=5.0, v_min=600.0, v_max=500.0),
                _plot(0.0, 0.0),
                [_plot(0.0, 1000.0)],
            )
        assert err.value.problem.errors[0].field == "gate.v_min"
        assert "gate.v_min" in str(err.value)


def _client(status: int, body: bytes, content_type: str = "application/problem+json") -> Client:
    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(status, content=body, headers={"content-type": content_type})

    return Client("http://plotgate", transport=httpx.MockTransport(handler), retries=0)


GATE = RingGate(kind="ring", tau=1.0, v_max=10.0)


def test_recording_unavailable():
    body = (
        b'{"type":"urn:plotgate:problem:recording-unavailable","title":"Recording '
        b'unavailable","status":503,"detail":"disk full","request_id":"r1"}'
    )
    with _client(503, body) as client, pytest.raises(RecordingUnavailable, match="r1"):
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])


@pytest.mark.parametrize(
    ("kind", "error"),
    [
        ("recording-unavailable", RecordingUnavailable),
        ("cluster-unavailable", ClusterUnavailable),
        ("something-new", ServiceUnavailable),
    ],
)
def test_a_503_is_a_service_unavailable_of_its_kind(kind, error):
    from plotgate.service.problems import PROBLEM_BASE, TITLES

    body = (
        f'{{"type":"{PROBLEM_BASE}{kind}","title":"{TITLES.get(kind, kind)}","status":503,'
        '"detail":"not now"}'
    )
    with _client(503, body.encode()) as client, pytest.raises(ServiceUnavailable) as err:
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert type(err.value) is error and err.value.attempts == 1
    assert "attempts" not in str(err.value)


def test_a_proxys_503_is_a_service_unavailable():
    client = _client(503, b"no healthy upstream", "text/plain")
    with client, pytest.raises(ServiceUnavailable, match="no healthy upstream") as err:
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert type(err.value) is ServiceUnavailable


def test_server_error_without_problem_body():
    client = _client(502, b"bad gateway", "text/plain")
    with client, pytest.raises(ServerError, match="502"):
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])


def test_transport_error():
    def refuse(request: httpx.Request) -> httpx.Response:
        raise httpx.ConnectError("connection refused", request=request)

    with Client("http://plotgate", transport=httpx.MockTransport(refuse), retries=0) as client:
        with pytest.raises(TransportError, match="gates.test"):
            client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
        assert not client.ready()


def test_wrong_request_type():
    with _client(200, b"{}") as client, pytest.raises(TypeError, match="GateTestRequest"):
        client.call("gates.test", GATE)


PROBLEM = {
    "gate": {"kind": "ring", "v_min": 100.0, "v_max": 500.0},
    "mark": {"r": 50_000.0, "sigma_r": 200.0, "sigma_az_deg": 0.5},
    "tau": 5.0,
}
PROBABILITY = {**PROBLEM, "velocity": {"speed": 300.0, "course_deg": 0.0}}
RESOLUTION = {"range": 500.0, "azimuth_deg": 1.5}
PRIOR = {"v_min": 100.0, "v_max": 500.0}


def _in_process() -> Client:
    """A sync client whose transport runs each request through the registry."""
    from plotgate.service.registry import OPERATIONS, execute

    by_path = {op.path: op for op in OPERATIONS.values()}

    def handler(request: httpx.Request) -> httpx.Response:
        outcome = execute(by_path[request.url.path], request.content)
        kind = "application/json" if outcome.ok else "application/problem+json"
        return httpx.Response(
            outcome.status, content=outcome.content, headers={"content-type": kind}
        )

    return Client("http://plotgate", transport=httpx.MockTransport(handler))


def test_probability_methods_take_a_model_or_a_dict():
    from plotgate.service.schemas import (
        GateAnalysisResult,
        GateProbabilityCurve,
        GateProbabilityRequest,
        GateProbabilityResult,
    )

    with _in_process() as client:
        from_dict = client.gate_probability(PROBABILITY)
        from_model = client.gate_probability(GateProbabilityRequest.model_validate(PROBABILITY))
        assert isinstance(from_dict, GateProbabilityResult) and from_dict == from_model
        assert from_dict.conditional and 0.9 < from_dict.probability < 1.0
        curve = client.gate_probability_curve(
            {**PROBLEM, "against": "speed", "values": [150.0, 300.0]}
        )
        assert isinstance(curve, GateProbabilityCurve)
        assert curve.probability[1] == pytest.approx(from_dict.probability, abs=1e-12)
        analysis = client.gate_analysis({**PROBLEM, "resolution": RESOLUTION})
        assert isinstance(analysis, GateAnalysisResult) and analysis.capture is None
        design = {
            **PROBLEM,
            "gate": {"kind": "combined", "v_max": 500.0},
            "capture": 0.95,
            "P_D1": 0.9,
            "resolution": RESOLUTION,
            "prior": PRIOR,
        }
        with pytest.raises(InvalidInputError) as err:
            client.gate_design(design)
        assert err.value.problem.errors[0].field == "capture"


def test_async_probability_methods(app):
    async def calls() -> None:
        transport = httpx.ASGITransport(app=app)
        async with AsyncClient("http://plotgate", transport=transport) as client:
            result = await client.gate_probability(PROBABILITY)
            assert result.conditional and 0.9 < result.probability < 1.0
            curve = await client.gate_probability_curve(
                {**PROBLEM, "against": "range", "values": [5e4], "speed": 300.0}
            )
            assert curve.probability == pytest.approx([result.probability], abs=1e-12)
            analysis = await client.gate_analysis({**PROBLEM, "resolution": RESOLUTION})
            assert analysis.area == pytest.approx(math.pi * (2500**2 - 500**2))
            with pytest.raises(InvalidInputError) as err:
                await client.gate_design(
                    {
                        **PROBLEM,
                        "gate": {"kind": "expanded", "v_max": 500.0},
                        "capture": 0.5,
                        "prior": PRIOR,
                        "resolution": RESOLUTION,
                    }
                )
            assert err.value.problem.errors[0].field == "capture"

    asyncio.run(calls())
