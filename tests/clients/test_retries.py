"""The clients' retries: a 503 and a failed connection are tried again, nothing else is.

A real server (uvicorn on a loopback port) that answers 503 a given number of times before
the operation's answer counts the attempts; MockTransport raises the connection errors; a
recorded ``sleep`` and a chosen ``uniform`` check the waits without waiting.
"""

import asyncio
import json
import random

import httpx
import pytest
from starlette.requests import Request
from starlette.responses import Response
from starlette.types import Receive, Scope, Send

from plotgate.clients import (
    AsyncClient,
    Client,
    ClusterUnavailable,
    InvalidInputError,
    RecordingUnavailable,
    ServerError,
    TransportError,
)
from plotgate.clients import client as client_module
from plotgate.clients.cli import main
from plotgate.service.problems import ProblemError, problem_json
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas import CartesianPlot, GateResults, GateTestRequest, RingGate
from tests.support.servers import free_port, serving

GATE = RingGate(kind="ring", tau=5.0, v_min=100.0, v_max=500.0)
FIRST = CartesianPlot(frame="cartesian", x=0.0, y=0.0, covariance=((1e4, 0.0), (0.0, 1e4)))
SECOND = CartesianPlot(frame="cartesian", x=0.0, y=1000.0, covariance=((1e4, 0.0), (0.0, 1e4)))
REQUEST = {
    "gate": GATE.model_dump(mode="json"),
    "first": FIRST.model_dump(mode="json"),
    "candidates": [SECOND.model_dump(mode="json")],
}


class Unavailable:
    """An ASGI app that answers 503 (a plotgate problem of ``kind``, with ``Retry-After``)
    to its first ``failures`` requests and runs the operation for the others; it keeps the
    ``X-Request-ID`` of every request it got."""

    def __init__(
        self, failures: int, kind: str = "recording-unavailable", retry_after: str = "0"
    ) -> None:
        self.failures = failures
        self.kind = kind
        self.retry_after = retry_after
        self.request_ids: list[str | None] = []
        self._operations = {op.path: op for op in OPERATIONS.values()}

    @property
    def attempts(self) -> int:
        return len(self.request_ids)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        request = Request(scope, receive)
        body = await request.body()
        self.request_ids.append(request.headers.get("x-request-id"))
        if self.attempts <= self.failures:
            problem = ProblemError(self.kind, 503, f"not now ({self.attempts})")
            response = Response(
                problem_json(problem, request.url.path, request.headers.get("x-request-id")),
                503,
                {"retry-after": self.retry_after},
                media_type="application/problem+json",
            )
        else:
            outcome = execute(self._operations[request.url.path], body)
            response = Response(outcome.content, outcome.status, media_type="application/json")
        await response(scope, receive, send)


@pytest.fixture
def waits(monkeypatch) -> list[float]:
    """The waits between attempts, recorded instead of slept (sync and async clients)."""
    recorded: list[float] = []

    async def async_sleep(seconds: float) -> None:
        recorded.append(seconds)

    monkeypatch.setattr(client_module, "sleep", recorded.append)
    monkeypatch.setattr(client_module, "async_sleep", async_sleep)
    return recorded


def _answers(result: GateResults) -> None:
    assert isinstance(result, GateResults)
    assert result.inside == [True] and result.statistic == pytest.approx([1000.0])


# --- against a real server that answers 503 twice ---------------------------------------


def test_503_twice_then_the_answer():
    """Real sleeps (Retry-After 0, a 10 ms backoff): the unpatched path, end to end."""
    server = Unavailable(failures=2)
    with serving(server) as url, Client(url, backoff=0.01) as client:
        _answers(client.test_gate(GATE, FIRST, [SECOND]))
    assert server.attempts == 3
    [request_id] = set(server.request_ids)
    assert request_id, "a call without a request id gets one, the same for every attempt"


def test_async_503_twice_then_the_answer(waits):
    server = Unavailable(failures=2, retry_after="1")

    async def call(url: str) -> GateResults:
        async with AsyncClient(url) as client:
            return await client.test_gate(GATE, FIRST, [SECOND])

    with serving(server) as url:
        _answers(asyncio.run(call(url)))
    assert server.attempts == 3 and len(waits) == 2
    assert all(1.0 <= wait <= 30.0 for wait in waits), waits
    assert len(set(server.request_ids)) == 1


def test_the_callers_request_id_on_every_attempt(waits):
    server = Unavailable(failures=2)
    with serving(server) as url, Client(url) as client:
        client.call("gates.test", GateTestRequest.model_validate(REQUEST), "mine-1")
    assert server.request_ids == ["mine-1"] * 3


def test_retries_0_is_one_attempt(waits):
    server = Unavailable(failures=2)
    with serving(server) as url, Client(url, retries=0) as client:
        with pytest.raises(RecordingUnavailable, match=r"not now \(1\)") as err:
            client.test_gate(GATE, FIRST, [SECOND])
    assert server.attempts == 1 and waits == []
    assert err.value.attempts == 1 and "attempts" not in str(err.value)


@pytest.mark.parametrize("retries", [1, 4])
def test_retries_exhausted(waits, retries):
    server = Unavailable(failures=10, kind="cluster-unavailable")
    with serving(server) as url, Client(url, retries=retries) as client:
        with pytest.raises(ClusterUnavailable, match=f"after {retries + 1} attempts") as err:
            client.test_gate(GATE, FIRST, [SECOND])
    assert server.attempts == retries + 1 and len(waits) == retries
    assert err.value.attempts == retries + 1
    assert err.value.problem.detail == f"not now ({retries + 1})", "the last attempt's problem"


def test_async_retries_exhausted(waits):
    server = Unavailable(failures=10)

    async def call(url: str) -> None:
        async with AsyncClient(url, retries=2) as client:
            await client.test_gate(GATE, FIRST, [SECOND])

    with serving(server) as url, pytest.raises(RecordingUnavailable, match="after 3 attempts"):
        asyncio.run(call(url))
    assert server.attempts == 3


def test_send_retries_and_returns_the_last_answer(waits):
    server = Unavailable(failures=10)
    with serving(server) as url, Client(url, retries=1) as client:
        answer = client.send("gates.test", json.dumps(REQUEST).encode())
    assert answer.status_code == 503 and server.attempts == 2


# --- what is retried and what is not ----------------------------------------------------


class Flaky:
    """A MockTransport handler: raises ``error`` (or answers ``status``) ``times`` times,
    then answers the operation; counts the requests."""

    def __init__(self, times: int, error: type[httpx.TransportError] | None, status: int = 0):
        self.times, self.error, self.status = times, error, status
        self.requests = 0

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests += 1
        if self.requests <= self.times:
            if self.error is not None:
                raise self.error("down", request=request)
            return httpx.Response(self.status, content=b"{}")
        outcome = execute(OPERATIONS["gates.test"], request.content)
        return httpx.Response(outcome.status, content=outcome.content)


RETRIED = [
    httpx.ConnectError,
    httpx.ConnectTimeout,
    httpx.PoolTimeout,
    httpx.RemoteProtocolError,
    httpx.ReadError,
    httpx.WriteError,
]


@pytest.mark.parametrize("error", RETRIED)
def test_connection_errors_retried(waits, error):
    flaky = Flaky(2, error)
    with Client("http://plotgate", transport=httpx.MockTransport(flaky)) as client:
        _answers(client.test_gate(GATE, FIRST, [SECOND]))
    assert flaky.requests == 3 and len(waits) == 2


@pytest.mark.parametrize("error", RETRIED)
def test_async_connection_errors_retried(waits, error):
    flaky = Flaky(2, error)

    async def call() -> GateResults:
        transport = httpx.MockTransport(flaky)
        async with AsyncClient("http://plotgate", transport=transport) as client:
            return await client.test_gate(GATE, FIRST, [SECOND])

    _answers(asyncio.run(call()))
    assert flaky.requests == 3


def test_connection_errors_exhausted(waits):
    flaky = Flaky(10, httpx.ConnectError)
    with Client("http://plotgate", transport=httpx.MockTransport(flaky), retries=2) as client:
        with pytest.raises(TransportError, match="gates.test at .*after 3 attempts") as err:
            client.test_gate(GATE, FIRST, [SECOND])
    assert isinstance(err.value.__cause__, httpx.ConnectError)
    assert flaky.requests == 3


@pytest.mark.parametrize("error", [httpx.ReadTimeout, httpx.WriteTimeout])
def test_a_timeout_once_connected_is_not_retried(waits, error):
    """The server may still be working on it: a second copy would double its load."""
    flaky = Flaky(1, error)
    with Client("http://plotgate", transport=httpx.MockTransport(flaky)) as client:
        with pytest.raises(TransportError) as err:
            client.test_gate(GATE, FIRST, [SECOND])
    assert isinstance(err.value.__cause__, error) and "attempts" not in str(err.value)
    assert flaky.requests == 1 and waits == []


@pytest.mark.parametrize(
    ("status", "raised"),
    [
        (400, InvalidInputError),
        (408, ServerError),
        (422, InvalidInputError),
        (429, ServerError),
        (500, ServerError),
        (502, ServerError),
        (504, ServerError),
    ],
)
def test_other_answers_are_not_retried(waits, status, raised):
    flaky = Flaky(1, None, status)
    with Client("http://plotgate", transport=httpx.MockTransport(flaky)) as client:
        with pytest.raises(raised, match=str(status)):
            client.test_gate(GATE, FIRST, [SECOND])
    assert flaky.requests == 1 and waits == []


def test_an_answer_after_a_503_says_which_attempt_it_was(waits):
    """A 503 then a 500: not retried again, and the error counts both attempts."""
    answers = iter([httpx.Response(503), httpx.Response(500)])
    transport = httpx.MockTransport(lambda request: next(answers))
    with Client("http://plotgate", transport=transport) as client:
        with pytest.raises(ServerError, match="after 2 attempts"):
            client.test_gate(GATE, FIRST, [SECOND])
    assert len(waits) == 1


# --- the waits --------------------------------------------------------------------------


def test_full_jitter_within_the_doubling_and_the_cap(waits, monkeypatch):
    ceilings: list[float] = []
    rng = random.Random(18)

    def uniform(low: float, high: float) -> float:
        ceilings.append(high)
        return rng.uniform(low, high)

    monkeypatch.setattr(client_module, "uniform", uniform)
    flaky = Flaky(7, httpx.ConnectError)
    transport = httpx.MockTransport(flaky)
    with Client(
        "http://plotgate", transport=transport, retries=7, backoff=0.5, backoff_max=4.0
    ) as client:
        _answers(client.test_gate(GATE, FIRST, [SECOND]))
    assert ceilings == [0.5, 1.0, 2.0, 4.0, 4.0, 4.0, 4.0]
    assert len(waits) == 7
    assert all(0.0 <= wait <= ceiling for wait, ceiling in zip(waits, ceilings, strict=True))
    assert len(set(waits)) == 7, "random waits, not one fixed wait"


def _three_503s(retry_after: str, backoff: float, backoff_max: float) -> None:
    """A call answered 503 with ``retry_after`` three times, then the operation's answer."""
    answers = [httpx.Response(503, headers={"retry-after": retry_after})] * 3

    def handler(request: httpx.Request) -> httpx.Response:
        if answers:
            return answers.pop()
        return httpx.Response(
            200, content=execute(OPERATIONS["gates.test"], request.content).content
        )

    transport = httpx.MockTransport(handler)
    with Client(
        "http://plotgate", transport=transport, backoff=backoff, backoff_max=backoff_max
    ) as client:
        _answers(client.test_gate(GATE, FIRST, [SECOND]))


@pytest.mark.parametrize("seed", range(5))
def test_at_least_retry_after(waits, monkeypatch, seed):
    monkeypatch.setattr(client_module, "uniform", random.Random(seed).uniform)
    _three_503s("2", backoff=0.1, backoff_max=30.0)
    assert len(waits) == 3 and all(2.0 <= wait <= 2.4 for wait in waits), waits


def test_retry_after_capped_by_backoff_max(waits):
    _three_503s("120", backoff=0.1, backoff_max=5.0)
    assert waits == [5.0, 5.0, 5.0]


@pytest.mark.parametrize("retry_after", ["Wed, 21 Oct 2015 07:28:00 GMT", "-3", "1.5", "soon"])
def test_retry_after_not_delta_seconds_is_ignored(waits, monkeypatch, retry_after):
    monkeypatch.setattr(client_module, "uniform", lambda low, high: high)
    _three_503s(retry_after, backoff=0.25, backoff_max=30.0)
    assert waits == [0.25, 0.5, 1.0]


def test_many_retries_stay_capped(waits, monkeypatch):
    """Past 2**1023 the doubling would overflow a float; the wait stays at the cap."""
    monkeypatch.setattr(client_module, "uniform", lambda low, high: high)
    flaky = Flaky(1100, httpx.ConnectError)
    with Client(
        "http://plotgate", transport=httpx.MockTransport(flaky), retries=1100, backoff_max=7.0
    ) as client:
        _answers(client.test_gate(GATE, FIRST, [SECOND]))
    assert len(waits) == 1100 and waits[-1] == 7.0 and max(waits) == 7.0


# --- arguments --------------------------------------------------------------------------


@pytest.mark.parametrize("cls", [Client, AsyncClient])
@pytest.mark.parametrize(
    ("argument", "value"),
    [
        ("retries", -1),
        ("retries", 1.5),
        ("backoff", -0.5),
        ("backoff", float("nan")),
        ("backoff_max", -1.0),
        ("backoff_max", float("inf")),
    ],
)
def test_bad_arguments(cls, argument, value):
    with pytest.raises(ValueError, match=f"^{argument} must be"):
        cls("http://plotgate", **{argument: value})


def test_the_clients_own_request_id_header_is_kept(waits):
    server = Unavailable(failures=1)
    with serving(server) as url, Client(url, headers={"X-Request-ID": "batch-7"}) as client:
        client.test_gate(GATE, FIRST, [SECOND])
    assert server.request_ids == ["batch-7", "batch-7"]


# --- plotgate call --server -------------------------------------------------------------


@pytest.fixture
def request_file(tmp_path):
    path = tmp_path / "request.json"
    path.write_text(json.dumps(REQUEST))
    return str(path)


def test_cli_retries_0(waits, request_file, capsys):
    server = Unavailable(failures=2)
    with serving(server) as url:
        code = main(["call", "gates.test", request_file, "--server", url, "--retries", "0"])
    assert code == 1 and server.attempts == 1
    out, err = capsys.readouterr()
    assert json.loads(out)["type"].endswith(":recording-unavailable") and err == ""


def test_cli_retries(waits, request_file, capsys):
    server = Unavailable(failures=2)
    with serving(server) as url:
        code = main(["call", "gates.test", request_file, "--server", url, "--backoff", "0"])
    assert code == 0 and server.attempts == 3 and waits == [0.0, 0.0]
    assert json.loads(capsys.readouterr().out)["inside"] == [True]


def test_cli_retries_exhausted(waits, request_file, capsys):
    server = Unavailable(failures=10)
    with serving(server) as url:
        code = main(["call", "gates.test", request_file, "--server", url, "--retries", "2"])
    assert code == 1 and server.attempts == 3
    assert "still 503 after 3 attempts" in capsys.readouterr().err


def test_cli_unreachable_server(waits, request_file, capsys):
    url = f"http://127.0.0.1:{free_port()}"
    assert main(["call", "gates.test", request_file, "--server", url, "--retries", "1"]) == 2
    assert "after 2 attempts" in capsys.readouterr().err and len(waits) == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--retries", "1"], "need --server"),
        (["--server", "http://127.0.0.1:9", "--retries", "-1"], "integer >= 0"),
        (["--server", "http://127.0.0.1:9", "--backoff", "nan"], "seconds >= 0"),
    ],
)
def test_cli_bad_retry_options(request_file, capsys, args, message):
    assert main(["call", "gates.test", request_file, *args]) == 2
    assert message in capsys.readouterr().err
