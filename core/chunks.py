"""Heavy batch work cut into fixed chunks, run by any ``map``.

A Monte Carlo study, an evaluation or a curve is cut into chunks whose bounds depend on
the size of the work alone, never on how many workers run them, and every chunk is seeded
by what it covers (its runs' spawned seeds, or its slice of noise drawn once), so the
answer is the same bit for bit whatever runs the chunks: the builtin ``map`` in this
process, or a Dask client's (:func:`plotgate.service.cluster.mapper`), which core never
imports.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["Mapper", "mapped", "spans"]

Mapper = Callable[..., Iterable[Any]]
"""A ``map``: (function, items) -> the function's results in the items' order (the
builtin ``map``, or a cluster's, such as :func:`plotgate.service.cluster.mapper`)."""


def spans(total: int, size: int) -> list[tuple[int, int]]:
    """[start, stop) of each chunk of ``size`` items (the last one shorter) over ``total``.

    >>> spans(7, 3)
    [(0, 3), (3, 6), (6, 7)]
    """
    return [(start, min(start + size, total)) for start in range(0, total, size)]


def mapped(mapper: Mapper | None, function: Callable[[Any], Any], items: list[Any]) -> list[Any]:
    """``function`` over ``items`` by ``mapper`` (None: the builtin ``map``), in order."""
    return list((mapper or map)(function, items))
