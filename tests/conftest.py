"""Shared fixtures: service settings on a temporary folder, the app, plots, the MCAP reader."""

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plotgate.service import registry
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from tests.support.requests import with_handler

READER = Path(__file__).resolve().parent / "interop"
"""The project's independent MCAP reader (Node, @mcap/core), pinned by its lockfile."""


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    return Settings(log_dir=tmp_path / "recordings", git_commit="test")


@pytest.fixture
def client(settings: Settings):
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def swap_handler(monkeypatch):
    """Swap an operation's handler in the registry for one test (a bug, a slow handler):
    ``swap_handler(name, handler)``."""

    def swap(name: str, handler) -> None:
        monkeypatch.setitem(registry.OPERATIONS, name, with_handler(name, handler))

    return swap


class McapReader:
    """Runs ``tests/interop/read.mjs`` (TypeScript MCAP library) on recordings."""

    def __init__(self, node: str) -> None:
        self.node = node

    def many(self, paths: list[Path], schemas: bool = False) -> tuple[int, list[dict]]:
        """Its exit status and one report per file.

        Node runs with V8's ``--single-threaded``: no background compile or GC tasks.
        Node 20's ``NodePlatform::DrainTasks`` can deadlock with a background TurboFan job
        waiting for a GC (nodejs/node#54918, fixed upstream after Node 20): seen here on a
        loaded machine, at exit and mid-way: 2 hung runs in 209 over 63 files, none in
        550 runs with the flag.
        """
        run = subprocess.run(
            [
                self.node,
                "--single-threaded",
                str(READER / "read.mjs"),
                *(["--schemas"] if schemas else []),
                *map(str, paths),
            ],
            capture_output=True,
            text=True,
            timeout=600,
        )
        reports = [json.loads(line) for line in run.stdout.splitlines()]
        assert run.returncode in (0, 1) and len(reports) == len(paths), run.stderr
        return run.returncode, reports

    def __call__(self, path: Path, schemas: bool = False) -> tuple[int, dict]:
        code, [report] = self.many([path], schemas)
        return code, report


@pytest.fixture(scope="session")
def interop_node() -> str:
    """Node, with tests/interop's packages installed (``npm ci`` once)."""
    node, npm = shutil.which("node"), shutil.which("npm")
    assert node and npm, "Node >= 18 (node and npm) is needed for tests/interop"
    installed = READER / "node_modules"
    wanted = json.loads((READER / "package.json").read_text())["dependencies"]
    if not all((installed / name).exists() for name in wanted):
        subprocess.run(
            [npm, "ci", "--no-audit", "--no-fund"],
            cwd=READER,
            check=True,
            capture_output=True,
            timeout=600,
        )
    return node


@pytest.fixture(scope="session")
def mcap_check(interop_node: str) -> McapReader:
    """The independent MCAP reader: ``mcap_check(path)`` is (0 if sound else 1, report)."""
    return McapReader(interop_node)


@pytest.fixture(scope="session")
def foxglove_check(interop_node: str):
    """Foxglove's schemas on a scene file: ``foxglove_check(path)`` is (0 when every
    protobuf message validates against @foxglove/schemas' JSON schema of its type, else 1,
    report) (tests/interop/scenes.mjs)."""

    def check(path: Path) -> tuple[int, dict]:
        run = subprocess.run(
            [interop_node, "--single-threaded", str(READER / "scenes.mjs"), str(path)],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert run.stdout, run.stderr
        return run.returncode, json.loads(run.stdout)

    return check
