"""The lazy public names of plotgate.core and plotgate.core.gates (PEP 562): each resolves
to its module's object, the lists the type checker reads (imports under TYPE_CHECKING)
and the lists read at run time are the same, and importing the package imports none of
its heavy modules."""

import ast
import importlib
import inspect
import subprocess
import sys

import pytest

PACKAGES = ["plotgate.core", "plotgate.core.gates"]


def _declared(package: str) -> tuple[dict[str, set[str]], set[str], dict[str, set[str]]]:
    """What the package's source declares: the names imported under TYPE_CHECKING (by
    module), those imported at run time, and the lazy table (by module)."""
    tree = ast.parse(inspect.getsource(importlib.import_module(package)))
    typed: dict[str, set[str]] = {}
    eager: set[str] = set()
    lazy: dict[str, set[str]] = {}
    for node in tree.body:
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom) and imp.module
                typed.setdefault(imp.module, set()).update(a.name for a in imp.names)
        elif isinstance(node, ast.ImportFrom) and node.module not in ("typing",):
            eager.update(a.name for a in node.names if a.name != "lazy_exports")
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            assert ast.unparse(node.targets[0]) == "(__getattr__, __dir__)"
            table = ast.literal_eval(node.value.args[1])
            lazy = {module: set(names) for module, names in table.items()}
    return typed, eager, lazy


@pytest.mark.parametrize("package", PACKAGES)
def test_the_typed_and_the_lazy_names_are_the_same(package):
    typed, eager, lazy = _declared(package)
    assert typed == lazy
    names = set().union(*lazy.values())
    assert not names & eager
    assert names | eager == set(importlib.import_module(package).__all__)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_is_its_module_s_object(package):
    _, _, lazy = _declared(package)
    module = importlib.import_module(package)
    for home, names in lazy.items():
        for name in names:
            assert getattr(module, name) is getattr(importlib.import_module(home), name)
    assert set(module.__all__) <= set(dir(module))
    with pytest.raises(AttributeError, match="no attribute 'gate_thershold'"):
        module.gate_thershold  # noqa: B018


def test_importing_core_imports_no_kernel_nor_scipy():
    code = (
        "import sys\n"
        "from plotgate.core import PlotgateError, gates\n"
        "heavy = [m for m in sys.modules if m.split('.')[0] in ('numba', 'scipy')]\n"
        "heavy += [m for m in sys.modules if m.startswith('plotgate.core.gates.')]\n"
        "assert not heavy, heavy\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
