"""Shared test builders: kernels."""

import importlib
import pkgutil

from numba.core.registry import CPUDispatcher

import plotgate.core


def compiled_kernels() -> dict[str, CPUDispatcher]:
    found = {}
    for info in pkgutil.walk_packages(plotgate.core.__path__, "plotgate.core."):
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == info.name:
                found[f"{info.name}.{name}"] = value
    return found
