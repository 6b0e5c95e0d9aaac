"""A second ``plotgate serve`` on a port in use says so in one line naming ``--port`` and
exits 2, instead of uvicorn's "[Errno 98]" and exit 3."""

import socket

import pytest

from plotgate.clients.cli import main
from plotgate.clients.ports import listen_refused
from tests.support.servers import free_port


def test_serve_on_a_busy_port_names_the_option_and_exits_2(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("uvicorn.run", lambda *a, **k: pytest.fail("the server started"))
    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        monkeypatch.setenv("PLOTGATE_PORT", str(port))  # serve sets it: restored after
        monkeypatch.setenv("PLOTGATE_LOG_DIR", str(tmp_path / "rec"))
        code = main(["serve", "--port", str(port), "--log-dir", str(tmp_path / "rec")])
    err = capsys.readouterr().err
    assert code == 2
    assert err == (
        f"plotgate serve: 127.0.0.1:{port} is already in use (another server?); "
        "choose another with --port\n"
    )


def test_a_free_port_is_not_refused():
    assert listen_refused("127.0.0.1", free_port()) is None


def test_an_address_that_is_not_this_machine_s_names_host():
    refused = listen_refused("192.0.2.1", free_port())  # TEST-NET-1: never local
    assert refused is not None and "--host" in refused
