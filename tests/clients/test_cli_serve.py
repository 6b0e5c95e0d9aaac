"""``plotgate serve``: settings the app would refuse end the command with a message."""

import pytest

from plotgate.clients.cli import main


@pytest.mark.parametrize(
    "limits",
    [
        '{"identification.picture": {"passive_deg x active_deg": 0}}',
        '{"identification.picture": {"passive_deg x active_deg": "many"}}',
        '{"identification.picture": {"plots": 5}}',
    ],
)
def test_serve_refuses_work_caps_it_cannot_apply(monkeypatch, tmp_path, capsys, limits):
    monkeypatch.setenv("PLOTGATE_LIMITS", limits)
    monkeypatch.setenv("PLOTGATE_LOG_DIR", str(tmp_path))  # restored after the test
    monkeypatch.setattr("uvicorn.run", lambda *a, **k: pytest.fail("the server started"))
    assert main(["serve"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("plotgate serve: the service's settings:") and "bug" not in err
