"""Tolerances learned from noise (``--calibrate``) and latency as a regression
(``--max-latency-ratio``)."""

import json
import random
import socket
import threading
import time
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from plotgate.clients.cli import main
from plotgate.service import registry
from tests.support.gate_recordings import moved_recording
from tests.support.servers import serve


def test_calibrate_on_a_clean_recording_writes_no_rule(tmp_path, capsys):
    rec = moved_recording(tmp_path / "rec")
    out = tmp_path / "learned.toml"
    assert main(["replay", str(rec), "--calibrate", str(out), "--runs", "2"]) == 0
    assert tomllib.loads(out.read_text()) == {}
    assert "0 fields differed" in capsys.readouterr().out


@pytest.fixture
def noisy_statistic(monkeypatch) -> None:
    """This build's gates.test answers with ``statistic`` jittered by up to 1e-7 relative
    (a stand-in for a Monte Carlo field): the one field that really varies."""
    real = registry.run
    noise = random.Random(2026)

    def run(*args, **kwargs):
        outcome = real(*args, **kwargs)
        if outcome.status != 200:
            return outcome
        result = json.loads(outcome.content)
        result["statistic"] = [s * (1 + noise.uniform(-1e-7, 1e-7)) for s in result["statistic"]]
        return registry.Outcome(outcome.status, json.dumps(result).encode())

    monkeypatch.setattr(registry, "run", run)


def test_calibrate_writes_rules_only_for_the_field_that_varies_and_then_replays_clean(
    tmp_path, noisy_statistic, capsys
):
    rec = moved_recording(tmp_path / "rec", exchanges=6)
    assert main(["replay", str(rec)]) == 1  # the noise breaks the default gate
    out = tmp_path / "learned.toml"
    assert main(["replay", str(rec), "--calibrate", str(out)]) == 0
    [rule] = tomllib.loads(out.read_text())["rule"]
    assert (rule["operation"], rule["path"]) == ("gates.test", "statistic[*]")
    assert 1e-7 < rule["rtol"] <= 2e-6  # ten times what was seen, which is under 1e-7
    capsys.readouterr()
    assert main(["replay", str(rec), "--tolerances", str(out)]) == 0


@contextmanager
def _slow_proxy(upstream: str, delay_s: float) -> Iterator[str]:
    """A loopback TCP proxy to ``upstream`` (``http://host:port``) that holds every piece
    of an answer ``delay_s`` before passing it on: a server slowed on purpose."""
    host, port = upstream.removeprefix("http://").rsplit(":", 1)
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    stop = threading.Event()

    def pipe(src: socket.socket, dst: socket.socket, delay: float) -> None:
        try:
            while data := src.recv(65536):
                time.sleep(delay)
                dst.sendall(data)
        except OSError:
            pass
        finally:
            dst.close()

    def accept() -> None:
        while not stop.is_set():
            try:
                client, _ = listener.accept()
            except TimeoutError:
                continue
            server = socket.create_connection((host.strip("[]"), int(port)), timeout=30)
            threading.Thread(target=pipe, args=(client, server, 0.0), daemon=True).start()
            threading.Thread(target=pipe, args=(server, client, delay_s), daemon=True).start()

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(5)
        listener.close()


def test_max_latency_ratio_fails_a_slowed_server_and_passes_otherwise(tmp_path, capsys):
    rec = moved_recording(tmp_path / "rec", exchanges=5)  # recorded: 2 ms each
    with serve(tmp_path / "served", "--no-record", ready_s=120.0) as (_, url):
        gate = ["replay", str(rec), "--max-latency-ratio", "100"]
        assert main([*gate, "--server", url]) == 0
        assert "latency gates.test" in capsys.readouterr().out
        with _slow_proxy(url, 0.5) as slow:
            summary = tmp_path / "summary.md"
            assert main([*gate, "--server", slow, "--summary-md", str(summary)]) == 1
            assert "LATENCY gates.test" in capsys.readouterr().err
            # open loop: five answers of 0.5 s each, sent 10 ms apart, take about 0.5 s
            started = time.monotonic()
            assert main(["replay", str(rec), "--server", slow, "--pace", "1x"]) == 0
            assert time.monotonic() - started < 2.4
            assert "pace 1x: 5 sent" in capsys.readouterr().out
    assert "### Latency" in summary.read_text()


class _At:
    def __init__(self, ms: int) -> None:
        self.log_time = ms * 10**6


def test_paced_sends_on_time_keeps_the_order_and_says_when_it_fell_behind(monkeypatch):
    from plotgate.clients import pace

    exchanges = [_At(10 * i) for i in range(6)]
    fast = pace.Pacing(1.0)
    started = time.monotonic()
    assert [ex for ex, _ in pace.paced(exchanges, lambda ex: ex, fast)] == exchanges
    assert 0.05 <= time.monotonic() - started and fast.behind == 0 and fast.sent == 6
    monkeypatch.setattr(pace, "MAX_IN_FLIGHT", 2)
    slow = pace.Pacing(1.0)
    out = list(pace.paced(exchanges, lambda ex: time.sleep(0.2) or ex.log_time, slow))
    assert [ex.log_time for ex, _ in out] == [r for _, r in out]
    assert slow.behind >= 3 and "fell behind" in slow.text()


def test_pace_without_a_server_is_exit_2(tmp_path, capsys):
    rec = moved_recording(tmp_path / "rec")
    assert main(["replay", str(rec), "--pace", "2x"]) == 2
    assert "--pace sends to a live server" in capsys.readouterr().err
    assert main(["replay", str(rec), "--pace", "fast"]) == 2
