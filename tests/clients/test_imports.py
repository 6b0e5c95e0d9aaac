"""The dependency rule: clients need only the wire schemas, and core needs only numpy/scipy."""

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    ("module", "forbidden"),
    [
        (
            "plotgate.clients",
            ["fastapi", "starlette", "uvicorn", "plotgate.core", "plotgate.service.registry"],
        ),
        ("plotgate.service.schemas", ["fastapi", "plotgate.core", "numpy"]),
        (
            "plotgate.core",
            ["pydantic", "fastapi", "plotgate.service", "plotgate.clients", "mcap", "httpx"],
        ),
    ],
)
def test_imports_flow_one_way(module, forbidden):
    # every submodule: plotgate.core imports its own lazily (plotgate.core.exports)
    code = (
        f"import importlib, pkgutil, sys, {module}\n"
        f"for m in pkgutil.walk_packages({module}.__path__, '{module}.'):\n"
        "    importlib.import_module(m.name)\n"
        f"bad = [m for m in {forbidden!r} if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
