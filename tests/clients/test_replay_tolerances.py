"""Per-field tolerances (``plotgate replay --tolerances``): a number moved by 1e-6 relative
is CHANGED by default, passes under a rule of rtol = 1e-5 for its path, and still fails
under a rule for another path; the report names the rule; a bad file is exit 2 with one
line naming the rule; the shipped file is valid."""

import json
from pathlib import Path

import pytest

from plotgate.clients.cli import main
from plotgate.clients.compare import diff
from plotgate.clients.replay import replay
from plotgate.clients.tolerances import (
    DEFAULT,
    Rules,
    ToleranceFileError,
    load_rules,
)
from plotgate.service.table import ENDPOINTS
from tests.support.gate_recordings import moved_recording, rules_file

ROOT = Path(__file__).resolve().parents[2]

THIS_PATH = """
[[rule]]
name = "gate statistic"
operation = "gates.*"
path = "statistic[*]"
rtol = 1e-5
reason = "the test's own"
"""
OTHER_PATH = """
[[rule]]
name = "threshold"
operation = "gates.test"
path = "threshold"
rtol = 1e-5
"""


@pytest.fixture
def moved(tmp_path: Path) -> Path:
    return moved_recording(tmp_path / "rec", moved=1e-6)


def test_a_number_moved_by_1e_6_is_changed_by_default(moved, capsys):
    assert main(["replay", str(moved)]) == 1
    assert "CHANGED gates.test r3 statistic[1]" in capsys.readouterr().out


def test_a_rule_of_rtol_1e_5_for_its_path_passes_it(moved, tmp_path, capsys):
    rules = rules_file(tmp_path / "t.toml", THIS_PATH)
    assert main(["replay", str(moved), "--tolerances", str(rules)]) == 0
    assert "4 compared: 4 unchanged, 0 changed" in capsys.readouterr().out


def test_a_rule_for_another_path_still_fails_and_the_report_names_what_judged(
    moved, tmp_path, capsys
):
    rules = rules_file(tmp_path / "t.toml", OTHER_PATH)
    report_path = tmp_path / "r.json"
    code = main(["replay", str(moved), "--tolerances", str(rules), "--report", str(report_path)])
    assert code == 1
    [change] = json.loads(report_path.read_text())["changes"]
    assert (change["field"], change["rule"]) == ("statistic[1]", DEFAULT)


def test_a_tighter_rule_names_itself_in_the_report(moved, tmp_path):
    rules = load_rules(
        rules_file(tmp_path / "t.toml", THIS_PATH.replace("1e-5", "1e-7")), 1e-3, 0.0
    )
    report = replay(moved, progress=False, rtol=1e-3, rules=rules)
    assert report.changed == 1 and report.changes[0].rule == "gate statistic"
    assert replay(moved, progress=False, rtol=1e-3).changed == 0  # the global one passes it


def test_ignore_and_decision(moved, tmp_path):
    ignore = '[[rule]]\noperation = "gates.test"\npath = "statistic"\nignore = true\n'
    rules = load_rules(rules_file(tmp_path / "i.toml", ignore), 1e-9, 1e-12)
    assert replay(moved, progress=False, rules=rules).changed == 0
    decision = '[[rule]]\npath = "statistic[*]"\ndecision = true\n'
    rules = load_rules(rules_file(tmp_path / "d.toml", decision), 1e-3, 1e-3)
    assert replay(moved, progress=False, rtol=1e-3, atol=1e-3, rules=rules).changed == 1


def test_the_most_specific_rule_wins():
    from plotgate.clients.tolerances import Rule, segments

    loose = Rule("loose", "*", "*", rtol=1.0, parts=segments("*"))
    tight = Rule("tight", "gates.test", "a[*].b", rtol=0.0, parts=segments("a[*].b"))
    middle = Rule("middle", "gates.*", "a", rtol=0.5, parts=segments("a"))
    rules = Rules([loose, tight, middle], 1e-9, 0.0)
    assert rules.at("gates.test", "a[3].b").rule == "tight"
    assert rules.at("gates.test", "a[3].c").rule == "middle"
    assert rules.at("gates.pairs", "a[0].b").rule == "middle"
    assert rules.at("solves.position", "a").rule == "loose"
    assert rules.at("solves.position", "").rule == DEFAULT


def test_rules_judge_lists_of_numbers_as_arrays():
    from plotgate.clients.tolerances import Rule, segments

    rule = Rule("m", "*", "m[*][*]", rtol=1e-3, parts=segments("m[*][*]"))
    fields = Rules([rule], 1e-12, 0.0).for_operation("x")
    a = {"m": [[1.0, 2.0], [3.0, 4.0]], "v": [1.0, 2.0]}
    b = {"m": [[1.0001, 2.0], [3.0, 4.0]], "v": [1.0, 2.0001]}
    assert [d[0] for d in diff(a, b, 1e-12, 0.0, rules=fields)] == ["v[1]"]


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ('[[rule]]\nname = "x"\npath = "a"\nrtol = -1\n', "rule 1 ('x'): rtol"),
        ('[[rule]]\npath = "a"\nrtol = 1e-3\n[[rule]]\npath = "a..b"\nrtol = 1\n', "rule 2"),
        ('[[rule]]\npath = "a"\nrtol = 1e-3\nignore = true\n', "rule 1: sets"),
        ('[[rule]]\npath = "a"\nrtlo = 1e-3\n', "rule 1: unknown key 'rtlo'"),
        ('[[rule]]\noperation = "gate.tset"\npath = "a"\natol = 1\n', "matches no operation"),
        ('[[rule]]\npath = "a"\n', "rule 1: sets none"),
        ("[[rule]\n", "not TOML"),
    ],
)
def test_a_bad_file_is_exit_2_with_one_line_naming_the_rule(moved, tmp_path, capsys, text, named):
    rules = rules_file(tmp_path / "bad.toml", text)
    assert main(["replay", str(moved), "--tolerances", str(rules)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err and "bad.toml" in err, err


def test_the_shipped_tolerance_file_is_valid():
    rules = load_rules(ROOT / "docs" / "replay_tolerances.toml", 1e-9, 1e-12, ENDPOINTS)
    assert rules.rules and all(rule.reason for rule in rules.rules)


def test_a_missing_file_is_a_tolerance_file_error(tmp_path):
    with pytest.raises(ToleranceFileError, match="cannot be read"):
        load_rules(tmp_path / "none.toml", 1e-9, 0.0)
