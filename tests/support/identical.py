"""Bit-for-bit equality of two answers of a chunked job (an evaluation, a study...)."""

import dataclasses

import numpy as np


def assert_identical(a, b, path: str = "") -> None:
    """``a`` and ``b`` equal bit for bit: dataclasses and dicts field by field, arrays by
    dtype, shape and every value (NaN equal to NaN where both have it)."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), path
        for f in dataclasses.fields(a):
            assert_identical(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            assert_identical(a[key], b[key], f"{path}[{key!r}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, path
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), path
    elif isinstance(a, float) and np.isnan(a):
        assert isinstance(b, float) and np.isnan(b), path
    else:
        assert a == b, path
