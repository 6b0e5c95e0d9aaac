"""plotgate cat (exchanges as JSON lines) and inspect (files' time ranges, per-operation
counts), with their filters."""

import json
import time
from datetime import datetime

from fastapi.testclient import TestClient

from plotgate.clients.cli import main
from plotgate.service.app import create_app
from tests.support.requests import BAD_COV, GOOD

PAIR = {
    "passive_bearings_deg": [1.0, 1.1, 0.9, 1.0],
    "active_bearings_deg": [1.0, 1.05],
    "delta_deg": 0.5,
}


def _session(settings) -> float:
    """Four exchanges, the last two after the returned time (Unix seconds)."""
    with TestClient(create_app(settings)) as c:
        c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": "a"})
        c.post("/v1/gates/test", json=BAD_COV, headers={"x-request-id": "b"})
        time.sleep(0.05)
        middle = time.time()
        time.sleep(0.05)
        pretty = json.dumps(GOOD, indent=2).encode()  # newlines in the recorded body
        c.post(
            "/v1/gates/test",
            content=pretty,
            headers={"x-request-id": "c", "content-type": "application/json"},
        )
        c.post("/v1/identification/pair", json=PAIR, headers={"x-request-id": "d"})
    return middle


def test_cat_prints_each_exchange_as_one_json_line(settings, capsys):
    middle = _session(settings)
    capsys.readouterr()
    assert main(["cat", str(settings.log_dir)]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [x["request_id"] for x in lines] == ["a", "b", "c", "d"]
    by_id = {x["request_id"]: x for x in lines}
    assert by_id["a"]["request"]["body"] == GOOD and by_id["c"]["request"]["body"] == GOOD
    assert by_id["b"]["response"]["status"] == 422
    assert by_id["d"]["operation"] == "identification.pair"
    assert by_id["d"]["response"]["result"]["identified"] in (True, False)
    for x in lines:
        assert x["replay_of"] is None and x["file"].endswith(".mcap")
        assert abs(datetime.fromisoformat(x["time"]).timestamp() * 1e9 - x["log_time"]) < 1e4

    main(["cat", str(settings.log_dir), "--operation", "gates.test", "--since", str(middle)])
    assert [json.loads(line)["request_id"] for line in capsys.readouterr().out.splitlines()] == [
        "c"
    ]
    main(
        [
            "cat",
            str(settings.log_dir),
            "--until",
            datetime.fromtimestamp(middle).astimezone().isoformat(),
        ]
    )
    assert [json.loads(line)["request_id"] for line in capsys.readouterr().out.splitlines()] == [
        "a",
        "b",
    ]


def test_inspect_shows_time_ranges_and_filters(settings, capsys):
    middle = _session(settings)
    capsys.readouterr()
    assert main(["inspect", str(settings.log_dir), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    [f] = summary["files"]
    first = datetime.fromisoformat(f["first_time"]).timestamp()
    last = datetime.fromisoformat(f["last_time"]).timestamp()
    assert first < middle < last and f["complete"] and f["damage_count"] == 0
    ops = summary["operations"]
    assert ops["gates.test"]["requests"] == 3 and ops["gates.test"]["errors"] == {"422": 1}
    assert ops["identification.pair"]["responses"] == 1

    assert main(["inspect", str(settings.log_dir), "--since", str(middle)]) == 0
    out = capsys.readouterr().out
    assert f"{f['first_time']} to {f['last_time']}" in out  # each file's whole time range
    rows = {
        line.split()[0]: line.split()[1]
        for line in out.splitlines()
        if line.startswith(("gates.", "identification."))
    }
    assert rows == {"gates.test": "1", "identification.pair": "1"}
    assert (
        main(["inspect", str(settings.log_dir), "--operation", "identification.pair", "--json"])
        == 0
    )
    assert list(json.loads(capsys.readouterr().out)["operations"]) == ["identification.pair"]


def test_empty_and_foreign_files_are_noted_not_fatal(settings, capsys):
    """Empty files (a full disk's litter) and a file that is not MCAP beside a recording:
    cat and inspect read the recording, note the others, and exit 0; with nothing but
    such files there is no recording, exit 2."""
    _session(settings)
    folder = settings.log_dir
    (folder / "plotgate-29990101T000000.000000Z-pid1-0001.mcap").touch()
    (folder / "notes.mcap").write_text("not a recording\n")
    assert main(["cat", str(folder)]) == 0
    out, err = capsys.readouterr()
    assert len(out.splitlines()) == 4
    assert "is empty (0 bytes), not an MCAP file: skipped" in err and "notes.mcap is not" in err
    assert main(["inspect", str(folder)]) == 0
    out, err = capsys.readouterr()
    assert "is empty (0 bytes)" in out and "is empty (0 bytes)" in err
    assert main(["inspect", str(folder), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["recordings"], len(summary["skipped"])) == (1, 2)
    for recording in folder.glob("plotgate-2*.mcap"):
        if recording.stat().st_size:
            recording.unlink()
    assert main(["cat", str(folder)]) == 2
    assert f"plotgate cat: no MCAP recordings in {folder}" in capsys.readouterr().err
