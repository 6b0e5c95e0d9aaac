"""The first start speaks: with an empty kernel cache a command says, on stderr, that it
is compiling the numerical kernels and how long that took, instead of a silent minute; the
server answers meanwhile."""

import json
import os
import select
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from plotgate.clients.cli import main
from plotgate.service import kernels
from plotgate.service.warmup import kernel_names
from tests.support.servers import free_port

ROOT = Path(__file__).resolve().parents[2]
ANNOUNCEMENT = "compiling numerical kernels (first start only, a minute or two)..."
WARMUP_ANNOUNCEMENT = f"compiling {len(kernel_names())} numerical kernels (first start only"


def _lines_until(proc: subprocess.Popen, wanted: str, seconds: float) -> list[str]:
    """The stderr lines of ``proc`` up to the first containing ``wanted`` (or all of them
    read within ``seconds``)."""
    assert proc.stderr is not None
    lines: list[str] = []
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and len(lines) < 1000:
        ready, _, _ = select.select([proc.stderr], [], [], deadline - time.monotonic())
        if not ready:
            break
        line = proc.stderr.readline()
        if not line:
            break
        lines.append(line)
        if wanted in line:
            break
    return lines


@pytest.mark.slow
def test_serve_with_an_empty_kernel_cache_answers_while_it_compiles(tmp_path):
    """``/healthz`` answers while the warm-up compiles (:mod:`plotgate.service.warmup`),
    and the console says what is compiling."""
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "plotgate.clients.cli", "serve", "--port", str(port)]
        + ["--log-dir", str(tmp_path / "rec")],
        cwd=ROOT,
        env={**os.environ, "NUMBA_CACHE_DIR": str(cache)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = _lines_until(proc, WARMUP_ANNOUNCEMENT, seconds=120)
        health = httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=15)
        compiling = httpx.get(f"http://127.0.0.1:{port}/readyz", timeout=15).json()
    finally:
        proc.kill()  # no need to wait out the whole compilation
        proc.wait(timeout=30)
        if proc.stderr:
            proc.stderr.close()
    assert lines and lines[-1].startswith(f"plotgate: {WARMUP_ANNOUNCEMENT}"), lines
    assert health.json() == {"status": "ok"}
    assert compiling["operations"]["compiling"], compiling


def _gate_request(tmp_path: Path) -> str:
    path = tmp_path / "request.json"
    path.write_text(
        json.dumps(
            {
                "gate": {"kind": "ellipse", "P_G": 0.9},
                "first": {"frame": "cartesian", "x": 0, "y": 0, "covariance": [[1, 0], [0, 1]]},
                "candidates": [
                    {"frame": "cartesian", "x": 1, "y": 0, "covariance": [[1, 0], [0, 1]]}
                ],
            }
        )
    )
    return str(path)


def test_a_compilation_is_announced_then_timed(tmp_path, monkeypatch, capsys):
    def compiling(announce, **options):
        announce()
        return 71.4

    monkeypatch.setattr(kernels, "load_kernels", compiling)
    assert main(["call", "gates.test", _gate_request(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"plotgate call: {ANNOUNCEMENT}"
    assert err[1].startswith("plotgate call: kernels ready in 71 s")


def test_a_warm_start_says_nothing(tmp_path, capsys):
    assert main(["call", "gates.test", _gate_request(tmp_path)]) == 0
    assert capsys.readouterr().err == ""


def test_a_call_to_a_server_loads_no_kernels(tmp_path, monkeypatch, capsys):
    def refuse(*args, **kwargs):
        raise AssertionError("a call to a server needs no kernels")

    monkeypatch.setattr(kernels, "load_kernels", refuse)
    url = f"http://127.0.0.1:{free_port()}"
    code = main(["call", "gates.test", _gate_request(tmp_path), "--server", url, "--retries", "0"])
    assert code == 2
    assert "kernels" not in capsys.readouterr().err


def test_kernels_that_cannot_be_cached_end_the_command_with_a_message(
    tmp_path, monkeypatch, capsys
):
    def full_disk(*args, **kwargs):
        raise kernels.CacheRepairFailed("OSError: [Errno 28] No space left on device")

    monkeypatch.setattr(kernels, "load_kernels", full_disk)
    assert main(["call", "gates.test", _gate_request(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("plotgate call: cannot compile and cache the numerical kernels")
    assert "No space left on device" in err and "Traceback" not in err


def _gate_recording(settings) -> Path:
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    with TestClient(create_app(settings)) as client:
        for i in range(3):
            body = json.loads(Path(_gate_request(settings.log_dir.parent)).read_text())
            assert client.post("/v1/gates/test", json=body).status_code == 200, i
    return settings.log_dir


def test_a_replay_loads_the_kernels_of_the_operations_it_meets(settings, monkeypatch, capsys):
    folder = _gate_recording(settings)
    loaded = []

    def compiling(announce, module=None, **options):
        loaded.append(module)
        announce()
        return 3.2

    monkeypatch.setattr(kernels, "load_kernels", compiling)
    assert main(["replay", str(folder)]) == 0
    assert loaded == ["plotgate.service.operations.gates"]  # once, and that operation's only
    err = capsys.readouterr().err.splitlines()
    assert err == [  # each operation's kernels load as the replay first meets it, named
        "plotgate replay: compiling numerical kernels of gates.test (first start only, a "
        "minute or two)...",
        "plotgate replay: kernels of gates.test ready in 3 s (cached: later starts take a "
        "few seconds)",
    ]


def test_a_replay_whose_kernels_cannot_be_cached_ends_with_a_message(
    settings, monkeypatch, capsys
):
    folder = _gate_recording(settings)

    def full_disk(*args, **kwargs):
        raise kernels.CacheRepairFailed("OSError: [Errno 28] No space left on device")

    monkeypatch.setattr(kernels, "load_kernels", full_disk)
    assert main(["replay", str(folder), "--out", str(settings.log_dir.parent / "out.mcap")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("plotgate replay: cannot compile and cache the numerical kernels")
    assert "No space left on device" in err and "Traceback" not in err


def test_a_call_loads_its_operation_s_kernels_only(tmp_path, monkeypatch, capsys):
    loaded = []

    def load(announce, module=None, **options):
        loaded.append(module)

    monkeypatch.setattr(kernels, "load_kernels", load)
    assert main(["call", "gates.test", _gate_request(tmp_path)]) == 0
    assert loaded == ["plotgate.service.operations.gates"]
