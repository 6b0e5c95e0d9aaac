"""The live view's gate: the API's keys asked before a byte is sent, a cap on the clients
connected, each client's backlog bounded (the oldest scene dropped and counted); and the
listeners' binding policy of ``plotgate serve``."""

import os
import socket
import time

import httpx
import pytest
import uvicorn

from plotgate.clients.cli import main
from plotgate.service.access import Keys, binding_refusal
from plotgate.service.scenes.live import LiveView
from plotgate.service.scenes.live_gate import BACKLOG_MESSAGES, Backlog, SlowClient
from tests.support.live_clients import (
    answer_head,
    handshake,
    read_frame,
    stalled_subscriber,
    subscribe,
)
from tests.support.servers import free_port, serve

KEY = "s3cret-live"


def _everything(sock: socket.socket) -> bytes:
    """All the bytes the server sends until it closes (or 5 s of silence)."""
    sock.settimeout(5)
    data = b""
    try:
        while chunk := sock.recv(65536):
            data += chunk
    except TimeoutError:
        pass
    sock.close()
    return data


def test_a_keyed_server_sends_no_byte_of_the_live_view_without_the_key(tmp_path):
    """Defect 1: with PLOTGATE_API_KEY set, HTTP answered 401 while the live view streamed
    everything to anyone."""
    port = free_port()
    env = {"PLOTGATE_API_KEY": KEY}
    with serve(tmp_path, "--foxglove-port", str(port), env=env, ready_s=120) as (_, url):
        assert httpx.post(url + "/v1/gates/test", json={}).status_code == 401
        for query in ("", "?key=wrong", "?token=" + KEY):
            data = _everything(handshake(port, query))
            assert data.startswith(b"HTTP/1.1 401 "), data[:200]
            assert b"101" not in data.split(b"\r\n", 1)[0] and b"serverInfo" not in data
        keyed = handshake(port, "?key=" + KEY)
        assert b" 101 " in answer_head(keyed)
        opcode, payload = read_frame(keyed)
        assert opcode == 0x1 and b"serverInfo" in payload
        keyed.close()
        metrics = httpx.get(url + "/metrics", headers={"X-API-Key": KEY}).text
        assert 'plotgate_foxglove_refused_total{reason="key"} 3.0' in metrics


def test_the_http_headers_of_the_api_are_taken_too():
    live = LiveView("127.0.0.1", 0, Keys(bearer_token=KEY.encode()), 8).start()
    try:
        raw = socket.create_connection(("127.0.0.1", live.port), timeout=30)
        raw.sendall(
            b"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
            b"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n"
            b"Authorization: Bearer " + KEY.encode() + b"\r\n\r\n"
        )
        assert b" 101 " in answer_head(raw)
        raw.close()
    finally:
        live.close()


def test_clients_over_the_cap_are_refused_with_503():
    """Defect 8: there was no cap on connections."""
    live = LiveView("127.0.0.1", 0, None, 3).start()
    held = []
    try:
        for _ in range(3):
            sock = handshake(live.port)
            assert b" 101 " in answer_head(sock)
            held.append(sock)
        assert _everything(handshake(live.port)).startswith(b"HTTP/1.1 503 ")
        assert live.refused["full"] == 1 and live.clients == 3
        held.pop().close()
        deadline = time.monotonic() + 10
        while live.clients > 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        again = handshake(live.port)
        assert b" 101 " in answer_head(again)
        held.append(again)
    finally:
        for sock in held:
            sock.close()
        live.close()


def _rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:"))


def test_stalled_subscribers_keep_a_bounded_backlog_and_count_the_drops():
    """Defect 8: subscribers that never read made the publisher grow without bound."""
    live = LiveView("127.0.0.1", 0, None, 16).start()
    stalled = []
    try:
        stalled = [stalled_subscriber(live.port, "/log") for _ in range(8)]
        stalled.append(reader := handshake(live.port))
        assert b" 101 " in answer_head(reader)
        subscribe(reader, "/log")
        before = _rss_kib(live._process.pid)  # noqa: SLF001 - the publisher's memory
        for _ in range(20):  # 6000 Log messages ("too large to draw live"), in bursts
            for _i in range(300):
                live.offer("gates.test", time.time_ns(), b"x" * (2**20 + 1), b"{}")
            time.sleep(0.1)
        deadline = time.monotonic() + 60
        while live.client_dropped < 8 * 100:  # (how many the kernel's buffers take varies)
            assert time.monotonic() < deadline, live.client_dropped
            time.sleep(0.2)
        grown = _rss_kib(live._process.pid) - before  # noqa: SLF001
        assert grown < 40 * 1024, grown  # 8 backlogs of at most 256 KiB, and the SDK's
        reader.settimeout(30)
        assert read_frame(reader)[0] in (0x1, 0x2)  # a client that reads still gets frames
    finally:
        for sock in stalled:
            sock.close()
        live.close()


def test_the_backlog_drops_the_oldest_scene_and_keeps_control_messages():
    backlog = Backlog()
    assert backlog.put(b"advertise", False) == 0
    dropped = sum(backlog.put(bytes([i % 256]), True) for i in range(BACKLOG_MESSAGES + 10))
    assert dropped == 11 and len(backlog.items) == BACKLOG_MESSAGES
    assert backlog.items[0] == (b"advertise", False)
    assert backlog.items[1][0] == bytes([11])  # the oldest scenes went first
    full = Backlog()
    for _ in range(BACKLOG_MESSAGES):
        full.put(b"ping", False)
    with pytest.raises(SlowClient):
        full.put(b"ping", False)


def _serve(monkeypatch, argv):
    """``plotgate serve`` up to uvicorn.run, which is recorded instead of run."""
    ran = []
    monkeypatch.setattr(os, "environ", os.environ.copy())  # serve sets its options there
    monkeypatch.setattr(uvicorn, "run", lambda *a, **k: ran.append(k))
    monkeypatch.setattr("plotgate.clients.cli.load_kernels_first", lambda args: True)
    return main(["serve", "--no-record", *argv]), ran


@pytest.mark.parametrize(
    "argv",
    [["--host", "0.0.0.0"], ["--foxglove-port", "0", "--foxglove-host", "0.0.0.0"]],
    ids=["api", "live-view"],
)
def test_a_listener_off_loopback_without_keys_needs_the_flag(monkeypatch, capsys, argv):
    for name in ("API_KEY", "BEARER_TOKEN", "ALLOW_UNAUTHENTICATED"):
        monkeypatch.delenv("PLOTGATE_" + name, raising=False)
    code, ran = _serve(monkeypatch, argv)
    err = capsys.readouterr().err
    assert code == 2 and not ran
    assert err.count("\n") == 1 and "--allow-unauthenticated" in err
    if "--host" in argv:  # the live view's check would bind 0.0.0.0 to see the port free
        code, ran = _serve(monkeypatch, [*argv, "--allow-unauthenticated"])
        assert code == 0 and ran
        assert "warning:" in capsys.readouterr().err


def test_the_binding_policy():
    keys = Keys(api_key=b"k")
    assert binding_refusal("x", "127.0.0.1", Keys(), False) == (None, None)
    assert binding_refusal("x", "::1", Keys(), False) == (None, None)
    assert binding_refusal("x", "0.0.0.0", keys, False) == (None, None)
    assert binding_refusal("x", "0.0.0.0", Keys(), False)[0] is not None
    assert binding_refusal("x", "example.org", Keys(), True)[1] is not None
