"""``plotgate serve --foxglove-port``: a Foxglove WebSocket client subscribes and receives
the scene of the call it makes; the queue is bounded and counts what it drops; the service
starts without foxglove-sdk when the live view is off."""

import base64
import json
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx

from plotgate.clients.cli import main
from plotgate.service.scenes.live import QUEUE_EXCHANGES, LiveView
from plotgate.service.table import ENDPOINTS
from tests.support.servers import free_port, serve

EXAMPLES = {name: e.example for name, e in ENDPOINTS.items()}

LIVE = Path(__file__).resolve().parents[2] / "interop" / "live.mjs"


def lines_of(proc: subprocess.Popen) -> tuple[list[str], threading.Thread]:
    """The lines ``proc`` prints, gathered as they come by the thread returned (it ends
    with the process's output)."""
    lines: list[str] = []

    def gather() -> None:
        for line in proc.stdout:
            lines.append(line)

    thread = threading.Thread(target=gather, daemon=True)
    thread.start()
    return lines, thread


def test_a_foxglove_client_receives_the_scene_of_its_call(tmp_path, interop_node):
    """With a key set, through the gate: the key as ?key= in the WebSocket URL."""
    port = free_port()
    key = {"X-API-Key": "live-key"}
    with serve(tmp_path, "--foxglove-port", str(port), env={"PLOTGATE_API_KEY": "live-key"}) as (
        _,
        url,
    ):
        client = subprocess.Popen(
            [
                interop_node,
                str(LIVE),
                f"ws://127.0.0.1:{port}/?key=live-key",
                "/scene/gates.test",
                "1",
                "120",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            lines, gathering = lines_of(client)
            deadline = time.monotonic() + 120
            while not lines and client.poll() is None and time.monotonic() < deadline:
                time.sleep(0.05)
            assert lines, client.stderr.read() if client.poll() is not None else "no advertise"
            subscribed = json.loads(lines[0])
            assert subscribed["schemaName"] == "foxglove.SceneUpdate"
            assert subscribed["encoding"] == "protobuf"
            sent = time.time_ns()
            answer = httpx.post(
                url + "/v1/gates/test",
                json=EXAMPLES["gates.test"],
                headers={"X-Request-ID": "live-call-1", **key},
                timeout=30,
            )
            assert answer.status_code == 200
            assert client.wait(timeout=180) == 0, client.stderr.read()
        finally:
            if client.poll() is None:
                client.kill()
                client.wait()
            gathering.join(10)
            client.stdout.close()
            client.stderr.close()
        message = json.loads(lines[1])
        assert message["topic"] == "/scene/gates.test"
        assert b"live-call-1" in base64.b64decode(message["data"])  # the entity's metadata
        assert abs(int(message["timestamp"]) - sent) < 30e9  # stamped with the call's time
        metrics = httpx.get(url + "/metrics", headers=key).text
        assert "plotgate_foxglove_published_total 1.0" in metrics
        assert 'plotgate_foxglove_dropped_total{reason="queue_full"} 0.0' in metrics


def test_the_queue_is_bounded_and_counts_what_it_drops():
    live = LiveView("127.0.0.1", 0)
    live.offer("gates.test", 1, b"{}", b"{}")  # no publisher (never started, or died)
    assert live.dropped["no_publisher"] == 1
    live._conn = object()  # noqa: SLF001 - a publisher, as far as offer can tell
    for _ in range(QUEUE_EXCHANGES + 5):
        live.offer("gates.test", 1, b"{}", b"{}")
    assert len(live._queue) == QUEUE_EXCHANGES  # noqa: SLF001
    assert live.dropped["queue_full"] == 5
    live.offer("gates.test", 1, b"x" * (2**20 + 1), b"{}")
    assert live.dropped["too_large"] == 1


def test_a_port_taken_is_a_message_and_exit_2(tmp_path, capsys):
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        code = main(["serve", "--log-dir", str(tmp_path), "--foxglove-port", str(port)])
    assert code == 2
    assert "--foxglove-port: cannot listen on 127.0.0.1:" in capsys.readouterr().err


def test_the_service_starts_without_foxglove_sdk_when_the_view_is_off():
    code = (
        "import sys; sys.modules['foxglove'] = None\n"
        "from fastapi.testclient import TestClient\n"
        "from plotgate.service.app import create_app\n"
        "from plotgate.service.config import Settings\n"
        "with TestClient(create_app(Settings(record=False))) as c:\n"
        "    assert c.get('/readyz').status_code == 200\n"
        "assert 'plotgate.service.scenes' not in sys.modules\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
