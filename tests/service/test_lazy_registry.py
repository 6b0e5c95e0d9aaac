"""The registry imports an operation's handler, and its part of core, when it is first
used: a replay of gate tests starts without every kernel, scipy.stats or the other
operations, while the service imports every operation in its warm-up."""

import subprocess
import sys
from pathlib import Path

from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.registry import OPERATIONS
from plotgate.service.table import ENDPOINTS

ROOT = Path(__file__).resolve().parents[2]
GATE_MODULES = {"plotgate.service.operations.gates"}
OTHER_OPERATIONS = {op.module for op in OPERATIONS.values()} - GATE_MODULES
HEAVY = ["numba", "scipy.stats", "scipy.optimize", "plotgate.core.initiation"]


def _run(code: str) -> None:
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_importing_the_registry_imports_no_operation_nor_kernel():
    _run(
        "import sys\n"
        "import plotgate.service.registry\n"
        f"bad = [m for m in {[*HEAVY, 'scipy', *sorted(OTHER_OPERATIONS | GATE_MODULES)]!r}"
        " if m in sys.modules]\n"
        "assert not bad, bad\n"
    )


def test_a_replay_of_gate_tests_imports_no_other_operation(settings):
    with TestClient(create_app(settings)) as client:
        for i in range(3):
            body = ENDPOINTS["gates.test"].example
            r = client.post("/v1/gates/test", json=body, headers={"x-request-id": f"r{i}"})
            assert r.status_code == 200
    _run(
        "import sys\n"
        "from plotgate.clients.cli import main\n"
        f"assert main(['replay', {str(settings.log_dir)!r}]) == 0\n"
        f"assert {sorted(GATE_MODULES)!r}[0] in sys.modules\n"
        f"bad = [m for m in {[*HEAVY[1:], *sorted(OTHER_OPERATIONS)]!r} if m in sys.modules]\n"
        "assert not bad, bad\n"
    )


def test_the_service_imports_every_operation_in_its_warm_up():
    """The server answers at once and imports every operation meanwhile
    (:mod:`plotgate.service.warmup`); ``/readyz`` says when all are in."""
    _run(
        "import sys, time\n"
        "from fastapi.testclient import TestClient\n"
        "from plotgate.service.app import create_app\n"
        "from plotgate.service.config import Settings\n"
        "with TestClient(create_app(Settings(record=False))) as c:\n"
        "    deadline = time.monotonic() + 280\n"
        "    while c.get('/readyz').json()['operations']['compiling']:\n"
        "        assert time.monotonic() < deadline\n"
        "        time.sleep(0.1)\n"
        f"    missing = [m for m in {sorted(OTHER_OPERATIONS | GATE_MODULES)!r}"
        " if m not in sys.modules]\n"
        "assert not missing, missing\n"
    )


def test_every_operation_has_a_handler_and_a_field_map():
    assert set(ENDPOINTS) == set(OPERATIONS)
    for op in OPERATIONS.values():
        assert callable(op.handler) and isinstance(op.fields, dict), op.name
