"""Replay against live servers: a folder replayed into itself, rotation under load, an
unreachable server, and the CLI's manners in a pipe."""

import json
import subprocess
import sys
import threading
from collections import Counter
from pathlib import Path

import httpx

from plotgate.clients.cli import main
from plotgate.clients.recordings import Reader, read_recording
from plotgate.clients.replay import REPLAYED_ORIGINAL
from tests.support.requests import BAD_COV, GOOD
from tests.support.servers import free_port, serve

ROOT = Path(__file__).resolve().parents[2]
PAIR = {
    "passive_bearings_deg": [1.0, 1.1, 0.9, 1.0],
    "active_bearings_deg": [1.0, 1.05],
    "delta_deg": 0.5,
}
BODIES = [json.dumps(GOOD).encode()] * 4 + [json.dumps(BAD_COV).encode(), b'{"gate": ']


def _tally(report: Path) -> tuple[int, int, int, int, dict[str, int]]:
    r = json.loads(report.read_text())
    return r["exchanges"], r["compared"], r["unchanged"], r["changed"], r["not_compared"]


def _sound(folder: Path, mcap_check) -> None:
    """Every file in the folder is sound for the independent reader."""
    code, reports = mcap_check.many(sorted(folder.glob("*.mcap")))
    assert code == 0, [r["errors"] for r in reports if not r["ok"]]


def test_a_folder_replayed_into_itself_twice(tmp_path, mcap_check):
    folder = tmp_path / "recordings"
    ids = [f"orig-{i}" for i in range(len(BODIES))]
    with serve(folder) as (_, url):
        with httpx.Client(base_url=url) as http:
            for rid, body in zip(ids, BODIES, strict=True):
                http.post(
                    "/v1/gates/test",
                    content=body,
                    headers={"x-request-id": rid, "content-type": "application/json"},
                )
        first, second = tmp_path / "first.json", tmp_path / "second.json"
        assert main(["replay", str(folder), "--server", url, "--report", str(first)]) == 0
        assert main(["replay", str(folder), "--server", url, "--report", str(second)]) == 0
    n = len(BODIES)
    assert _tally(first) == (n, n, n, 0, {})
    # the second time the folder also holds the first replay: each of those is a replay of
    # an original read before it, counted apart, not compared again
    assert _tally(second) == (2 * n, n, n, 0, {REPLAYED_ORIGINAL: n})

    exchanges = [ex for ex in Reader([folder]) if ex.request is not None]
    originals = [ex for ex in exchanges if ex.replay_of is None]
    replays = [ex for ex in exchanges if ex.replay_of is not None]
    assert sorted(ex.request_id for ex in originals) == sorted(ids)
    assert Counter(ex.replay_of for ex in replays) == {rid: 2 for rid in ids}
    assert not {ex.request_id for ex in replays} & set(ids)  # never under an original's id
    assert all(ex.response is not None for ex in exchanges)
    for ex in replays:
        original = next(o for o in originals if o.request_id == ex.replay_of)
        assert ex.response["status"] == original.response["status"]
    _sound(folder, mcap_check)


def test_rotation_under_load_hides_no_exchange(tmp_path, mcap_check):
    folder = tmp_path / "recordings"
    clients, each = 10, 200
    calls = [
        ("/v1/gates/test", json.dumps(GOOD).encode()),
        ("/v1/identification/pair", json.dumps(PAIR).encode()),
    ]  # slow: in a thread
    errors: list[str] = []

    def client(k: int, url: str) -> None:
        with httpx.Client(base_url=url, timeout=60) as http:
            for i in range(each):
                path, body = calls[i % 2]
                r = http.post(
                    path,
                    content=body,
                    headers={"content-type": "application/json", "x-request-id": f"c{k}-{i}"},
                )
                if r.status_code != 200:
                    errors.append(r.text)

    with serve(folder, env={"PLOTGATE_ROTATE_AGE_S": "0.05"}) as (_, url):
        threads = [threading.Thread(target=client, args=(k, url)) for k in range(clients)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=300)
    assert not errors
    files = sorted(folder.glob("*.mcap"))
    split = sum(1 for f in files for ex in read_recording(f).exchanges if ex.response is None)
    print(f"{len(files)} files, {split} answers recorded in a later file than their request")
    assert len(files) > 10 and split > 0  # answers did land in the file after their request
    _sound(folder, mcap_check)
    report = tmp_path / "report.json"
    assert main(["replay", str(folder), "--report", str(report)]) == 0
    assert _tally(report) == (clients * each, clients * each, clients * each, 0, {})

    # the CLI in a pipe that closes early ends quietly, with its own exit status
    for command in (
        ["cat", str(folder)],
        ["inspect", "--json", str(folder)],
        ["replay", str(folder), "--operation", "gates.test"],
    ):
        run = subprocess.run(
            [
                "bash",
                "-c",
                f'"{sys.executable}" -m clients.cli "$@" | head -c 100 > /dev/null; '
                'exit "${PIPESTATUS[0]}"',
                "pipe",
                *command,
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0 and run.stderr == "", (command, run.stderr[-2000:])


def test_an_unreachable_server_is_one_line_and_exit_2(settings, tmp_path, capsys):
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    with TestClient(create_app(settings)) as c:
        c.post("/v1/gates/test", json=GOOD)
    url = f"http://127.0.0.1:{free_port()}"
    capsys.readouterr()
    assert main(["replay", str(settings.log_dir), "--server", url]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"plotgate replay: cannot reach {url}/v1/gates/test")
    assert len(err.strip().splitlines()) == 1
    request = tmp_path / "request.json"
    request.write_text(json.dumps(GOOD))
    assert main(["call", "gates.test", str(request), "--server", url, "--backoff", "0"]) == 2
    err = capsys.readouterr().err
    assert f"gates.test at {url}: " in err and "(after 4 attempts)" in err
    assert len(err.strip().splitlines()) == 1
