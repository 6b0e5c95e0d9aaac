"""``plotgate call``: any operation on a JSON request, in-process or on a server."""

import json

import numpy as np
import pytest

from plotgate.clients.cli import main

TX = np.array([0.0, 0.0])
RX = np.array([[10_000.0, 0.0], [0.0, 10_000.0], [10_000.0, 10_000.0]])
TARGET = np.array([4_000.0, 3_000.0])
SUMS = (np.linalg.norm(TARGET - RX, axis=1) + np.linalg.norm(TARGET - TX)).tolist()
REQUEST = {
    "problems": [
        {"range_sums": SUMS, "transmitter": TX.tolist(), "receivers": RX.tolist(), "sigma": 0.5}
    ]
}


def test_call_solves_in_process(tmp_path, capsys):
    path = tmp_path / "request.json"
    path.write_text(json.dumps(REQUEST))
    assert main(["call", "solves.position", str(path)]) == 0
    answer = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(answer["solutions"][0]["position"], TARGET, atol=1e-6)


def test_call_reads_stdin_and_reports_a_problem(monkeypatch, capsys):
    bad = {**REQUEST, "problems": [{**REQUEST["problems"][0], "sigma": 0.0}]}
    monkeypatch.setattr("sys.stdin", type("In", (), {"buffer": _Bytes(json.dumps(bad))})())
    assert main(["call", "solves.position"]) == 1
    problem = json.loads(capsys.readouterr().out)
    assert problem["status"] == 422
    assert any("sigma" in e["field"] for e in problem["errors"])


class _Bytes:
    def __init__(self, text: str) -> None:
        self._data = text.encode()

    def read(self) -> bytes:
        return self._data


@pytest.mark.slow
def test_call_on_a_live_server(tmp_path, capsys):
    from tests.support.servers import serve

    path = tmp_path / "request.json"
    path.write_text(json.dumps(REQUEST))
    with serve(tmp_path / "recordings") as (_, url):
        assert main(["call", "solves.position", str(path), "--server", url]) == 0
    answer = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(answer["solutions"][0]["position"], TARGET, atol=1e-6)


class Answering:
    """An ASGI app that answers every request with one status, body and content type (a
    proxy, a captive portal or a broken build in the server's place)."""

    def __init__(self, status: int, body: bytes, content_type: str, **headers: str) -> None:
        self.status = status
        self.body = body
        self.headers = [(b"content-type", content_type.encode())]
        self.headers += [(k.encode(), v.encode()) for k, v in headers.items()]

    async def __call__(self, scope, receive, send) -> None:
        while (await receive()).get("more_body"):
            pass
        await send({"type": "http.response.start", "status": self.status, "headers": self.headers})
        await send({"type": "http.response.body", "body": self.body})


HTML = b"<html><body><h1>502 Bad Gateway</h1></body></html>"


@pytest.mark.parametrize(
    ("status", "body", "kind", "code", "said"),
    [
        (502, HTML, "text/html", 1, ""),
        (503, HTML, "text/html", 1, ""),
        (200, HTML, "text/html", 2, "invalid answer: not a PositionSolveResult"),
        (200, b'{"solutions": [{"pos', "application/json", 2, "EOF while parsing"),
        (200, b'{"wrong": "schema"}', "application/json", 2, "solutions: Field required"),
    ],
    ids=["html-502", "html-503", "html-200", "truncated-200", "wrong-schema-200"],
)
def test_call_on_a_server_answering_what_is_no_answer(
    tmp_path, capsys, status, body, kind, code, said
):
    """A message and the contracted exit code, never a traceback: a non-2xx body that is no
    problem is printed as the problem the client makes of it (exit 1); a 2xx body that is not
    the operation's answer is no answer (exit 2)."""
    from tests.support.servers import serving

    path = tmp_path / "request.json"
    path.write_text(json.dumps(REQUEST))
    with serving(Answering(status, body, kind)) as url:
        args = ["call", "solves.position", str(path), "--server", url, "--retries", "0"]
        assert main(args) == code
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "internal error" not in err and said in err
    if code == 1:
        problem = json.loads(out)
        assert problem["status"] == status and "502 Bad Gateway" in problem["detail"]
    else:
        assert out == "" and url in err


def test_call_on_a_server_announcing_an_answer_over_the_cap(tmp_path, capsys):
    from tests.support.servers import serving

    path = tmp_path / "request.json"
    path.write_text(json.dumps(REQUEST))
    app = Answering(200, b"{}", "application/json", **{"content-length": str(2**40)})
    with serving(app) as url:
        assert main(["call", "solves.position", str(path), "--server", url]) == 2
    err = capsys.readouterr().err.splitlines()  # with the test server's own complaint
    said = [line for line in err if line.startswith("plotgate call: ")]
    assert len(said) == 1 and "200 from" in said[0] and "max_response_bytes" in said[0]


PICTURE = {"passive_deg": [[10.0, 10.2], [45.0, 45.1]], "active_deg": [[10.1, 10.0]]}


def test_call_in_process_applies_the_servers_caps_and_no_limits_lifts_them(
    tmp_path, monkeypatch, capsys
):
    """In-process, call answers what the server would: the work caps in force (the defaults
    with PLOTGATE_LIMITS over them) refuse before any work; --no-limits runs the request."""
    monkeypatch.setenv(
        "PLOTGATE_LIMITS", '{"identification.picture": {"passive_deg x active_deg": 1}}'
    )
    path = tmp_path / "picture.json"
    path.write_text(json.dumps(PICTURE))
    assert main(["call", "identification.picture", str(path)]) == 1
    problem = json.loads(capsys.readouterr().out)
    assert [e["field"] for e in problem["errors"]] == ["passive_deg x active_deg"]
    assert main(["call", "identification.picture", str(path), "--no-limits"]) == 0
    assert len(json.loads(capsys.readouterr().out)["z"]) == 2


def test_call_refuses_no_limits_with_a_server(tmp_path, capsys):
    path = tmp_path / "picture.json"
    path.write_text(json.dumps(PICTURE))
    args = ["call", "identification.picture", str(path), "--server", "http://127.0.0.1:9"]
    assert main([*args, "--no-limits"]) == 2
    assert "--no-limits is for in-process runs" in capsys.readouterr().err


def test_call_refuses_limits_the_server_would_not_start_with(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PLOTGATE_LIMITS", '{"identification.picture": {"plots": 1}}')
    path = tmp_path / "picture.json"
    path.write_text(json.dumps(PICTURE))
    assert main(["call", "identification.picture", str(path)]) == 2
    assert "PLOTGATE_LIMITS: identification.picture has no size 'plots'" in capsys.readouterr().err
