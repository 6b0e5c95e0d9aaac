"""Numbers read from a recording are checked once, in the reader, before any arithmetic.

A response whose ``duration_s`` is a 400-digit integer or ``1e308`` (both JSON, both within
the recorder's schema), or a message whose time is past an int64 of nanoseconds, is damage
reported with its offset: ``inspect``, ``cat``, ``replay`` and ``view`` keep the sound
exchanges and end as contracted. Before the check, ``inspect`` and ``view`` ended with
"internal error" (OverflowError) and ``inspect`` printed nan percentiles.
"""

import json
from pathlib import Path

import pytest

from plotgate.clients.cli import main
from plotgate.clients.messages import MAX_DURATION_S, check_messages
from plotgate.service.recording import request_record, response_record
from plotgate.service.registry import OPERATIONS, execute
from tests.support.recorded import OP, write_files
from tests.support.requests import GOOD

T0 = 1_700_000_000_000_000_000
HOSTILE = {
    "400-digit-integer": (10**400, T0),
    "1e308": (1e308, T0),
    "time-past-int64": (0.001, 2**64 - 1),
}


def _file(folder: Path, duration: float, t: int) -> Path:
    """One sound exchange, then one whose answer states ``duration`` at time ``t``."""
    body = json.dumps(GOOD).encode()
    answer = execute(OPERATIONS[OP], body)
    events = [
        (T0, "request", request_record("sound", OP, body)),
        (T0 + 1000, "response", response_record("sound", OP, 200, 0.002, answer.content)),
        (T0 + 2000, "request", request_record("hostile", OP, body)),
        (t, "response", response_record("hostile", OP, 200, duration, answer.content)),
    ]
    write_files(folder, events, set())
    [path] = folder.glob("*.mcap")
    return path


def test_a_duration_out_of_range_is_refused_by_the_one_check():
    for duration in (10**400, 1e308, MAX_DURATION_S * 2):
        data = response_record("x", OP, 200, duration, b"{}")
        [verdict] = check_messages([("response", OP, data)])
        assert isinstance(verdict, str) and "duration_s" in verdict
    [ok] = check_messages([("response", OP, response_record("x", OP, 200, 7, b"{}"))])
    assert not isinstance(ok, str) and ok.duration_s == 7.0


@pytest.mark.parametrize("name", HOSTILE)
def test_every_reader_reports_the_number_as_damage(name, tmp_path, capsys):
    path = _file(tmp_path / "rec", *HOSTILE[name])
    capsys.readouterr()

    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "internal error" not in text and "nan" not in text, text
    assert "1 damaged records skipped" in text and "offset " in text, text
    assert "never answered: 1" in text

    assert main(["cat", str(path)]) == 0
    out = capsys.readouterr()
    assert "internal error" not in out.err and "offset " in out.err, out.err
    assert [json.loads(line)["request_id"] for line in out.out.splitlines()] == [
        "sound",
        "hostile",
    ]

    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    tally = json.loads(report.read_text())
    assert (tally["compared"], tally["unchanged"], tally["changed"]) == (1, 1, 0)
    capsys.readouterr()

    view = tmp_path / "view.mcap"
    code = main(["view", str(path), "-o", str(view)])
    out = capsys.readouterr()
    assert code == 0 and "internal error" not in out.out + out.err, out.err
    assert view.stat().st_size > 0
