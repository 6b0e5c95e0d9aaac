"""The one-pass comparison of answers reports exactly what the field-by-field walk it
replaced reported: :func:`diff_reference` below is that walk, as it was in
plotgate.clients.replay, held against :func:`plotgate.clients.compare.diff` on generated
trees (NaN and None, ints against floats, bools, ragged lists, matrices, nested dicts, type
changes, missing and extra keys, ints too large for a double)."""

import copy
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from plotgate.clients.compare import FIELDS_PER_EXCHANGE, MISSING, diff


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _floats(values: list[Any]) -> np.ndarray | None:
    try:
        return np.asarray(values, float)
    except (OverflowError, ValueError, TypeError):
        return None


def diff_reference(
    a: Any, b: Any, rtol: float, atol: float, path: str = ""
) -> Iterator[tuple[str, Any, Any]]:
    """The field-by-field walk of plotgate 0.2.0: one Python call per element."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(a.keys() | b.keys()):
            sub = f"{path}.{key}" if path else key
            if key not in a or key not in b:
                yield sub, a.get(key, MISSING), b.get(key, MISSING)
            else:
                yield from diff_reference(a[key], b[key], rtol, atol, sub)
    elif isinstance(a, list) and isinstance(b, list):
        numbers = a and all(map(_is_number, a)) and all(map(_is_number, b))
        x = _floats(a) if numbers else None
        y = _floats(b) if numbers else None
        if len(a) != len(b):
            yield f"{path}.length", len(a), len(b)
        elif x is not None and y is not None:
            for i in np.flatnonzero(~np.isclose(x, y, rtol, atol))[:FIELDS_PER_EXCHANGE]:
                yield f"{path}[{i}]", a[i], b[i]
        else:
            for i, (u, v) in enumerate(zip(a, b, strict=True)):
                yield from diff_reference(u, v, rtol, atol, f"{path}[{i}]")
    elif _is_number(a) and _is_number(b):
        x, y = _floats([a]), _floats([b])
        if x is None or y is None or not np.isclose(x[0], y[0], rtol, atol):
            if a != b:
                yield path, a, b
    elif a != b:
        yield path, a, b


TOLERANCES = [(1e-9, 1e-12), (0.0, 0.0), (1e-3, 1e-6), (0.5, 0.0), (0.0, 1.0)]

DOUBLES = st.one_of(
    st.integers(-3, 3),
    st.sampled_from([0.0, -0.0, 1.0, 1.0 + 1e-12, 1e-13, 1e300, -1e300, 2**53 + 1]),
    st.floats(allow_nan=True, allow_infinity=True),
)
"""Numbers that fit a double (lists of them are compared as arrays)."""
NUMBERS = st.one_of(DOUBLES, st.integers(-(10**400), 10**400))
LEAVES = st.one_of(NUMBERS, st.booleans(), st.none(), st.sampled_from(["", "a", "b"]))
VECTORS = st.lists(st.one_of(DOUBLES, DOUBLES, DOUBLES, NUMBERS), max_size=24)
MATRICES = st.integers(0, 14).flatmap(
    lambda m: st.lists(st.lists(DOUBLES, min_size=m, max_size=m), max_size=4)
)
EDGES = st.sampled_from(
    [0, 1, -1, 0.0, 1.0, 1.0 + 1e-10, 1e-13, math.inf, -math.inf, math.nan, 10**400, True]
)
TREES = st.recursive(
    st.one_of(LEAVES, VECTORS, MATRICES),
    lambda kids: st.one_of(
        st.lists(kids, max_size=5), st.dictionaries(st.sampled_from("abcde"), kids, max_size=5)
    ),
    max_leaves=40,
)


def _nudge(x: Any, draw: Any) -> Any:
    """A number changed a little, a lot, or into something else."""
    how = draw(st.integers(0, 6))
    if how == 0:
        return x
    if how == 1 and isinstance(x, float):
        return x * (1 + draw(st.sampled_from([1e-15, 1e-10, 1e-6, 1e-2])))
    if how == 2 and isinstance(x, bool):
        return not x
    if how == 2 and isinstance(x, int | float):
        return x + 1
    if how == 3:
        return float(x) if isinstance(x, int) and abs(x) < 2**1000 else x
    return draw(LEAVES)


def _mutate(tree: Any, draw: Any) -> Any:
    """A copy of ``tree`` with some leaves nudged, keys dropped or added, lists shortened,
    lengthened or turned into other types."""
    roll = draw(st.integers(0, 9))
    if roll == 0:
        return draw(TREES)
    if isinstance(tree, dict):
        out = {k: _mutate(v, draw) for k, v in tree.items() if draw(st.integers(0, 7))}
        if roll == 1:
            out[draw(st.sampled_from("abcdef"))] = draw(LEAVES)
        return out
    if isinstance(tree, list):
        out = [_mutate(v, draw) for v in tree]
        if roll == 1 and out:
            out.pop(draw(st.integers(0, len(out) - 1)))
        elif roll == 2:
            out.append(draw(LEAVES))
        return out
    return _nudge(tree, draw)


@settings(max_examples=700, deadline=None, derandomize=True)
@given(data=st.data(), tolerance=st.sampled_from(TOLERANCES))
def test_diff_reports_what_the_reference_reports(data, tolerance):
    a = data.draw(TREES)
    b = _mutate(copy.deepcopy(a), data.draw)
    rtol, atol = tolerance
    assert list(diff(a, b, rtol, atol)) == list(diff_reference(a, b, rtol, atol))


def _moved(x: Any, step: int) -> Any:
    """A number moved by a step that keeps it a number: none, a relative 1e-10 or 1e-2,
    or one."""
    if step == 1:
        return x * (1 + 1e-10) if isinstance(x, float) else x
    if step == 2:
        return x * 1.01 if isinstance(x, float) else x
    return x + 1 if step == 3 else x


@settings(max_examples=300, deadline=None, derandomize=True)
@given(
    a=st.one_of(st.lists(DOUBLES, max_size=24), VECTORS, MATRICES),
    data=st.data(),
    tolerance=st.sampled_from(TOLERANCES),
)
def test_arrays_report_what_the_reference_reports(a, data, tolerance):
    steps = st.integers(0, 3)
    if a and isinstance(a[0], list):
        b = [[_moved(x, data.draw(steps)) for x in row] for row in a]
    else:
        b = [_moved(x, data.draw(steps)) for x in a]
    rtol, atol = tolerance
    assert list(diff(a, b, rtol, atol)) == list(diff_reference(a, b, rtol, atol))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(a=TREES, b=TREES)
def test_unrelated_trees_are_reported_alike(a, b):
    assert list(diff(a, b, 1e-9, 1e-12)) == list(diff_reference(a, b, 1e-9, 1e-12))


@settings(max_examples=500, deadline=None, derandomize=True)
@given(
    a=st.one_of(EDGES, NUMBERS), b=st.one_of(EDGES, NUMBERS), tolerance=st.sampled_from(TOLERANCES)
)
def test_numbers_are_close_as_numpy_says(a, b, tolerance):
    rtol, atol = tolerance
    for x, y in ((a, b), ([a, 0], [b, 0]), ([[a]], [[b]])):
        assert list(diff(x, y, rtol, atol)) == list(diff_reference(x, y, rtol, atol))


def test_a_shared_nan_is_still_a_change():
    """Python's == takes a list holding one NaN object as equal to itself; the walk does not."""
    shared = [math.nan]
    tree = {"x": shared, "y": [shared, shared]}
    assert list(diff(tree, tree, 1e-9, 1e-12)) == list(diff_reference(tree, tree, 1e-9, 1e-12))
    assert [path for path, *_ in diff(tree, tree, 1e-9, 1e-12)] == ["x[0]", "y[0][0]", "y[1][0]"]


def test_a_matrix_reports_the_first_few_of_each_row():
    a = [[0.0] * 30 for _ in range(3)]
    b = [[1.0] * 30, [0.0] * 30, [0.0] * 29 + [1.0]]
    found = list(diff(a, b, 0, 0, "m"))
    assert found == list(diff_reference(a, b, 0, 0, "m"))
    assert [p for p, *_ in found] == [f"m[0][{j}]" for j in range(10)] + ["m[2][29]"]


def test_lists_of_other_number_types_fall_back_to_the_walk():
    """Subclasses (numpy scalars, IntEnum) are numbers to the check by isinstance."""
    a = [np.float64(1.0), np.float64(2.0), 3]
    b = [np.float64(1.0), np.float64(2.5), True]
    assert list(diff(a, b, 1e-9, 1e-12)) == list(diff_reference(a, b, 1e-9, 1e-12))
