"""``plotgate plot``: the curve requests follow the wire contract, the figures are PNGs."""

import json
import struct
import sys

import pytest

from plotgate.clients import InvalidInputError
from plotgate.clients.cli import main
from plotgate.clients.gate_figures import (
    FIGURES,
    INSTALL_HINT,
    OPERATION,
    MissingMatplotlib,
    Setup,
    figure_requests,
    plot,
)
from plotgate.clients.runners import http_runner, in_process_runner
from plotgate.service.table import ENDPOINTS
from tests.support.servers import serve

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _png_size(data: bytes) -> tuple[int, int]:
    """Width and height from the IHDR chunk, which must come first."""
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_fig2_in_process_writes_a_png(tmp_path, capsys):
    out = tmp_path / "figs" / "fig2.png"
    assert main(["plot", "fig2", "--out", str(out), "--points", "6"]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    data = out.read_bytes()
    width, height = _png_size(data)
    assert (width, height) == (1320, 990)
    assert len(data) > 20_000  # four panels of curves, not an empty canvas


@pytest.mark.parametrize("figure", FIGURES)
def test_curve_requests_match_the_wire_contract(figure):
    model = ENDPOINTS["gates.probability_curve"].request
    panels = figure_requests(figure, Setup(tau=4.0, v_min=120.0, v_max=450.0, course_deg=30.0))
    assert len(panels) == (1 if figure == "compare" else 4)
    for panel in panels:
        assert len(panel.curves) == 3
        for _, body in panel.curves:
            model.model_validate_json(json.dumps(body))  # unknown or missing fields fail
            assert body["tau"] == 4.0 and "tau" not in body["gate"]
            assert body["against"] == panel.against
            assert body["course_deg"] == 30.0
            if body["against"] == "speed":
                assert "speed" not in body and "prior" not in body
                assert body["values"][0] == 120.0 and body["values"][-1] == 450.0
                assert len(body["values"]) <= 1000
            elif figure == "compare":
                assert "speed" not in body
                assert body["prior"] == {"kind": "area", "v_min": 120.0, "v_max": 450.0}
                assert len(body["values"]) <= 100
                assert (body["mark"]["sigma_r"], body["mark"]["sigma_az_deg"]) == (200.0, 0.5)
            else:
                assert "prior" not in body and body["speed"] in (200.0, 300.0)
                assert len(body["values"]) <= 1000
            assert body["mark"]["r"] == body["values"][0] or body["against"] == "speed"
    kinds = {body["gate"]["kind"] for p in panels for _, body in p.curves}
    assert (
        kinds
        == {"fig2": {"ring"}, "fig5": {"combined"}, "compare": {"ring", "combined", "expanded"}}[
            figure
        ]
    )


def test_points_sets_the_curve_length():
    for figure in FIGURES:
        for panel in figure_requests(figure, points=4):
            assert all(len(body["values"]) == 4 for _, body in panel.curves)


def test_missing_matplotlib_says_how_to_install(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    out = tmp_path / "fig2.png"
    with pytest.raises(MissingMatplotlib, match=r'pip install "plotgate\[plot\]"'):
        plot("fig2", out, points=3)
    assert main(["plot", "fig2", "--out", str(out), "--points", "3"]) == 2
    assert INSTALL_HINT in capsys.readouterr().err
    assert not out.exists()


def test_a_refused_request_is_reported(tmp_path, capsys):
    bad = figure_requests("fig2", Setup(v_min=600.0, v_max=500.0), points=3)[0].curves[0][1]
    with pytest.raises(InvalidInputError, match="gate.v_min"):
        in_process_runner(OPERATION)(bad)
    out = tmp_path / "fig2.png"
    assert main(["plot", "fig2", "--v-min", "600", "--out", str(out), "--points", "3"]) == 2
    assert "gate.v_min" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow
def test_server_answers_match_in_process(tmp_path, capsys):
    from plotgate.clients import Client

    with serve(tmp_path / "recordings", "--no-record") as (_, url):
        out = tmp_path / "fig5.png"
        assert main(["plot", "fig5", "--server", url, "--out", str(out), "--points", "3"]) == 0
        assert capsys.readouterr().out.strip() == str(out)
        assert out.read_bytes()[:8] == PNG_SIGNATURE
        local = in_process_runner(OPERATION)
        panels = figure_requests("fig5", points=3)
        with Client(url) as client:
            remote = http_runner(client, OPERATION)
            for panel in (panels[0], panels[2]):  # one curve against speed, one against range
                body = panel.curves[1][1]
                assert remote(body) == local(body)
