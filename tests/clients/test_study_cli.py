"""``plotgate study``'s verdicts: each carries its standard error, NOT MET only beyond the
Monte Carlo noise, the exit code says so, and the shipped example scenario runs."""

import json
from pathlib import Path

import pytest

import plotgate.clients.study as study
from plotgate.clients.cli import main
from plotgate.clients.study import (
    MET,
    NOT_MET,
    WITHIN_NOISE,
    checks,
    noise_allowance,
    table,
    verdict,
)
from plotgate.service.schemas import StudyRequest
from plotgate.service.table import ENDPOINTS

EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "study_scenario.json"


def _sample(ml_single: float, se: float = 0.02) -> dict:
    return {
        "t": 0.0,
        "position": [0.0, 0.0],
        "crlb": [1.0, 0.0],
        "ml_single": [ml_single, 0.0],
        "linearised": [1.0, 0.0],
        "crlb_accumulated": [1.0, 0.0],
        "ml_track": None,
        "linearised_track": None,
        "sum_range": [1.5, 0.0],
        "max_distance": 3.0,
        "difference_range": [2.0, 0.0],
        "crlb_difference": [2.0, 0.0],
        "ml_single_se": se,
        "full_track": None,
        "false_minima": 0,
        "false_unflagged": 0,
        "gradient": [1.0],
        "inconsistent": 0,
    }


def test_the_noise_allowance_is_two_standard_errors_and_grows_with_the_samples():
    assert noise_allowance(1) == 2.0
    assert noise_allowance(200) == pytest.approx(3.66, abs=0.01)
    assert noise_allowance(0) == 2.0


@pytest.mark.parametrize(
    ("ratio", "se", "expected"),
    [
        (1.04, 0.01, MET),  # within the 5% limit
        (0.96, 0.01, MET),
        (1.07, 0.015, WITHIN_NOISE),  # 2% over the limit, 1.3 standard errors
        (1.07, 0.005, NOT_MET),  # the same 2%, 4 standard errors
        (0.92, 0.02, WITHIN_NOISE),  # short of 1: 1.5 standard errors over the limit
        (0.90, 0.02, NOT_MET),  # 2.5 standard errors over it; one estimate allows 2
    ],
)
def test_a_single_estimate_is_judged_against_its_noise(ratio, se, expected):
    assert verdict([(ratio, se)], 0.05) == expected


def test_the_worst_of_many_samples_gets_the_wider_allowance():
    # 3 standard errors over the limit: NOT MET for one estimate, noise among 200
    assert verdict([(1.08, 0.01)], 0.05) == NOT_MET
    assert verdict([(1.08, 0.01)] + [(1.0, 0.01)] * 199, 0.05) == WITHIN_NOISE


def test_checks_carry_the_standard_error_and_count_the_samples_outside():
    answer = {"runs": 200, "samples": [_sample(1.07, se=0.005), _sample(1.0)]}
    found = checks(answer)
    first = found[0]
    assert first.verdict == NOT_MET and not first.passed
    assert "worst 1.070 ± 0.005 at sample 0 (1 of 2 outside)" in first.result
    assert "no standard error" in found[2].result  # the largest Mahalanobis error
    noisy = checks({"runs": 200, "samples": [_sample(1.07, se=0.05), _sample(1.0)]})
    assert noisy[0].verdict == WITHIN_NOISE and noisy[0].passed


def _fake_study(answer: dict):
    def run(request, *, server=None):
        return {"runs": request["runs"], **answer}

    return run


def test_study_exits_1_on_not_met_and_0_within_noise(tmp_path, capsys, monkeypatch):
    base = {"seed": 1, "sigma": 0.5, "noise_sigma": 0.5, "noise_sigma_spread": 0.01}
    table = tmp_path / "t.md"
    args = ["study", str(EXAMPLE), "--no-png", "--table", str(table)]
    far, noisy = _sample(1.3, 0.01), _sample(1.07, 0.05)
    monkeypatch.setattr(study, "run_study", _fake_study({**base, "samples": [far]}))
    assert main(args) == 1
    printed = capsys.readouterr().out
    assert printed.startswith("NOT MET: ML single shot")
    assert "more than 2 standard errors" in printed
    assert "**NOT MET**" in table.read_text()
    monkeypatch.setattr(study, "run_study", _fake_study({**base, "samples": [noisy]}))
    assert main(args) == 0
    assert capsys.readouterr().out.startswith("within noise: ML single shot")


def test_the_example_scenario_is_a_valid_quick_study():
    request = StudyRequest.model_validate_json(EXAMPLE.read_text())
    runs, samples = request.runs, len(request.sample_times)
    assert not request.tracks and runs * samples * len(request.receivers) <= 100_000
    for size, cap in ENDPOINTS["solves.study"].caps.items():
        assert ENDPOINTS["solves.study"].work[size](request) <= cap


@pytest.mark.slow
def test_plotgate_study_runs_the_example_scenario(tmp_path, capsys):
    table = tmp_path / "study.md"
    code = main(["study", str(EXAMPLE), "--runs", "20", "--no-png", "--table", str(table)])
    printed = capsys.readouterr().out.splitlines()
    verdicts = [line.split(":")[0] for line in printed[:-2]]
    assert set(verdicts) <= {MET, WITHIN_NOISE, NOT_MET} and len(verdicts) == 5
    assert code == (1 if NOT_MET in verdicts else 0)
    assert all("±" in line or "no standard error" in line for line in printed[:-2])
    assert "20 runs" in table.read_text()


@pytest.mark.parametrize("text", ["{not json", "[1, 2]", "\xff"])
def test_a_request_file_that_is_no_json_object_is_exit_2(tmp_path, capsys, text):
    bad = tmp_path / "bad.json"
    bad.write_bytes(text.encode("latin-1"))
    assert main(["study", str(bad), "--no-png", "--table", str(tmp_path / "t.md")]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "Traceback" not in err


def test_the_example_is_shown_with_the_command(capsys):
    assert main(["study", "--help"]) == 0
    assert "docs/examples/study_scenario.json" in capsys.readouterr().out
    assert json.loads(EXAMPLE.read_text())["runs"] == 200


def test_checks_judge_the_limits_and_the_table_shows_them():
    sample = _sample(1.2)
    found = checks({"runs": 1000, "samples": [sample, sample]})
    # 1.2 is 20 % off, far beyond the noise; no track checks
    assert [c.verdict for c in found] == [NOT_MET, NOT_MET, MET, MET, MET]
    text = table(
        {
            "samples": [sample, sample],
            "runs": 1000,
            "seed": 0,
            "sigma": 0.5,
            "noise_sigma": 0.5,
            "noise_sigma_spread": 0.0,
        }
    )
    assert "| 1 | 0 |  | 1 | 1 | — | 1.2 | 1.5 | 2 | 2 | 1.200 | 1.200 | — | — | 1.000 |" in text
    assert "| **NOT MET** |" in text and 'note "on bk": the target crosses baseline k' in text


def test_study_writes_files_only_where_told_and_sums_up_in_a_sentence(
    tmp_path, capsys, monkeypatch
):
    base = {"seed": 1, "sigma": 0.5, "noise_sigma": 0.5, "noise_sigma_spread": 0.01}
    monkeypatch.setattr(study, "run_study", _fake_study({**base, "samples": [_sample(1.0)]}))
    monkeypatch.chdir(tmp_path)
    assert main(["study", str(EXAMPLE)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert list(tmp_path.iterdir()) == []  # nothing written unasked (issue 37)
    assert printed[-2].startswith("Verdict: all 5 requirements met: over 200 Monte Carlo runs")
    assert printed[-1].startswith("wrote no file (--out DIR")
    out = tmp_path / "results"
    assert main(["study", str(EXAMPLE), "--out", str(out), "--no-png"]) == 0
    assert [p.name for p in out.iterdir()] == ["multistatic_accuracy.md"]
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {out / 'multistatic_accuracy.md'}"
