"""One naming for every compiled kernel and its reference: ``x`` and ``x_reference``.

Every compiled function of core (:func:`plotgate.core.compiled.kernel` or
:func:`~plotgate.core.compiled.rule`) is one of:

- a kernel ``x`` with its numpy reference ``x_reference`` beside it, in its module;
- a step of such a pair: called by the kernel ``x`` of a pair (a compiled ``x``, or the
  Python function ``x`` that runs compiled steps) or by a helper, directly or through
  other functions of core, so the pair's tests hold it to the reference;
- one of :data:`HELPERS`, each with why it has no reference of its own.

Every ``x_reference`` has its ``x`` in the same module, and no function keeps an old
style of naming a pair (``*_kernel``, ``numpy_*``, ``*_numpy``), but a reference whose
kernel is a method (:data:`METHOD_KERNELS`).
"""

import ast
import importlib
import inspect
import pkgutil
import re

import numpy as np
from numba.core.registry import CPUDispatcher

import plotgate.core

HELPERS = {
    "plotgate.core.gates.kernels.ellipse_test": "held to EllipseGate.test_reference",
    "plotgate.core.gates.kernels.combined_test": "held to CombinedGate.test_reference",
    "plotgate.core.gates.kernels.sector_test": "held to SectorGate.test_reference",
    "plotgate.core.gates.kernels.first_association_test": (
        "held to FirstAssociationGate.test_reference"
    ),
    "plotgate.core.gates.kernels.wrapped": "frames.wrap_finite on a scalar, in the gate tests",
    "plotgate.core.gates.kernels.stride": "an index step (1 or 0): no arithmetic to hold",
    "plotgate.core.gates.heading.interpolated_density": (
        "the density table's interpolation, held to prior_density_reference by the "
        "probability tests (a table has no numpy twin)"
    ),
    "plotgate.core.initiation.windows.window_pairs": (
        "PlotIndex.window's band search, held to near_windows_reference"
    ),
    "plotgate.core.initiation.windows.grown": (
        "an array doubled, the plots copied: no arithmetic to hold (the searches' tests grow it)"
    ),
    "plotgate.core.validation.first_invalid_covariance": (
        "as_covariance's one compiled pass; its numpy diagnosis is the reference"
    ),
    "plotgate.core.validation.is_valid_covariance": "the scalar test of the pass above",
}
"""Compiled functions without a reference of their own, and why (at most a dozen)."""

METHOD_KERNELS = {
    "plotgate.core.initiation.windows.near_windows_reference": (
        "PlotIndex.window's band search: a method, on the index's plots sorted once a scan"
    ),
}
"""References whose kernel is a method, not a function beside them."""

OLD_STYLES = re.compile(r"_kernel$|^_?numpy_|_numpy$")


def _modules():
    for info in pkgutil.walk_packages(plotgate.core.__path__, "plotgate.core."):
        yield importlib.import_module(info.name)


def _compiled(module) -> list[str]:
    defined = _defined(module)
    return [
        name
        for name, value in vars(module).items()
        if name in defined and isinstance(value, CPUDispatcher | np.ufunc)
    ]


def _defined(module) -> dict[str, ast.FunctionDef]:
    tree = ast.parse(inspect.getsource(module))
    return {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}


def _callees(function: ast.AST) -> set[str]:
    """Names a function calls, plain or as an attribute (``self._search``)."""
    names = set()
    for node in ast.walk(function):
        if isinstance(node, ast.Call):
            f = node.func
            names.add(f.id if isinstance(f, ast.Name) else getattr(f, "attr", ""))
    return names


def _core():
    """Per module: its functions (and methods) by name, its compiled functions."""
    found = {}
    for module in _modules():
        tree = ast.parse(inspect.getsource(module))
        functions: dict[str, list[ast.AST]] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                functions.setdefault(node.name, []).append(node)
        found[module.__name__] = (functions, _compiled(module))
    return found


def _reached_from_pairs(core) -> set[str]:
    """Every function name called, directly or through others, by a pair's kernel or a
    helper (a helper's steps are held where the helper is)."""
    by_name: dict[str, list[ast.AST]] = {}
    for functions, _ in core.values():
        for name, nodes in functions.items():
            by_name.setdefault(name, []).extend(nodes)
    stack = [
        name
        for functions, _ in core.values()
        for name in functions
        if f"{name}_reference" in functions
    ] + [helper.rsplit(".", 1)[1] for helper in HELPERS]
    reached: set[str] = set()
    while stack:
        name = stack.pop()
        for node in by_name.get(name, []):
            for callee in _callees(node) - reached:
                if callee in by_name and not callee.endswith("_reference"):
                    reached.add(callee)
                    stack.append(callee)
    return reached


def test_every_compiled_function_pairs_with_a_reference_or_is_a_step_or_a_helper():
    core = _core()
    reached = _reached_from_pairs(core)
    unpaired = [
        f"{module}.{name}"
        for module, (functions, compiled) in core.items()
        for name in compiled
        if f"{name}_reference" not in functions
        and name not in reached
        and f"{module}.{name}" not in HELPERS
    ]
    assert not unpaired, f"compiled without x_reference, not a step, not a helper: {unpaired}"
    assert sum(len(c) for _, c in core.values()) > 50  # the walk finds the kernels


def test_every_reference_has_its_kernel_beside_it():
    lonely = [
        f"{module}.{name}"
        for module, (functions, _) in _core().items()
        for name in functions
        if name.endswith("_reference")
        and name.removesuffix("_reference") not in functions
        and f"{module}.{name}" not in METHOD_KERNELS
    ]
    assert not lonely, f"x_reference without x in its module: {lonely}"


def test_no_pair_is_named_in_an_old_style():
    old = [
        f"{module}.{name}"
        for module, (functions, _) in _core().items()
        for name in functions
        if OLD_STYLES.search(name)
    ]
    assert not old, f"name a pair x and x_reference: {old}"


def test_the_helpers_are_few_and_real():
    core = _core()
    compiled = {f"{m}.{name}" for m, (_, c) in core.items() for name in c}
    assert len(HELPERS) <= 12
    assert set(HELPERS) <= compiled, set(HELPERS) - compiled
