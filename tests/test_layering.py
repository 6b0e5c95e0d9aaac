"""The layering, read from the source (an ast walk, so a lazy import inside a function
counts as much as one at the top): clients reach the service only through its wire
schemas and the table of operations, the service never imports the clients, the schemas
and the table import nothing of ours but the schemas, and core imports nothing of ours
outside core (DESIGN.md section 1)."""

import ast
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {"core": "plotgate.core", "service": "plotgate.service", "clients": "plotgate.clients"}
CLIENT_MAY_IMPORT = ("plotgate.service.schemas", "plotgate.service.table")
IN_PROCESS = Counter(
    {
        ("clients/commands/call.py", "plotgate.service.cluster"): 1,
        ("clients/commands/call.py", "plotgate.service.registry"): 1,
        ("clients/commands/kernels.py", "plotgate.service.kernels"): 1,
        ("clients/commands/kernels.py", "plotgate.service.registry"): 2,
        ("clients/commands/plot.py", "plotgate.service.cluster"): 1,
        ("clients/commands/replay.py", "plotgate.service.cluster"): 1,
        ("clients/commands/serve.py", "plotgate.service.config"): 1,
        ("clients/commands/serve.py", "plotgate.service.connections"): 1,
        ("clients/commands/serve.py", "plotgate.service.recording"): 1,
        ("clients/commands/serve.py", "plotgate.service.registry"): 1,
        ("clients/commands/study.py", "plotgate.service.cluster"): 1,
        ("clients/commands/view.py", "plotgate.service.scenes"): 1,
        ("clients/commands/where.py", "plotgate.service.cluster"): 1,
        ("clients/commands/where.py", "plotgate.service.config"): 1,
        ("clients/commands/where.py", "plotgate.service.registry"): 1,
        ("clients/commands/worker.py", "plotgate.service.cluster"): 1,
        ("clients/fleet.py", "plotgate.service.cluster"): 1,
        ("clients/listen.py", "plotgate.service.access"): 1,
        ("clients/replay.py", "plotgate.service"): 1,
        ("clients/replay.py", "plotgate.service.provenance"): 1,
        ("clients/replay.py", "plotgate.service.recording"): 2,
        ("clients/replay.py", "plotgate.service.registry"): 3,
        ("clients/runners.py", "plotgate.service.registry"): 1,
    }
)
"""The imports of service internals the commands that run the service in-process make
(``serve`` and its listener policy, ``call``, in-process replay, ``view``, the Dask
options of ``plot``, ``study`` and ``worker``): known, counted, and not to grow. A new
client import of the service goes through the schemas or the table."""


def _imports(layer: str) -> list[tuple[str, str]]:
    """(file, imported module) for every import of ``plotgate`` in ``layer``'s files."""
    found = []
    for path in sorted((ROOT / layer).rglob("*.py")):
        where = str(path.relative_to(ROOT))
        package = LAYERS[layer] + "." + ".".join(path.relative_to(ROOT / layer).parts[:-1])
        for node in ast.walk(ast.parse(path.read_text(), where)):
            if isinstance(node, ast.Import):
                found += [(where, a.name) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                module = node.module or ""
                if node.level:  # relative: resolve against the file's package
                    base = package.rstrip(".").split(".")
                    module = ".".join(base[: len(base) - node.level + 1] + [module]).rstrip(".")
                found.append((where, module))
    return [(where, m) for where, m in found if m == "plotgate" or m.startswith("plotgate.")]


def _within(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def test_core_imports_nothing_of_service_or_clients():
    bad = [(w, m) for w, m in _imports("core") if not _within(m, ("plotgate.core",))]
    assert not bad, bad


def test_the_service_never_imports_the_clients():
    bad = [(w, m) for w, m in _imports("service") if _within(m, ("plotgate.clients",))]
    assert not bad, bad


def test_schemas_and_the_table_import_only_schemas_of_ours():
    own = ("service/schemas/", "service/capabilities/", "service/table.py")
    allowed = ("plotgate.service.schemas", "plotgate.service.capabilities")
    bad = [(w, m) for w, m in _imports("service") if w.startswith(own) and not _within(m, allowed)]
    assert not bad, bad


def test_clients_reach_the_service_through_schemas_and_the_table():
    reached = Counter(
        (w, m)
        for w, m in _imports("clients")
        if _within(m, ("plotgate.service",)) and not _within(m, CLIENT_MAY_IMPORT)
    )
    new = reached - IN_PROCESS
    assert not new, f"clients import service internals: {dict(new)}"
