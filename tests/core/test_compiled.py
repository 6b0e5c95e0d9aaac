"""Every compiled kernel in core is compiled when its module is imported, and cached."""

import importlib
import pkgutil

from numba.core.registry import CPUDispatcher

import plotgate.core


def _kernels() -> dict[str, CPUDispatcher]:
    found = {}
    for info in pkgutil.walk_packages(plotgate.core.__path__, "plotgate.core."):
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == info.name:
                found[f"{info.name}.{name}"] = value
    return found


def test_the_kernels_are_found():
    assert "plotgate.core.initiation.search._grid_counts" in _kernels()


def test_every_kernel_is_compiled_at_import_and_cached_on_disk():
    for name, dispatcher in _kernels().items():
        assert dispatcher.signatures, f"{name} compiles on its first call, not at import"
        assert type(dispatcher._cache).__name__ == "FunctionCache", f"{name} is not cached"
