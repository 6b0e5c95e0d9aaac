"""The examples in the docstrings of the installed package run, and give what they show.

They run against ``plotgate.*`` as installed (pytest's ``--doctest-modules`` would import the
source files under their folder names, a second copy of every module).
"""

import doctest
import importlib
import pkgutil

import pytest

import plotgate.clients
import plotgate.core
import plotgate.service

MODULES = sorted(
    name
    for package in (plotgate.core, plotgate.service, plotgate.clients)
    for name in (
        package.__name__,
        *(m.name for m in pkgutil.walk_packages(package.__path__, package.__name__ + ".")),
    )
)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
