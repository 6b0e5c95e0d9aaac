"""Compare a recorded JSON answer with a replayed one: every field that differs, in one pass.

Replay compares thousands of answers a second, most of them hundreds of numbers long, so the
walk over the two trees touches each dict and list once, and a list of numbers (or a list of
equally long lists of numbers: a covariance, a matrix of positions) is compared as one
numpy array with ``numpy.isclose(rtol, atol)``, never one Python call per element.

What it reports is fixed (a regression gate's report must not move with its speed): a
field's path (``a.b[3]``, ``a.length`` when two lists differ in length), the recorded value
and the replayed one; keys in sorted order, a key on one side only as ``<missing>`` on the
other; at most :data:`FIELDS_PER_EXCHANGE` elements of one list of numbers; ints and floats
are numbers, compared within the tolerances, while a bool is not one and is compared exactly
(``true`` equals ``1`` as in Python, but not ``1.0000001``); NaN is never close to anything,
itself included. ``tests/clients/test_compare.py``
holds :func:`diff` to the field-by-field walk it replaced on generated trees.

Given ``rules`` (:class:`plotgate.clients.tolerances.OperationRules`), each field is
judged by the rule its path resolves to: a list of numbers still as one array, with the
tolerances of its items' path (``a[*]``, ``a[*][*]``); a field a rule ignores is not walked.
Without them nothing is looked up, and the walk is what it was.
"""

import math
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from plotgate.clients.tolerances import OperationRules

__all__ = ["FIELDS_PER_EXCHANGE", "MISSING", "diff", "is_number"]

MISSING = "<missing>"
"""The value reported for a key that one side lacks."""
FIELDS_PER_EXCHANGE = 10
"""Differing fields reported per changed exchange (and per list of numbers)."""

_NUMBER_TYPES = frozenset((int, float))
_SCALAR_TYPES = frozenset((int, float, str, bool, type(None)))


def diff(
    a: Any,
    b: Any,
    rtol: float,
    atol: float,
    path: str = "",
    rules: "OperationRules | None" = None,
) -> Iterator[tuple[str, Any, Any]]:
    """Yield (field path, recorded, replayed) for every difference between two JSON trees
    (``rules``: per-field tolerances, over ``rtol`` and ``atol``)."""
    if rules is not None:
        judged = rules.at(path)
        if judged.ignore:
            return
        rtol, atol = judged.rtol, judged.atol
    if isinstance(a, dict) and isinstance(b, dict):
        yield from _dicts(a, b, rtol, atol, path, rules)
    elif isinstance(a, list) and isinstance(b, list):
        yield from _lists(a, b, rtol, atol, path, rules)
    elif is_number(a) and is_number(b):
        if not _close(a, b, rtol, atol) and a != b:
            yield path, a, b
    elif a != b:
        yield path, a, b


def _dicts(
    a: dict[Any, Any],
    b: dict[Any, Any],
    rtol: float,
    atol: float,
    path: str,
    rules: "OperationRules | None",
) -> Iterator[tuple[str, Any, Any]]:
    keys = a.keys() if a.keys() == b.keys() else a.keys() | b.keys()
    for key in sorted(keys):
        sub = f"{path}.{key}" if path else key
        if key not in a or key not in b:
            if rules is None or not rules.at(sub).ignore:
                yield sub, a.get(key, MISSING), b.get(key, MISSING)
        elif not _equal_scalars(a[key], b[key]):
            yield from diff(a[key], b[key], rtol, atol, sub, rules)


def _lists(
    a: list[Any],
    b: list[Any],
    rtol: float,
    atol: float,
    path: str,
    rules: "OperationRules | None",
) -> Iterator[tuple[str, Any, Any]]:
    if len(a) != len(b):
        yield f"{path}.length", len(a), len(b)
        return
    arrays = _numbers(a, b) or _matrices(a, b)
    if arrays is None:
        for i in _unequal(a, b):
            yield from diff(a[i], b[i], rtol, atol, f"{path}[{i}]", rules)
        return
    x, y = arrays
    if rules is not None:
        judged = rules.at(path + "[*]" * x.ndim)
        if judged.ignore:
            return
        rtol, atol = judged.rtol, judged.atol
    far = ~np.isclose(x, y, rtol, atol)
    if x.ndim == 1:
        for i in np.flatnonzero(far)[:FIELDS_PER_EXCHANGE].tolist():
            yield f"{path}[{i}]", a[i], b[i]
        return
    # A matrix is reported as its rows would be one by one: the first few of each row.
    rows, cols = np.nonzero(far)
    rank = np.arange(rows.size) - np.searchsorted(rows, rows)
    keep = rank < FIELDS_PER_EXCHANGE
    for i, j in zip(rows[keep].tolist(), cols[keep].tolist(), strict=True):
        yield f"{path}[{i}][{j}]", a[i][j], b[i][j]


def _unequal(a: list[Any], b: list[Any]) -> Iterable[int]:
    """The indices where two equally long lists may differ: for lists of plain scalars
    (strings, bools, None, numbers) those whose values are unequal, found in one
    comprehension (equal scalars have no difference); for anything else, every index."""
    if set(map(type, a)) <= _SCALAR_TYPES and set(map(type, b)) <= _SCALAR_TYPES:
        return [i for i, (u, v) in enumerate(zip(a, b, strict=True)) if u != v]
    return range(len(a))


def _equal_scalars(u: Any, v: Any) -> bool:
    """Whether two plain scalars are equal (then they have no difference). Containers are
    always walked: Python's ``==`` on them takes a shared NaN as equal to itself."""
    return type(u) in _SCALAR_TYPES and type(v) in _SCALAR_TYPES and u == v


def _numbers(a: list[Any], b: list[Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """Two lists of numbers (the first not empty) as float arrays; None when they are not,
    or when a number does not fit a double (those are compared one by one)."""
    if not (a and _all_numbers(a) and _all_numbers(b)):
        return None
    x, y = _floats(a), _floats(b)
    return None if x is None or y is None else (x, y)


def _matrices(a: list[Any], b: list[Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """Two lists of lists of numbers, every row of both as long as every other, as 2-D
    float arrays; None otherwise (the rows are then compared one by one)."""
    if not a or not all(isinstance(row, list) and _all_numbers(row) for row in (*a, *b)):
        return None
    x, y = _floats(a), _floats(b)
    if x is None or y is None or x.ndim != 2 or x.shape != y.shape:
        return None
    return x, y


def _all_numbers(values: list[Any]) -> bool:
    """Whether every value is a number: a set of types for what a JSON parser gives
    (ints and floats), the per-value check only for anything else (a bool, a subclass)."""
    return set(map(type, values)) <= _NUMBER_TYPES or all(map(is_number, values))


def is_number(x: Any) -> bool:
    """Whether a JSON value is a number (an int or a float, never a bool)."""
    return isinstance(x, int | float) and not isinstance(x, bool)


def _floats(values: list[Any]) -> np.ndarray | None:
    """JSON numbers (a list, or equally long lists) as floats; None when one does not fit a
    double or the rows are ragged."""
    try:
        return np.asarray(values, float)
    except (OverflowError, ValueError, TypeError):
        return None


def _close(a: int | float, b: int | float, rtol: float, atol: float) -> bool:
    """``numpy.isclose`` for two numbers, without building arrays: ``|a - b| <= atol + rtol
    |b|`` for a finite ``b``, or equal; False when one does not fit a double."""
    try:
        x, y = float(a), float(b)
    except OverflowError:
        return False
    return x == y or (math.isfinite(y) and abs(x - y) <= atol + rtol * abs(y))
