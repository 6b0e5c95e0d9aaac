"""The typed clients: in-process against the app, and their error paths via MockTransport."""

import asyncio
import gzip
import itertools
import json
import math
from collections.abc import AsyncIterator, Iterable, Iterator

import httpx
import pytest

from plotgate.clients import (
    DEFAULT_MAX_RESPONSE_BYTES,
    AsyncClient,
    Client,
    ClusterUnavailable,
    InvalidInputError,
    InvalidResponseError,
    PlotgateClientError,
    ProblemError,
    RecordingUnavailable,
    ResponseTooLarge,
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


# --- answers that are not the operation's, and answers without end ------------------------

GOOD_ANSWER = (
    b'{"kind":"ring","statistic_name":"distance |z2 - z1|, m","threshold":2500.0,'
    b'"inside":[true],"statistic":[1000.0],"stage":null,"count_inside":1}'
)
MALFORMED = {
    "html": b"<html><body>Welcome to our portal</body></html>",
    "truncated": GOOD_ANSWER[:40],
    "wrong schema": b'{"solutions": []}',
    "nan": GOOD_ANSWER.replace(b"[1000.0]", b"[NaN]"),
    "deep nesting": b"[" * 100_000 + b"]" * 100_000,
    "empty": b"",
    "not utf-8": b'{"kind":"\xff\xfe"}',
    "huge key": b'{"' + b"k" * 10**6 + b'": 1}',
}


def _mock(handler, **kwargs) -> Client:
    return Client("http://plotgate", transport=httpx.MockTransport(handler), **kwargs)


def _async_mock(handler, **kwargs) -> AsyncClient:
    return AsyncClient("http://plotgate", transport=httpx.MockTransport(handler), **kwargs)


def _answering(status: int, body: bytes, calls: list[int]):
    def handler(request: httpx.Request) -> httpx.Response:
        calls.append(1)
        headers = {"content-type": "application/json", "x-request-id": "srv-1"}
        return httpx.Response(status, content=body, headers=headers)

    return handler


def test_the_good_answer_parses():
    """The bodies below are malformed versions of this one."""
    with _mock(_answering(200, GOOD_ANSWER, [])) as client:
        assert client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)]).inside == [True]


@pytest.mark.parametrize("body", MALFORMED.values(), ids=MALFORMED.keys())
def test_a_malformed_200_is_an_invalid_response_not_retried(body):
    calls: list[int] = []
    with _mock(_answering(200, body, calls)) as client:
        with pytest.raises(InvalidResponseError, match="GateResults") as err:
            client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert calls == [1]  # the same server would send the same again
    exc = err.value
    assert (exc.status, exc.url, exc.request_id, exc.attempts) == (
        200,
        "http://plotgate/v1/gates/test",
        "srv-1",
        1,
    )
    assert "srv-1" in str(exc) and len(str(exc)) < 1000  # the body is not pasted in


@pytest.mark.parametrize("body", MALFORMED.values(), ids=MALFORMED.keys())
def test_async_a_malformed_200_is_an_invalid_response(body):
    async def call() -> None:
        async with _async_mock(_answering(200, body, [])) as client:
            await client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])

    with pytest.raises(InvalidResponseError, match="GateResults"):
        asyncio.run(call())


@pytest.mark.parametrize(
    ("status", "error"), [(502, ServerError), (503, ServiceUnavailable), (422, InvalidInputError)]
)
@pytest.mark.parametrize("body", MALFORMED.values(), ids=MALFORMED.keys())
def test_an_error_body_that_is_no_problem_is_the_error_of_its_status(status, error, body):
    with _mock(_answering(status, body, []), retries=0) as client:
        with pytest.raises(error) as err:
            client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert err.value.problem.status == status and str(status) in str(err.value)


class Streamed(httpx.SyncByteStream, httpx.AsyncByteStream):
    """A body sent piece by piece, as off the network (never read ahead by httpx); counts the
    bytes it produced."""

    def __init__(self, pieces: Iterable[bytes]) -> None:
        self.pieces = pieces
        self.produced = 0

    def __iter__(self) -> Iterator[bytes]:
        for piece in self.pieces:
            self.produced += len(piece)
            yield piece

    async def __aiter__(self) -> AsyncIterator[bytes]:
        for piece in self:
            yield piece


def endless() -> Streamed:
    """A body without end, in 64 KiB pieces of a JSON array that never closes."""
    return Streamed(itertools.repeat(b"[" + b"0," * 32767 + b"0"))


def _streaming(status: int, stream: Streamed, **headers: str):
    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(status, headers=headers, stream=stream)

    return handler


@pytest.mark.parametrize("status", [200, 503, 502])
def test_an_endless_body_stops_at_the_default_cap(status):
    body = endless()
    with _mock(_streaming(status, body)) as client, pytest.raises(ResponseTooLarge) as err:
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert DEFAULT_MAX_RESPONSE_BYTES < body.produced <= DEFAULT_MAX_RESPONSE_BYTES + 2**16
    assert err.value.status == status and err.value.attempts == 1  # a 503 too: not retried
    assert "max_response_bytes" in str(err.value)


def test_send_stops_an_endless_body_at_the_clients_cap():
    body = endless()
    with _mock(_streaming(200, body), max_response_bytes=10**6) as client:
        with pytest.raises(ResponseTooLarge, match="at most 1000000"):
            client.send("gates.test", b"{}")
    assert body.produced <= 10**6 + 2**16


def test_async_an_endless_body_stops_at_the_cap():
    body = endless()

    async def call() -> None:
        async with _async_mock(_streaming(200, body), max_response_bytes=10**6) as client:
            await client.send("gates.test", b"{}")

    with pytest.raises(ResponseTooLarge):
        asyncio.run(call())
    assert body.produced <= 10**6 + 2**16


def test_a_content_length_over_the_cap_is_refused_before_reading():
    body = endless()
    handler = _streaming(200, body, **{"content-length": str(10**12)})
    with _mock(handler, max_response_bytes=10**6) as client:
        with pytest.raises(ResponseTooLarge, match="Content-Length 1000000000000"):
            client.send("gates.test", b"{}")
    assert body.produced == 0


def test_the_cap_counts_the_decoded_body():
    """A gzip bomb: 10 MB of zeros in about 10 kB on the wire."""
    bomb = gzip.compress(b"0" * 10**7)

    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(200, headers={"content-encoding": "gzip"}, stream=Streamed([bomb]))

    with _mock(handler, max_response_bytes=10**6) as client:
        with pytest.raises(ResponseTooLarge):
            client.send("gates.test", b"{}")
    with _mock(handler, max_response_bytes=2 * 10**7) as client:
        answer = client.send("gates.test", b"{}")  # within the cap: the body, decoded
    assert answer.content == b"0" * 10**7 and "content-encoding" not in answer.headers


def test_a_body_that_does_not_decode_is_an_invalid_response():
    def handler(request: httpx.Request) -> httpx.Response:
        body = Streamed([b"not gzip at all"])
        return httpx.Response(200, headers={"content-encoding": "gzip"}, stream=body)

    with _mock(handler) as client, pytest.raises(InvalidResponseError, match="Content-Encoding"):
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])


def test_ready_never_reads_the_body():
    body = endless()
    with _mock(_streaming(200, body)) as client:
        assert client.ready()
    assert body.produced <= 2**16

    async def ready() -> bool:
        async with _async_mock(_streaming(200, body)) as client:
            return await client.ready()

    assert asyncio.run(ready())


@pytest.mark.parametrize("value", [0, -1, 1.5, True, "1"])
def test_bad_max_response_bytes(value):
    for cls in (Client, AsyncClient):
        with pytest.raises(ValueError, match="max_response_bytes"):
            cls(max_response_bytes=value)


def test_the_hierarchy():
    assert issubclass(ResponseTooLarge, InvalidResponseError)
    assert issubclass(InvalidResponseError, PlotgateClientError)
    assert not issubclass(InvalidResponseError, ProblemError)


def test_a_problem_with_a_million_fields_makes_a_readable_message():
    errors = [{"field": f"candidates[{i}].r", "reason": "x" * 100} for i in range(10**5)]
    problem = {"type": "about:blank", "title": "T" * 10**5, "status": 422, "detail": "d"}
    body = json.dumps({**problem, "errors": errors}).encode()
    with _mock(_answering(422, body, [])) as client, pytest.raises(InvalidInputError) as err:
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])
    assert len(err.value.problem.errors) == 10**5  # all of it kept on the exception
    assert len(str(err.value)) < 5000 and "(and 99995 more)" in str(err.value)


def test_a_transport_error_that_says_nothing_is_named_by_its_type():
    def reset(request: httpx.Request) -> httpx.Response:
        raise httpx.ReadError("", request=request)

    with _mock(reset, retries=0) as client, pytest.raises(TransportError, match=r"ReadError$"):
        client.test_gate(GATE, _plot(0, 0), [_plot(1, 1)])


class Clock:
    """The client's ``monotonic``, moved on a second by every piece of a trickling body."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def trickle(self) -> Iterator[bytes]:
        while True:
            self.now += 1.0
            yield b" "


@pytest.mark.parametrize("asynchronous", [False, True])
def test_a_body_trickling_past_the_read_timeout_ends_the_call(monkeypatch, asynchronous):
    """A byte a second never trips httpx's read timeout (a wait for the next bytes); the
    whole body gets that timeout too, and like any timeout once connected it is not
    retried."""
    from plotgate.clients import client as client_module

    clock = Clock()
    monkeypatch.setattr(client_module, "monotonic", clock)
    body = Streamed(clock.trickle())
    handler = _streaming(200, body)
    with pytest.raises(TransportError, match="still coming 10 s after the headers") as err:
        if asynchronous:

            async def call() -> None:
                async with _async_mock(handler, timeout=10.0) as client:
                    await client.send("gates.test", b"{}")

            asyncio.run(call())
        else:
            with _mock(handler, timeout=10.0) as client:
                client.send("gates.test", b"{}")
    assert body.produced == 11 and "attempts" not in str(err.value)
