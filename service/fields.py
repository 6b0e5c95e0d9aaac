"""Where in a request a core error points: a table declared next to each operation.

core raises its errors naming its own arguments (``l``, ``tx``, ``x0``) and, for a batch, the
index of the offending row (:class:`plotgate.core.PlotgateError`); the client must read the
path of the value it sent (``problems[3].range_sums``). Each operation declares that
mapping as data, a :data:`FieldMap` from core argument to request path template, resolved
here by one function for every operation:

- ``{i}`` is the error's batch index; when the error has none, the path stops before the
  first ``[{i}]`` (``problems[{i}].range_sums`` names ``problems``);
- ``a|b`` is a field that comes in two forms, of which a request sends one
  (``transmitter|transmitters``): the one the request holds is named;
- ``*`` is the template of every argument the table does not list; without it such an
  argument is named as it is (core's name is then the request's, e.g. ``alpha``);
- a value that is a function ``(request, error) -> path`` covers what a template cannot
  (which side of a pair a gate argument came from), and stays beside the table.

>>> from types import SimpleNamespace
>>> from plotgate.core import ParameterError
>>> request = SimpleNamespace(problems=[SimpleNamespace(transmitter=None, transmitters=[])])
>>> table = {"l": "problems[{i}].range_sums", "tx": "problems[{i}].transmitter|transmitters"}
>>> resolve(table, request, ParameterError("tx", "coincides with a receiver", 0))
'problems[0].transmitters'
>>> resolve(table, request, ParameterError("l", "is negative"))
'problems'
>>> resolve(table, request, ParameterError("alpha", "must be in (0, 1)"))
'alpha'
"""

import re
from collections.abc import Callable, Mapping
from typing import Any

from plotgate.core import PlotgateError

__all__ = ["FieldMap", "resolve"]

FieldMap = Mapping[str, "str | Callable[[Any, PlotgateError], str]"]
"""Core argument -> request path template (or a function of the request and the error)."""

_STEP = re.compile(r"\.?([^.\[]+)|\[(\{i\}|\d+)\]")


def resolve(table: FieldMap, request: Any, exc: PlotgateError) -> str:
    """The request path ``table`` gives for core's error ``exc`` on ``request``."""
    entry = table.get(exc.field, table.get("*", exc.field))
    if callable(entry):
        return entry(request, exc)
    path, node = "", request
    for name, index in _STEP.findall(entry):
        if index:
            if index == "{i}":
                if exc.index is None:
                    break
                index = str(exc.index)
            path += f"[{index}]"
            node = _item(node, int(index))
            continue
        choices = name.split("|")
        name = next((c for c in choices if _attribute(node, c) is not None), choices[0])
        path += f".{name}" if path else name
        node = _attribute(node, name)
    return path


def _attribute(node: Any, name: str) -> Any:
    return getattr(node, name, None) if node is not None else None


def _item(node: Any, index: int) -> Any:
    try:
        return node[index]
    except (TypeError, IndexError, KeyError):
        return None
