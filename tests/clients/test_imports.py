"""The dependency rule: clients need only the wire schemas, and core needs only numpy/scipy."""

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    ("module", "forbidden"),
    [
        ("clients", ["fastapi", "starlette", "uvicorn", "core", "service.registry"]),
        ("service.schemas", ["fastapi", "core", "numpy"]),
        ("core", ["pydantic", "fastapi", "service", "clients", "mcap", "httpx"]),
    ],
)
def test_imports_flow_one_way(module, forbidden):
    code = (
        f"import sys, {module}\n"
        f"bad = [m for m in {forbidden!r} if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
