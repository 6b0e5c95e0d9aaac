"""``plotgate scenario``: simulate, initiate and draw a PNG, in-process or on a server."""

from plotgate.clients.cli import main
from tests.servers import serve

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_scenario_png_in_process(tmp_path, capsys):
    out = tmp_path / "figs" / "scenario.png"
    assert main(["scenario", "--clutter", "50", "--seed", "3", "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    data = out.read_bytes()
    assert data[:8] == PNG_SIGNATURE and len(data) > 30_000


def test_scenario_png_on_a_server_with_own_settings(tmp_path, capsys):
    config = tmp_path / "config.json"
    config.write_text('{"mode": "cartesian", "capture_gate": "expanded", "v_max": 30.0}')
    out = tmp_path / "scenario.png"
    with serve(tmp_path / "rec", "--no-record") as (_, url):
        assert (
            main(
                [
                    "scenario",
                    "--clutter",
                    "20",
                    "--config",
                    str(config),
                    "--out",
                    str(out),
                    "--server",
                    url,
                ]
            )
            == 0
        )
    assert out.read_bytes()[:8] == PNG_SIGNATURE


def test_bad_settings_file_is_a_clean_error(tmp_path, capsys):
    config = tmp_path / "config.json"
    config.write_text('{"mode": "spherical"}')
    assert main(["scenario", "--config", str(config), "--out", str(tmp_path / "x.png")]) == 2
    assert "config.mode" in capsys.readouterr().err
