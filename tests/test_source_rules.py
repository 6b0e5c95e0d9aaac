"""Rules read from the source (ast), over the package, the tests and the benchmarks.

- A name starting with ``_`` is private to its module: no module imports one from another
  (``from x import _y``, ``x._y`` on an imported module, or anything from a module
  ``_x``); a helper two modules need is a public name of a module of its own.
- Test modules import shared builders only from ``tests/support/``.
- Nothing imports the layers by their folder names (``core``, ``service``, ``clients``):
  they exist only as ``plotgate.core``, ``plotgate.service`` and ``plotgate.clients``.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("plotgate", "core", "service", "clients", "tests", "bench")
SOURCES = sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.py"))


DOCUMENTED = {"os._exit"}
"""Underscored names a library documents as public: ``os._exit``, the exit without cleanup
handlers (the ``os`` module's documentation), which the command line uses after a Ctrl-C."""


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _private_imports(tree: ast.Module) -> list[str]:
    found = []
    modules: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if any(_private(part) for part in (node.module or "").split(".")):
                found.append(f"line {node.lineno}: from {node.module} (a private module)")
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"line {node.lineno}: from {node.module} import {alias.name}")
                else:
                    modules.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                modules.add(alias.asname or alias.name.split(".")[0])
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
            and isinstance(node.value, ast.Name)
            and node.value.id in modules
            and f"{node.value.id}.{node.attr}" not in DOCUMENTED
        ):
            found.append(f"line {node.lineno}: {node.value.id}.{node.attr}")
    return found


def _folder_imports(tree: ast.Module) -> list[str]:
    layers = {"core", "service", "clients"}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] in layers:
                found.append(f"line {node.lineno}: from {node.module}")
        elif isinstance(node, ast.Import):
            found += [
                f"line {node.lineno}: import {a.name}"
                for a in node.names
                if a.name.split(".")[0] in layers
            ]
    return found


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_is_imported_from_another_module(path):
    assert _private_imports(ast.parse(path.read_text())) == []


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_layers_are_imported_by_their_installed_names(path):
    assert _folder_imports(ast.parse(path.read_text())) == []


def test_test_modules_have_unique_names():
    """pytest imports test modules by their base name (the test folders are not packages),
    so two ``test_x.py`` in different folders stop the whole run at collection."""
    names = [p.name for p in (ROOT / "tests").rglob("test_*.py") if "node_modules" not in p.parts]
    assert sorted(n for n in set(names) if names.count(n) > 1) == []


def _test_module_imports(tree: ast.Module) -> list[str]:
    """Imports of ``tests.*`` that reach anything but the shared builders of
    ``tests/support/``: another test module, or ``tests.conftest``."""
    found = []
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        found += [
            f"line {node.lineno}: {name}"
            for name in names
            if name.split(".")[0] == "tests" and not name.startswith("tests.support")
        ]
    return found


def test_tests_share_builders_only_through_tests_support():
    """Test modules form a tree, not a web: shared builders live in ``tests/support/``
    (fixtures in the ``conftest.py`` of the package that uses them), and no test module
    imports another test module or ``tests.conftest``."""
    found = {
        str(path.relative_to(ROOT)): bad
        for path in (ROOT / "tests").rglob("*.py")
        if "node_modules" not in path.parts
        and (bad := _test_module_imports(ast.parse(path.read_text())))
    }
    assert found == {}
