"""The hostile corpus (tests/support/hostile.py) through inspect, replay, recover and cat.

Every file ends every command with a message and its contracted exit code, never a
traceback; a file cut short (as a killed writer leaves it) is reported unfinished, not
damaged; replay compares exactly the exchanges left intact (and never reports a change:
the damage must not pass for an answer); a file that is not MCAP is refused and left as it
is; the peak resident memory of each run stays bounded (VmHWM from /proc); and the
independent reader rejects every damaged or unfinished file and accepts the sound ones.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.registry import OPERATIONS, execute
from tests.support.hostile import corpus
from tests.support.requests import BAD_COV, GOOD

ROOT = Path(__file__).resolve().parents[2]
PEAK_MB = 400
"""Bound on any run's peak resident memory: the runner's own (numpy, scipy, the service's
models) plus what reading holds. Before the reader was bounded one file took 3.3 GB."""


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    from plotgate.service.config import Settings

    tmp = tmp_path_factory.mktemp("hostile")
    settings = Settings(log_dir=tmp / "sound", git_commit="test")
    with TestClient(create_app(settings)) as c:
        for i in range(6):
            body = BAD_COV if i == 4 else GOOD
            c.post("/v1/gates/test", json=body, headers={"x-request-id": f"s{i}"})
        c.post("/v1/gates/test", content=b'{"gate": ', headers={"x-request-id": "s6"})
    [sound] = settings.log_dir.glob("*.mcap")
    body = json.dumps(GOOD).encode()
    good = (body, 200, execute(OPERATIONS["gates.test"], body).content)
    files = tmp / "files"
    return files, corpus(sound.read_bytes(), good, files)


def test_the_corpus(hostile):
    _, expect = hostile
    assert len(expect) >= 50
    kinds = {name.split("-")[0] for name in expect}
    assert {"cut", "chunk", "bomb", "request", "response", "not"} <= kinds


def _run_all(jobs: list[list[str]], tmp_path: Path) -> list[dict]:
    spec = tmp_path / "jobs.json"
    spec.write_text(json.dumps(jobs))
    run = subprocess.run(
        [sys.executable, "-m", "tests.support.hostile", str(spec)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert run.returncode == 0, run.stderr[-5000:]
    return [json.loads(line) for line in run.stdout.splitlines()]


def test_every_command_ends_every_hostile_file_as_contracted(hostile, tmp_path):
    files, expect = hostile
    copies = tmp_path / "copies"
    copies.mkdir()
    jobs = []
    for name in expect:
        path = files / f"{name}.mcap"
        copy = copies / path.name
        shutil.copyfile(path, copy)
        report = tmp_path / f"{name}.json"
        jobs += [
            ["inspect", str(path)],
            ["cat", str(path)],
            ["replay", str(path), "--report", str(report)],
            ["recover", str(copy)],
        ]
    results = _run_all(jobs, tmp_path)
    assert len(results) == len(jobs)

    peak = max(r["peak_kb"] for r in results) / 1024
    print(f"peak resident memory over {len(results)} runs: {peak:.0f} MB")
    failures = []
    for r in results:
        command, path = r["args"][0], Path(r["args"][1])
        e = expect[path.stem]
        out = r["stdout"] + r["stderr"]
        problems = []
        if r["escaped"] or "Traceback" in out or "internal error" in out:
            problems.append(f"escaped: {r['escaped']} {out[-2000:]}")
        if r["peak_kb"] > PEAK_MB * 1024:
            problems.append(f"peak memory {r['peak_kb'] // 1024} MB")
        if not e.mcap:
            # replay names it once, on its report's line for the file (stdout); the others
            # on stderr
            said = out if command == "replay" else r["stderr"]
            if r["code"] != 2 or "not an MCAP file" not in said:
                problems.append(f"exit {r['code']}, stdout+stderr {out!r}")
            if command == "recover" and path.read_bytes() != (files / path.name).read_bytes():
                problems.append("recover touched a file that is not MCAP")
        elif command == "replay":
            report = json.loads(Path(r["args"][3]).read_text())
            if report["changed"] or report["compared"] != report["unchanged"]:
                problems.append(f"replay reported a change: {report['changes'][:3]}")
            if e.exchanges is not None and report["compared"] != e.exchanges:
                problems.append(f"compared {report['compared']}, intact {e.exchanges}")
            if r["code"] != (0 if report["compared"] else 2):
                problems.append(f"exit {r['code']} with {report['compared']} compared")
            damage = sum(f["damage_count"] for f in report["files"])
            if bool(damage) != e.damaged:
                problems.append(f"{damage} damaged records reported")
            [state] = [f["state"] for f in report["files"]]
            if e.unfinished is not None and (state == "unfinished") != e.unfinished:
                problems.append(f"its state is {state}")
        else:
            if r["code"] != 0:
                problems.append(f"exit {r['code']}: {r['stderr'][-500:]}")
            if e.damaged and "offset " not in out:
                problems.append("no damage reported with its offset")
            if command == "inspect" and e.unfinished is not None:
                if ("unfinished (no footer" in out) != e.unfinished:
                    problems.append(f"unfinished {e.unfinished}, but it says {out[:300]!r}")
                if not e.damaged and "damaged" in out:
                    problems.append(f"damage reported: {out[:300]!r}")
        if problems:
            failures.append(f"{command} {path.name}: {'; '.join(problems)}")
    assert not failures, "\n".join(failures[:40])


def test_the_independent_reader_rejects_every_hostile_file(hostile, mcap_check):
    files, expect = hostile
    names = list(expect)
    code, reports = mcap_check.many([files / f"{name}.mcap" for name in names])
    assert code == 1
    wrong = [
        (name, report["errors"])
        for name, report in zip(names, reports, strict=True)
        if report["ok"]
        != (expect[name].mcap and not expect[name].damaged and not expect[name].unfinished)
    ]
    assert not wrong, wrong[:10]


def test_what_recover_writes_from_any_of_them_is_sound(hostile, tmp_path, mcap_check):
    """recover keeps the intact plotgate records and drops the rest: the independent reader
    accepts every copy, and replay finds in it the exchanges the original holds intact."""
    from plotgate.clients.recordings import Reader
    from plotgate.clients.recover import recover

    files, expect = hostile
    outputs = {}
    for name, e in expect.items():
        if e.mcap:
            copy = tmp_path / f"{name}.mcap"
            shutil.copyfile(files / copy.name, copy)
            outputs[name] = recover(copy).output
    code, reports = mcap_check.many(list(outputs.values()))
    rejected = [(r["file"], r["errors"]) for r in reports if not r["ok"]]
    assert code == 0 and not rejected, rejected[:5]
    for name, out in outputs.items():
        if expect[name].exchanges is not None:
            answered = [ex for ex in Reader([out]) if ex.request and ex.response]
            assert len(answered) == expect[name].exchanges, name


@pytest.mark.parametrize("command", ["inspect", "cat", "replay", "recover"])
def test_a_fifo_socket_or_device_is_refused_at_once(command, tmp_path):
    """Readers open only regular files: a FIFO named *.mcap (given, or in a folder) blocked
    inspect, cat and replay forever, and recover called it "no such file"."""
    import socket

    fifo, sock, device = tmp_path / "fifo.mcap", tmp_path / "socket.mcap", tmp_path / "dev.mcap"
    os.mkfifo(fifo)
    server = socket.socket(socket.AF_UNIX)
    server.bind(str(sock))
    device.symlink_to("/dev/zero")
    folder = tmp_path / "folder"
    folder.mkdir()
    os.mkfifo(folder / "plotgate-x.mcap")
    paths = [fifo, sock, device] + ([] if command == "recover" else [folder])
    kinds = ["a FIFO", "a socket", "a character device", "a FIFO"]
    try:
        for path, kind in zip(paths, kinds, strict=False):
            run = subprocess.run(
                [sys.executable, "-m", "plotgate.clients.cli", command, str(path)],
                cwd=ROOT,
                capture_output=True,
                text=True,
                timeout=120,  # a hang, not a speed: the refusal takes well under a second
            )
            assert run.returncode == 2, (path, run.stdout, run.stderr)
            assert f"{kind}, not a regular file" in run.stderr, run.stderr
            assert "Traceback" not in run.stderr and len(run.stderr.splitlines()) == 1
    finally:
        server.close()
