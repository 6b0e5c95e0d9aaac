"""Rules over several fields of a request, shared by the schema modules.

A model validator collects the errors of its rules, each a (location, reason, value)
triple with the location relative to the model, and hands them to
:func:`raise_errors`, which answers 422 naming every offending field: exactly one of
two alternatives (:func:`one_of`), a list of the length another field sets
(:func:`length`), and one dimension, 2D or 3D, for every position and velocity of a
request (:func:`dimension`).
"""

from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from plotgate.service.schemas.common import Loc, invalid

__all__ = ["dimension", "dotted", "length", "one_of", "raise_errors"]


def one_of(obj: Any, a: str, b: str, what: str) -> list[tuple[Loc, str, Any]]:
    """Errors unless exactly one of the fields ``a`` and ``b`` is given."""
    if (getattr(obj, a) is None) == (getattr(obj, b) is None):
        reason = f"give exactly one of {a} and {b} ({what})"
        return [((a,), reason, getattr(obj, a)), ((b,), reason, getattr(obj, b))]
    return []


def length(loc: Loc, value: Sequence[Any] | None, n: int, of: str) -> list[tuple[Loc, str, Any]]:
    """An error unless ``value`` (when given) has ``n`` entries, one per ``of``."""
    if value is not None and len(value) != n:
        return [(loc, f"must have {n} entries, one per {of}; got {len(value)}", len(value))]
    return []


def dimension(
    sizes: Iterable[set[int]], points: Callable[[], Iterator[tuple[Loc, Sequence[float]]]]
) -> list[tuple[Loc, str, Any]]:
    """An error at the first vector whose length differs from most vectors' length.

    ``sizes`` are the vector lengths found in each part of the request (a cheap pass);
    only when they differ are the vectors walked with their locations (``points``). The
    request's dimension is that of most of its positions and velocities (of the first
    one on a tie), so the odd one out is the field named.
    """
    if len(set().union(*sizes)) < 2:
        return []
    vectors = list(points())
    lengths = [len(v) for _, v in vectors]
    d = max(dict.fromkeys(lengths), key=lengths.count)
    example = next(loc for loc, v in vectors if len(v) == d)
    loc, point = next((loc, v) for loc, v in vectors if len(v) != d)
    return [
        (
            loc,
            f"has {len(point)} coordinates, but the request is {d}D (as "
            f"{dotted(example)}): every position and velocity of a request must be 2D, "
            f"or every one 3D",
            list(point),
        )
    ]


def dotted(loc: Loc) -> str:
    """A location as a request path: ``("receivers", 1, "x")`` is ``receivers[1].x``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def raise_errors(model: Any, errors: list[tuple[Loc, str, Any]]) -> None:
    """Raise the errors found in ``model`` as one validation error (422), if any.

    Each error is (location in the model, reason, offending value); the answer names
    every location.
    """
    if errors:
        raise invalid(type(model).__name__, errors)
