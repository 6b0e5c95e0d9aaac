"""Public names of a package, imported from their modules when first used (PEP 562).

``from plotgate.core import EllipseGate`` must not import all of core: a replay of gate
tests alone would otherwise wait for every kernel, scipy.stats and scipy.optimize
(about a second). A package lists where each of its names lives; the module holding a
name is imported when the name is first looked up, and the value is then kept on the
package, so later lookups are plain attribute reads. Type checkers read the same names
from imports under ``if TYPE_CHECKING:`` (tests/core/test_exports.py holds the two lists
equal).
"""

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, modules: Mapping[str, tuple[str, ...]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package``, whose public names live in
    ``modules`` (module name -> the names it holds)."""
    home = {name: module for module, names in modules.items() for name in names}

    def __getattr__(name: str) -> Any:
        module = home.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(home))

    return __getattr__, __dir__
