"""Shared fixtures: service settings on a temporary folder, the app, plots, the MCAP reader."""

import dataclasses
import io
import json
import shutil
import subprocess
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plotgate.service import registry
from plotgate.service.app import create_app
from plotgate.service.config import Settings

READER = Path(__file__).resolve().parent / "interop"
"""The project's independent MCAP reader (Node, @mcap/core), pinned by its lockfile."""


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    return Settings(log_dir=tmp_path / "recordings", git_commit="test")


@pytest.fixture
def client(settings: Settings):
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def with_handler(name: str, handler) -> registry.Operation:
    """A copy of the registry's operation ``name`` answering with ``handler`` (held where
    the registry keeps the handler it imports on first use)."""
    op = dataclasses.replace(registry.OPERATIONS[name])
    vars(op)["handler"] = handler
    return op


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


def cartesian(
    x: float, y: float, sxx: float = 100.0**2, syy: float = 100.0**2, sxy: float = 0.0
) -> dict:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[sxx, sxy], [sxy, syy]]}


def polar(r: float, az_deg: float, sigma_r: float = 200.0, sigma_az_deg: float = 0.5) -> dict:
    return {
        "frame": "polar",
        "r": r,
        "az_deg": az_deg,
        "sigma_r": sigma_r,
        "sigma_az_deg": sigma_az_deg,
    }


def answer(r) -> dict:
    """The JSON body of a 200 answer."""
    assert r.status_code == 200, r.text
    return r.json()


def invalid_input(r, field: str, status: int = 422) -> dict:
    """The problem body of an invalid-input answer that names ``field``."""
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["status"] == status and body["type"] == "urn:plotgate:problem:invalid-input"
    assert field in [e["field"] for e in body["errors"]], body
    assert field in body["detail"]
    return body


def chunk_per_exchange(path: Path) -> None:
    """Rewrite a recording with one LZ4 chunk per exchange (a flush after each response),
    as the recorder wrote files before compaction: the readers' tests of a damaged chunk
    need many small chunks, where a compacted file holds a megabyte per chunk."""
    from mcap.records import Channel, Message, Metadata, Schema
    from mcap.stream_reader import StreamReader
    from mcap.writer import CompressionType, Writer

    data = path.read_bytes()
    with open(path, "wb") as out:
        writer = Writer(out, compression=CompressionType.LZ4)
        writer.start(library="plotgate")
        for record in StreamReader(io.BytesIO(data)).records:
            if isinstance(record, Schema):
                writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel):
                writer.register_channel(
                    record.topic, record.message_encoding, record.schema_id, record.metadata
                )
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
            elif isinstance(record, Message):
                writer.add_message(
                    record.channel_id, record.log_time, record.data, record.publish_time
                )
                if b'"status": ' in record.data[:200]:
                    writer.flush()
        writer.finish()
