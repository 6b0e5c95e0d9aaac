"""The server answers while its kernels compile: ``/healthz`` at once, ``/readyz`` naming
the operations ready and those compiling, a request waiting for its operation's kernels
(which go first), and the console told how far the warm-up is."""

import subprocess
import sys
from pathlib import Path

from plotgate.service.warmup import kernel_names, warm_order

ROOT = Path(__file__).resolve().parents[2]

FAKE_CHILD = """
import json, os, sys, time
for line in sys.stdin:
    module = line.strip()
    if module.endswith(".probability"):  # held until the test has looked
        deadline = time.monotonic() + 120
        while not os.path.exists(sys.argv[1]) and time.monotonic() < deadline:
            time.sleep(0.05)
    print(json.dumps({"compiled": module + ".kernel"}), flush=True)
    time.sleep(0.3)
    print(json.dumps({"done": module}), flush=True)
"""

TRIAL = """
import sys, time
from fastapi.testclient import TestClient
from plotgate.service import registry, warmup
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.table import ENDPOINTS

flag = sys.argv[2]
warmup.CHILD = [sys.executable, "-c", sys.argv[1], flag]
warmup.PROGRESS_EVERY_S = 0.2
# the warm-up of the gate operations only: the trial imports no other part of core
warmup.OPERATIONS = {
    name: op for name, op in registry.OPERATIONS.items() if name.startswith("gates.")
}
warmup.MOST_USED = ("gates.test",)
with TestClient(create_app(Settings(record=False))) as c:
    assert c.get("/healthz").json() == {"status": "ok"}
    ready = c.get("/readyz").json()
    assert ready["status"] == "ready" and "gates.design" in ready["operations"]["compiling"]
    test = c.post("/v1/gates/test", json=ENDPOINTS["gates.test"].example)
    assert test.status_code == 200, test.text
    operations = c.get("/readyz").json()["operations"]
    assert "gates.test" in operations["ready"], operations
    assert "gates.design" in operations["compiling"], operations
    time.sleep(0.5)  # a progress line or two while the probabilities are held
    open(flag, "w").close()
    design = c.post("/v1/gates/design", json=ENDPOINTS["gates.design"].example)
    assert design.status_code == 200, design.text
    deadline = time.monotonic() + 120
    while c.get("/readyz").json()["operations"]["compiling"] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert c.get("/readyz").json()["operations"]["compiling"] == []
print("ok")
"""


def test_requests_wait_for_their_kernels_while_the_server_answers(tmp_path):
    run = subprocess.run(
        [sys.executable, "-c", TRIAL, FAKE_CHILD, str(tmp_path / "go")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stdout + run.stderr
    lines = [line for line in run.stderr.splitlines() if line.startswith("plotgate: ")]
    assert lines[0].startswith(f"plotgate: compiling {len(kernel_names())} numerical kernels")
    assert any(" of " in line and " compiled, " in line for line in lines[1:-1]), lines
    assert lines[-1].startswith("plotgate: every kernel ready in "), lines


def test_the_most_used_operations_compile_first():
    order = warm_order()
    assert order[0] == "plotgate.service.operations.gates"
    assert len(order) == len(set(order))


def test_the_kernels_counted_are_the_functions_core_compiles():
    """The kernels of the progress lines, read from the sources, are every compiled
    function of core (the test of :mod:`plotgate.core.compiled` finds them by import)."""
    import importlib

    import numpy as np
    from numba.core.registry import CPUDispatcher
    from numba.np.ufunc.dufunc import DUFunc

    from tests.support.kernels import compiled_kernels

    names = kernel_names()
    assert set(compiled_kernels()) <= names
    for name in names:
        module, function = name.rsplit(".", 1)
        value = getattr(importlib.import_module(module), function)
        assert isinstance(value, CPUDispatcher | DUFunc | np.ufunc), name
