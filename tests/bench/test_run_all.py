"""bench/run_all.py: the SUMMARY lines read, the front table rebuilt, the exit status, on
tiny fake benches (nothing here runs a real bench); and every bench of BENCHES takes
``--quick``."""

import json
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest

from bench import run_all
from bench.run_all import BEGIN, BENCHES, END, ROOT, Bench, Outcome, parse_summary

WHEN = datetime(2026, 12, 5, 8, 0, tzinfo=UTC)


def _line(row: str, met: bool | None = True, **fields: str) -> str:
    values = {"workload": "w", "peer": "p", "measured": "1.0x", "aim": ">= 1x"} | fields
    return "SUMMARY " + json.dumps({"row": row, **values, "met": met})


def test_summary_lines_are_read_in_order_and_the_rest_ignored():
    out = f"a table\n{_line('x.a')}\nSUMMARY-ish\n{_line('x.b', None)}\n"
    rows = parse_summary(out)
    assert [r["row"] for r in rows] == ["x.a", "x.b"] and rows[1]["met"] is None


@pytest.mark.parametrize(
    ("line", "why"),
    [
        ("SUMMARY {not json", "not JSON"),
        ('SUMMARY {"row": "x"}', "lacks or adds"),
        ("SUMMARY " + json.dumps({"row": "x", "workload": "", "peer": "", "measured": "",
                                  "aim": "", "met": "yes"}), "met is not"),
    ],
)  # fmt: skip
def test_a_malformed_summary_line_is_named(line, why):
    with pytest.raises(ValueError, match=why):
        parse_summary(line)


def _readme(tmp_path: Path, block: str = "") -> Path:
    readme = tmp_path / "README.md"
    readme.write_text(f"# Benchmarks\n\nabove\n\n{BEGIN}\n{block}\n{END}\n\nbelow\n")
    return readme


def _outcome(bench: Bench, *rows: dict[str, object]) -> Outcome:
    return Outcome(bench, list(rows), 1.0)


A = Bench("bench/bench_a.py", ("--size", "9"), ("--quick",), ("a.one", "a.two"))
B = Bench("bench/bench_b.py", (), ("--quick",), ("b.one",))


def test_the_block_is_rebuilt_in_bench_order_and_the_page_around_it_kept(tmp_path):
    readme = _readme(tmp_path, "old text")
    fresh = [json.loads(_line(r, measured="2 | 3")[8:]) for r in ("a.two", "a.one")]
    run_all.rewrite(readme, [A, B], [_outcome(A, *fresh)], WHEN)
    text = readme.read_text()
    assert text.startswith("# Benchmarks\n\nabove\n\n") and text.endswith(f"{END}\n\nbelow\n")
    assert "old text" not in text and "on 2026-12-05 08:00 UTC" in text
    rows = [line for line in text.splitlines() if line.startswith("| `")]
    assert rows[0].startswith("| `a.one` |") and rows[1].startswith("| `a.two` |")
    assert "| 2 \\| 3 |" in rows[0] and rows[0].endswith(
        "| yes | `python bench/bench_a.py --size 9` |"
    )


def test_rows_of_a_bench_not_run_are_kept_and_marked_with_their_run(tmp_path):
    readme = _readme(tmp_path)
    one = json.loads(_line("b.one", False)[8:])
    run_all.rewrite(readme, [A, B], [_outcome(B, one)], WHEN)
    hand = "| `a.one` | w | p | 0.9x (from issue 40's run) | >= 1x | **no** | `python x` |"
    readme.write_text(readme.read_text().replace(END, hand + "\n" + END))
    later = datetime(2026, 12, 6, tzinfo=UTC)
    run_all.rewrite(readme, [A, B], [_outcome(A, json.loads(_line("a.two")[8:]))], later)
    rows = [line for line in readme.read_text().splitlines() if line.startswith("| `")]
    assert [r.split(" | ")[0] for r in rows] == ["| `a.one`", "| `a.two`", "| `b.one`"]
    assert rows[0] == hand  # already says where it is from
    assert "1.0x (from the 2026-12-05 run) | >= 1x | **no** |" in rows[2]


def test_a_page_without_the_markers_is_refused(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# no markers\n")
    with pytest.raises(ValueError, match="no <!-- run_all:begin -->"):
        run_all.rewrite(readme, [A], [], WHEN)


def _fake(tmp_path: Path, name: str, body: str, rows: tuple[str, ...] = ("x",), **kw) -> Bench:
    script = tmp_path / "bench" / f"bench_{name}.py"
    script.parent.mkdir(exist_ok=True)
    script.write_text(
        "import json, sys, time\n"
        "quick = '--quick' in sys.argv\n"
        "def summary(row):\n"
        "    print('SUMMARY ' + json.dumps({'row': row, 'workload': 'w', 'peer': 'p',"
        " 'measured': 'quick' if quick else 'full', 'aim': 'a', 'met': None}))\n" + body
    )
    return Bench(f"bench/bench_{name}.py", (), ("--quick",), rows, **kw)


def _main(tmp_path, benches, *argv):
    readme = _readme(tmp_path)
    return run_all.main(list(argv), benches, tmp_path, readme), readme.read_text()


def test_full_runs_rewrite_the_table_and_exit_0(tmp_path, capsys):
    ok = _fake(tmp_path, "ok", "summary('ok.x')\n", ("ok.x",))
    status, text = _main(tmp_path, [ok])
    assert status == 0 and "| `ok.x` | w | p | full | a | — | `python bench/bench_ok.py` |" in text
    assert "[1/1] python bench/bench_ok.py ... 1 rows" in capsys.readouterr().out


def test_quick_runs_pass_quick_and_write_nothing(tmp_path, capsys):
    ok = _fake(tmp_path, "ok", "summary('ok.x')\n", ("ok.x",))
    status, text = _main(tmp_path, [ok], "--quick")
    assert status == 0 and "ok.x" not in text
    assert "ok.x: quick" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("body", "said"),
    [
        ("print('half', flush=True)\nsys.exit('boom: the bench broke')\n", "exited 1"),
        ("print('a table, no summary')\n", "printed no SUMMARY line"),
        ("print('SUMMARY {')\n", "a SUMMARY line is not JSON"),
        ("time.sleep(30)\n", "timed out after 1 s"),
    ],
)
def test_a_failing_bench_is_named_with_its_stderr_and_the_rest_still_run(
    tmp_path, capsys, body, said
):
    bad = _fake(tmp_path, "bad", body, timeout_s=1.0)
    ok = _fake(tmp_path, "ok", "summary('ok.x')\n", ("ok.x",))
    status, text = _main(tmp_path, [bad, ok], "--no-write")
    out, err = capsys.readouterr()
    assert status == 1 and "ok.x: full" in out and "Traceback" not in out + err
    assert f"FAILED bench/bench_bad.py: {said}" in err
    if "boom" in body:
        assert "boom: the bench broke" in err


def test_rows_printed_and_declared_differently_are_noted(tmp_path, capsys):
    ok = _fake(tmp_path, "ok", "summary('ok.new')\n", ("ok.x",))
    status, _ = _main(tmp_path, [ok], "--quick")
    out = capsys.readouterr().out
    assert status == 0 and "row ok.new is not among BENCHES' rows" in out
    assert "row ok.x not printed" in out


def test_only_runs_the_benches_named(tmp_path, capsys):
    a = _fake(tmp_path, "a", "summary('a.x')\n", ("a.x",))
    b = _fake(tmp_path, "b", "summary('b.x')\n", ("b.x",))
    status, _ = _main(tmp_path, [a, b], "--quick", "--only", "b")
    assert status == 0 and "bench_a" not in capsys.readouterr().out


def test_a_missing_table_is_an_error_not_a_traceback(tmp_path, capsys):
    ok = _fake(tmp_path, "ok", "summary('ok.x')\n", ("ok.x",))
    (tmp_path / "README.md").write_text("no markers\n")
    status = run_all.main([], [ok], tmp_path, tmp_path / "README.md")
    assert status == 1 and "the table was not rewritten" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["--only", "nosuch"], ["--quick", "--write"], ["--bogus"]])
def test_usage_errors_exit_2_without_a_traceback(argv):
    done = subprocess.run(
        [sys.executable, "bench/run_all.py", *argv], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr and done.stderr


def test_benches_and_rows_are_named_once():
    names = [b.name for b in BENCHES]
    rows = [r for b in BENCHES for r in b.rows]
    assert len(set(names)) == len(names) and len(set(rows)) == len(rows)


@pytest.mark.parametrize("bench", BENCHES, ids=lambda b: b.name)
def test_every_bench_exists_and_takes_quick(bench):
    assert (ROOT / bench.script).is_file()
    done = subprocess.run(
        [sys.executable, bench.script, "--help"], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert "--quick" in done.stdout


def test_a_bench_that_cannot_start_is_a_failure_not_a_traceback(tmp_path, monkeypatch):
    ok = _fake(tmp_path, "ok", "summary('ok.x')\n", ("ok.x",))
    monkeypatch.setattr(sys, "executable", str(tmp_path / "no-python"))
    outcome = run_all.run(ok, quick=True, root=tmp_path)
    assert outcome.failure is not None and outcome.failure.startswith("did not start:")
