"""The table of operations: each operation declared once, and the table cheap to import.

An operation's name is a key in one place, its capability's declaration
(:mod:`plotgate.service.capabilities`); everything else reads the table. The count is of
string literals that are exactly a name (what code keys on), not of prose mentioning one.
"""

import ast
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

from plotgate.service.registry import OPERATIONS
from plotgate.service.table import ENDPOINTS

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ("core", "service", "clients", "plotgate")


def _files_naming() -> dict[str, set[str]]:
    """Each operation's name -> the package's files holding it as a string literal."""
    names = set(ENDPOINTS)
    found: dict[str, set[str]] = defaultdict(set)
    for folder in PACKAGE:
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Constant) and node.value in names:
                    found[node.value].add(str(path.relative_to(ROOT)))
    return found


def test_every_operation_name_is_a_string_in_at_most_two_files():
    found = _files_naming()
    assert set(found) == set(ENDPOINTS)
    crowded = {name: sorted(files) for name, files in found.items() if len(files) > 2}
    assert not crowded, crowded


def test_each_name_is_declared_in_its_capability():
    found = _files_naming()
    for name, endpoint in ENDPOINTS.items():
        declared = f"service/capabilities/{endpoint.tag}.py"
        assert declared in found[name], (name, found[name])


def test_the_table_imports_no_handler_core_fastapi_nor_foxglove():
    heavy = ["fastapi", "starlette", "numpy", "numba", "foxglove", "plotgate.core"]
    heavy += sorted({op.module for op in OPERATIONS.values()})
    code = (
        "import sys\n"
        "import plotgate.service.table\n"
        f"bad = [m for m in {heavy!r} if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr


def test_every_declaration_names_what_exists():
    for name, op in OPERATIONS.items():
        assert callable(op.handler) and isinstance(op.fields, dict), name
        drawer = op.endpoint.drawer
        assert drawer is not None and drawer.module.startswith("plotgate.service.scenes."), name
        assert op.endpoint.description and op.endpoint.example, name
