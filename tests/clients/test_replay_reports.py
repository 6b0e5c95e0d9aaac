"""Replay's reports for CI: JUnit XML valid against the Ant/JUnitReport schema CI systems
read (test cases = exchanges compared, failures = changed), a Markdown summary, and an
HTML page that a real headless Chromium, with no network, shows the changed path in; and
the same reports from the serial replay and from ``--local-workers 2``."""

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from lxml import etree, html

from plotgate.clients.cli import main
from tests.support.gate_recordings import moved_recording

SCHEMA = Path(__file__).parent / "schemas" / "junit_ant.xsd"


@pytest.fixture
def moved(tmp_path: Path) -> Path:
    return moved_recording(tmp_path / "rec", exchanges=5, moved=1e-6)


def test_junit_validates_and_counts_exchanges_and_changes(moved, tmp_path):
    out = tmp_path / "junit.xml"
    assert main(["replay", str(moved), "--junit", str(out)]) == 1
    document = etree.parse(str(out))
    schema = etree.XMLSchema(etree.parse(str(SCHEMA)))
    assert schema.validate(document), schema.error_log
    cases = document.findall(".//testcase")
    failures = document.findall(".//testcase/failure")
    assert len(cases) == 5 and len(failures) == 1
    [suite] = document.findall("testsuite")
    assert (suite.get("name"), suite.get("tests"), suite.get("failures")) == (
        "gates.test",
        "5",
        "1",
    )
    message = failures[0].get("message")
    assert "statistic[1]" in message and "0.5" in message and "default" in message


def test_summary_markdown_counts_per_operation_and_first_differences(moved, tmp_path):
    out = tmp_path / "summary.md"
    assert main(["replay", str(moved), "--summary-md", str(out)]) == 1
    text = out.read_text()
    assert "| gates.test | 5 | 4 | 1 |" in text
    assert "| gates.test | r4 | statistic[1] |" in text


def test_a_report_path_that_is_a_folder_is_exit_2(moved, tmp_path, capsys):
    (tmp_path / "folder").mkdir()
    assert main(["replay", str(moved), "--junit", str(tmp_path / "folder")]) == 2
    assert "not a regular file" in capsys.readouterr().err


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _dump_dom(page: Path) -> str:
    """The page as headless Chromium renders it, in a network namespace of its own (no
    network at all) when ``unshare`` can make one, and told to resolve no host anyway."""
    command = [
        _chromium() or "chromium",
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--proxy-server=127.0.0.1:9",
        "--dump-dom",
        page.as_uri(),
    ]
    unshare = shutil.which("unshare")
    if unshare and subprocess.run([unshare, "-n", "true"], capture_output=True).returncode == 0:
        command = [unshare, "-n", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.mark.skipif(
    _chromium() is None, reason="chromium is not installed (apt-get install chromium)"
)
def test_html_shows_the_changed_path_in_headless_chromium_without_network(moved, tmp_path):
    page = tmp_path / "report.html"
    assert main(["replay", str(moved), "--html", str(page)]) == 1
    text = page.read_text()
    assert not any(what in text for what in ("src=", "href=", "url(", "<script"))
    tree = html.fromstring(_dump_dom(page))
    paths = [
        td.text_content() for td in tree.xpath('//table[@id="differences"]//td[@class="path"]')
    ]
    assert paths == ["statistic[1]"]
    assert tree.xpath("//svg//circle"), "the plot of relative differences has its point"


def test_serial_and_two_local_workers_give_identical_reports(moved, tmp_path):
    rules = tmp_path / "t.toml"
    rules.write_text('[[rule]]\nname = "thr"\npath = "threshold"\nrtol = 1e-5\n')
    outputs = {}
    for name, extra in (("serial", []), ("fleet", ["--local-workers", "2"])):
        folder = tmp_path / name
        folder.mkdir()
        argv = ["replay", str(moved), "--tolerances", str(rules)]
        for flag, file in (
            ("--report", "r.json"),
            ("--summary-md", "s.md"),
            ("--html", "p.html"),
            ("--junit", "j.xml"),
        ):
            argv += [flag, str(folder / file)]
        assert main(argv + extra) == 1
        outputs[name] = {
            p.name: re.sub(r'timestamp="[^"]*"', "", p.read_text()) for p in folder.iterdir()
        }
    assert outputs["serial"] == outputs["fleet"]
    report = json.loads(outputs["serial"]["r.json"])
    assert report["operations"] == {"gates.test": {"compared": 5, "changed": 1}}
