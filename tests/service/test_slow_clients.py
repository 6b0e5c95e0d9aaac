"""Clients that stop half-way, and secrets in URLs.

* A body not received within ``PLOTGATE_BODY_TIMEOUT_S`` is answered 408 problem+json,
  recorded like any refusal of a request that reached an operation, and the connection is
  closed: connections that send half a body are dropped after the deadline, not held.
* A connection whose request headers are not complete within ``PLOTGATE_HEADER_TIMEOUT_S``
  (nothing sent, or half a request) is closed.
* The access log (off unless ``PLOTGATE_ACCESS_LOG``) never carries a query string.
"""

import json
import socket
import time

import httpx

from plotgate.clients.recordings import read_recording
from tests.support.requests import GOOD
from tests.support.servers import serve

HALF_SENT = 300
DEADLINE_S = 1.0


def _half_sent(port: int, i: int) -> socket.socket:
    body = json.dumps(GOOD).encode()
    head = (
        f"POST /v1/gates/test HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\n"
        f"x-request-id: half-{i}\r\ncontent-length: {len(body)}\r\n\r\n"
    ).encode()
    conn = socket.create_connection(("127.0.0.1", port))
    conn.sendall(head + body[: len(body) // 2])
    return conn


def _read_all(conn: socket.socket, within_s: float) -> bytes:
    """Everything the server sends until it closes the connection."""
    conn.settimeout(within_s)
    data = b""
    while chunk := conn.recv(65536):
        data += chunk
    return data


def test_half_sent_bodies_are_answered_408_and_dropped_after_the_deadline(tmp_path):
    env = {"PLOTGATE_BODY_TIMEOUT_S": str(DEADLINE_S)}
    with serve(tmp_path, env=env) as (_, url):
        port = int(url.rsplit(":", 1)[1])
        conns = [_half_sent(port, i) for i in range(HALF_SENT)]
        started = time.monotonic()
        r = httpx.post(url + "/v1/gates/test", json=GOOD, timeout=10)
        assert r.status_code == 200  # served meanwhile
        answers = [_read_all(c, within_s=10 * DEADLINE_S) for c in conns]  # EOF: dropped
        took = time.monotonic() - started
        for c in conns:
            c.close()
    assert took < 10 * DEADLINE_S
    for data in answers:
        head, _, body = data.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 408"), head
        assert b"content-type: application/problem+json" in head.lower()
        problem = json.loads(body)
        assert problem["type"] == "urn:plotgate:problem:request-timeout"
        assert problem["errors"][0]["field"] == "body"
    recorded = {
        ex.request_id: ex for f in tmp_path.glob("*.mcap") for ex in read_recording(f).exchanges
    }
    for i in range(HALF_SENT):
        exchange = recorded[f"half-{i}"]
        assert exchange.response["status"] == 408
        assert exchange.request["raw"] == json.dumps(GOOD)[: len(json.dumps(GOOD)) // 2]


def test_connections_without_whole_headers_are_closed_after_the_deadline(tmp_path):
    env = {"PLOTGATE_HEADER_TIMEOUT_S": str(DEADLINE_S)}
    with serve(tmp_path, env=env) as (_, url):
        port = int(url.rsplit(":", 1)[1])
        idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(HALF_SENT // 2)]
        half = [socket.create_connection(("127.0.0.1", port)) for _ in range(HALF_SENT // 2)]
        for conn in half:
            conn.sendall(b"POST /v1/gates/test HTTP/1.1\r\nhost: x\r\n")
        with httpx.Client(base_url=url) as http:  # a keep-alive client keeps being served
            for _ in range(3):
                assert http.get("/healthz").status_code == 200
                time.sleep(DEADLINE_S / 2)
        started = time.monotonic()
        assert all(_read_all(c, within_s=10 * DEADLINE_S) == b"" for c in idle + half)
        assert time.monotonic() - started < 10 * DEADLINE_S
        for c in idle + half:
            c.close()


def test_the_access_log_never_carries_a_query_string(tmp_path):
    log = tmp_path / "server.log"
    secret = "s3cr3t-key-0123456789"
    with serve(tmp_path / "recordings", log=log, env={"PLOTGATE_ACCESS_LOG": "true"}) as (_, url):
        assert httpx.get(f"{url}/healthz?api_key={secret}").status_code == 200
        r = httpx.post(f"{url}/v1/gates/test?key={secret}&x=1", json=GOOD)
        assert r.status_code == 200
        assert httpx.get(f"{url}/nowhere?token={secret}").status_code == 404
    text = log.read_text()
    assert secret not in text
    assert text.count("?[redacted]") == 3 and '"POST /v1/gates/test?[redacted] HTTP' in text
