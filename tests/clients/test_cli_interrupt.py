"""A clustered ``plotgate call`` is quiet. Ctrl-C, as a terminal sends it (SIGINT to the
whole process group, the Dask worker processes included): every time exit 130, one line on
stderr, no traceback, no warning, no worker left behind. And a call that runs to its end
says nothing on stderr, with Dask's default dashboard port 8787 taken."""

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

WORKERS = 2
HANG_S = 60.0
"""Detects a hang; the exit itself takes well under a second once the workers run."""
BODY = {"runs": 1000, "seed": 2, "scenario": {"clutter": 250}, "config": {"mode": "polar"}}
"""Minutes of Monte Carlo on two workers: still running when the interrupt comes."""


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue  # gone meanwhile
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _alive(pids: list[int]) -> list[int]:
    alive = []
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.append(pid)
    return alive


def _interrupted_run(body: Path) -> tuple[int | None, str, list[int], int]:
    """Start a clustered call, wait for its workers, press Ctrl-C every half second until
    it ends (one lands while the workers start, where it is lost, now and then): (exit
    status, stderr, worker processes still alive after it ended, Ctrl-Cs sent)."""
    command = [sys.executable, "-m", "plotgate", "call", "initiation.evaluate", str(body)]
    proc = subprocess.Popen(
        [*command, "--local-workers", str(WORKERS)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own group, like a terminal's foreground job
    )
    try:
        deadline = time.monotonic() + HANG_S
        workers: list[int] = []
        while len(workers) < WORKERS and time.monotonic() < deadline:
            time.sleep(0.2)
            workers = [c for c in _children(proc.pid) if "spawn_main" in _command(c)]
        presses = 0
        while proc.poll() is None and time.monotonic() < deadline:
            os.killpg(proc.pid, signal.SIGINT)
            presses += 1
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=0.5)
        _, err = proc.communicate(timeout=HANG_S)
        time.sleep(0.5)
        return proc.returncode, err.decode(), _alive(workers), presses
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()


def _command(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
    except OSError:
        return ""


@pytest.mark.slow
def test_ctrl_c_in_five_clustered_calls_is_quiet_and_exits_130(tmp_path):
    body = tmp_path / "evaluate.json"
    body.write_text(json.dumps(BODY))
    runs = [_interrupted_run(body) for _ in range(5)]
    for code, err, left, presses in runs:
        assert code == 130, err
        assert err == "plotgate: interrupted\n", f"after {presses} Ctrl-C: {err}"
        assert left == []
    stderr = "".join(err for _, err, _, _ in runs)
    assert stderr.count("Traceback") == 0 and stderr.lower().count("warn") == 0


@pytest.mark.slow
def test_a_clustered_call_says_nothing_on_stderr_with_port_8787_taken(tmp_path):
    body = tmp_path / "evaluate.json"
    body.write_text(json.dumps({**BODY, "runs": 8, "scenario": {"clutter": 20}}))
    with contextlib.ExitStack() as stack:
        taken = stack.enter_context(socket.socket())
        with contextlib.suppress(OSError):  # already taken by someone else: as good
            taken.bind(("127.0.0.1", 8787))
            taken.listen()
        done = subprocess.run(
            [sys.executable, "-m", "plotgate", "call", "initiation.evaluate", str(body)]
            + ["--local-workers", str(WORKERS)],
            capture_output=True,
            timeout=HANG_S * 2,
        )
    assert done.returncode == 0 and done.stderr.decode() == ""
    assert json.loads(done.stdout)["runs"] == 8
