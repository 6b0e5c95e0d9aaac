"""A file still being written reads as open, not as damage (issue 26, finding 5); one whose
writer is gone reads as unfinished; real damage in either is still damage."""

import json
import os
import subprocess
import sys
from pathlib import Path

import httpx

from plotgate.clients.cli import main
from plotgate.clients.live import writer_alive, writer_pid
from plotgate.clients.recordings import Reader
from tests.support.recordings import chunk_per_exchange
from tests.support.requests import GOOD
from tests.support.servers import serve

ROOT = Path(__file__).resolve().parents[2]


def _recorded(settings, n: int) -> bytes:
    """The bytes of a finished recording of ``n`` exchanges, one chunk per exchange."""
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    with TestClient(create_app(settings)) as c:
        for i in range(n):
            c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": f"r{i}"})
    [path] = settings.log_dir.glob("*.mcap")
    copy = settings.log_dir / "copy"
    copy.write_bytes(path.read_bytes())
    chunk_per_exchange(copy)  # the tests cut and damage chunks: one per exchange
    path.unlink()
    return copy.read_bytes()


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_the_writers_pid_in_the_name_decides(tmp_path):
    mine = tmp_path / f"plotgate-20261203T000000.000000Z-pid{os.getpid()}-0001.mcap"
    mine.write_bytes(b"x")
    assert writer_pid(mine) == os.getpid()
    assert not writer_alive(mine)  # this process exists, but does not have the file open
    with open(mine, "rb"):
        assert writer_alive(mine)
    gone = tmp_path / f"plotgate-20261203T000000.000000Z-pid{_dead_pid()}-0001.mcap"
    gone.write_bytes(b"x")
    assert not writer_alive(gone)
    for name in ("recording.mcap", "plotgate-x-pid0-1.mcap", "plotgate-pid12-1.mcap"):
        assert not writer_alive(tmp_path / name)


def test_a_file_being_written_is_open_and_not_damaged(settings, tmp_path, capsys):
    """Cut where a live writer may be (mid-record, between records): open while the
    writer holds it, unfinished once it is gone; never damage, exit 0."""
    data = _recorded(settings, 3)
    live = tmp_path / f"plotgate-20261203T000000.000000Z-pid{os.getpid()}-0001.mcap"
    for cut in (len(data) // 2, len(data) - 100, len(data) - 3):
        live.write_bytes(data[:cut])
        with open(live, "rb"):  # the writer: this process, holding the file
            reader = Reader(live)
            list(reader)
            assert reader.files[0].state == "open" and not reader.files[0].damage
            assert main(["inspect", str(live)]) == 0
            out = capsys.readouterr().out
            assert "open (still being written)" in out and "damaged" not in out
            assert main(["replay", str(live), "--allow-empty"]) == 0
            out = capsys.readouterr().out
            assert "open (still being written)" in out and "truncated" not in out
        reader = Reader(live)
        list(reader)
        assert reader.files[0].state == "unfinished" and not reader.files[0].damage


def test_real_damage_in_a_live_file_is_still_damage(settings, tmp_path, capsys):
    data = bytearray(_recorded(settings, 4))
    chunks, pos = [], 8
    while len(chunks) < 2:  # to the second chunk (the first holds the channels)
        chunks += [pos] if data[pos] == 6 else []
        pos += 9 + int.from_bytes(data[pos + 1 : pos + 9], "little")
    data[chunks[1] + 9 + 24] ^= 0xFF  # its CRC
    live = tmp_path / f"plotgate-20261203T000000.000000Z-pid{os.getpid()}-0001.mcap"
    live.write_bytes(bytes(data[: len(data) - 50]))
    with open(live, "rb"):
        assert main(["inspect", str(live), "--json"]) == 0
        [f] = json.loads(capsys.readouterr().out)["files"]
    assert f["state"] == "open" and f["damage_count"] == 1
    assert "CRC mismatch" in f["damage"][0]


def test_inspect_and_replay_on_a_running_servers_folder(tmp_path):
    """The newcomer's case: the folder of a server that is running."""
    folder = tmp_path / "recordings"
    with serve(folder) as (_, url), httpx.Client(base_url=url) as http:
        for _ in range(3):
            assert http.post("/v1/gates/test", json=GOOD).status_code == 200
        for command in (["inspect"], ["replay", "--allow-empty"]):
            run = subprocess.run(
                [sys.executable, "-m", "plotgate.clients.cli", *command, str(folder)],
                cwd=ROOT,
                capture_output=True,
                text=True,
                timeout=300,
            )
            assert run.returncode == 0, run.stderr
            assert "open (still being written)" in run.stdout, run.stdout
            for word in ("damaged", "truncated", "unfinished"):
                assert word not in run.stdout + run.stderr, run.stdout
