"""``plotgate scenario``: simulate, initiate and draw a PNG, in-process or on a server."""

import json

from plotgate.clients.cli import main
from plotgate.clients.scenario_plot import classify_tracks, confirmed_tracks, draw_scenario
from tests.support.servers import serve

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


# Four scans of a hand-made scenario: plot j of scan i labelled LABELS[i][j] (-1 clutter).
# Target 0 is seen in every scan, target 1 in scans 0, 1 and 3, target 2 in scans 0, 2 and 3
# (three detections: missable), target 3 only twice (never counted as missed).
LABELS = [[0, -1, 1, 2, 3], [0, -1, 1, 3], [-1, 0, -1, 2], [0, 1, 2, -1]]
SIM = {
    "labels": LABELS,
    "truth": [[[1000.0 * k + 10.0 * i, 2000.0] for k in range(4)] for i in range(4)],
    "scans": [
        {
            "t": float(i),
            "plots": [
                {"frame": "cartesian", "x": 1000.0 * max(lab, 0) + 10.0 * i, "y": 2000.0 + j}
                for j, lab in enumerate(scan)
            ],
        }
        for i, scan in enumerate(LABELS)
    ],
}


def test_classification_follows_the_evaluation_rule():
    confirmed = {
        10: [[0, 0], [1, 0], [2, 0]],  # 2 of 3 plots from target 0: true, counts target 0
        11: [[1, 0], [2, 1], [3, 0]],  # all target 0, already counted: false
        12: [[0, 2], [1, 2], [2, 2], [3, 3]],  # target 1 in 2 of 4, not more than half: false
        13: [[0, 4], [1, 3], [2, 0]],  # 2 of 3 from target 3: true
    }
    kinds = classify_tracks(SIM, confirmed)
    assert kinds.true == {10: 0, 13: 3}
    assert kinds.false == [11, 12]
    assert kinds.missed == [1, 2]
    # the first confirmed track takes the target: the order of confirmation decides
    kinds = classify_tracks(SIM, {11: confirmed[11], 10: confirmed[10]})
    assert kinds.true == {11: 0} and kinds.false == [10]
    assert classify_tracks(SIM, {}, min_detections=4).missed == [0]


def test_tracks_confirmed_then_dropped_are_kept_scan_by_scan():
    def track(i, plots):
        return {"id": i, "status": "confirmed", "plots": plots}

    answers = iter(
        [
            {"state": "s1", "tracks": [], "scans": [{"confirmed": []}]},
            {"state": "s2", "tracks": [track(7, [[0, 0], [1, 0]])], "scans": [{"confirmed": [7]}]},
            {
                "state": "s3",
                "tracks": [track(7, [[0, 0], [1, 0], [2, 1]])],
                "scans": [{"confirmed": []}],
            },
            {"state": "s4", "tracks": [], "scans": [{"confirmed": []}]},  # 7 dropped
        ]
    )
    states = []

    def run(request):
        assert request["config"] == {"mode": "cartesian"} and len(request["scans"]) == 1
        states.append(request.get("state"))
        return next(answers)

    at_confirmation, last = confirmed_tracks(run, {"mode": "cartesian"}, SIM["scans"])
    assert states == [None, "s1", "s2", "s3"]
    assert at_confirmation == {7: [[0, 0], [1, 0]]}
    assert last == {7: [[0, 0], [1, 0], [2, 1]]}


def test_hand_made_scenario_png(tmp_path):
    confirmed = {10: [[0, 0], [1, 0], [2, 0]], 12: [[0, 2], [1, 2], [2, 2], [3, 3]]}
    scenario = {"sensor": (0.0, 0.0), "interval": 1.0, "P_D": 0.8, "clutter": 1.0}
    out = draw_scenario(SIM, (confirmed, confirmed), scenario, tmp_path / "s.png", "hand-made")
    assert out.read_bytes()[:8] == PNG_SIGNATURE


def test_the_title_names_the_method_the_settings_give():
    from pathlib import Path

    from plotgate.clients.scenario_plot import default_settings, describe
    from plotgate.service.schemas import InitiationSettings

    def title(config):
        return describe(InitiationSettings.model_validate(config).model_dump())

    score = (Path(__file__).parents[2] / "docs/examples/score_initiation.json").read_text()
    assert title(json.loads(score)) == (
        "Cartesian initiation, 2/3 capture in the combined gate, score confirmation "
        "(false_confirmation 0.15, at least 3 plots)"
    )
    assert title(default_settings()) == (
        "polar (Mu et al.) initiation, 2/2 capture in the combined gate, 3/4 confirmation"
    )
