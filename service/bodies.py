"""Request bodies: received within a deadline, sized up before they are parsed.

A body is read from the ASGI ``receive`` channel with :func:`read_body`, which gives up
after ``deadline_s`` (:class:`BodyTimeout`, answered 408): a client that sends half a body
and stops does not hold the server for ever.

While it arrives, a body is sized up by a :class:`ShapeScan` against the operation's
:func:`value_ceiling`. Parsing JSON costs memory per *value*, not per byte: measured with
pydantic on this machine, a million empty objects (3 MB of body) cost about 380 MB before
validation could refuse them, a million zeros about 150 MB. So a body that holds more JSON
values than any valid request of its operation could hold, or a megabyte with no JSON
structure in it, is refused (:class:`BodyRefused`) as soon as the bytes received show it:
the rest is drained unread and nothing is built from any of it, whatever its size. The
count is an upper bound taken from the raw bytes (one value per comma, per opening bracket
or brace, plus the root): it never refuses a valid body, and it costs a few ``bytes.count``
calls per piece received. The same scan runs over a whole body in :func:`shape_problem`,
so an in-process replay of the received part refuses it the same way.
"""

import asyncio
import math
import re
from collections.abc import Awaitable, Callable, Iterator, MutableMapping
from functools import cache
from typing import Any

from pydantic import BaseModel
from pydantic_core import from_json

__all__ = [
    "MAX_BODY_VALUES",
    "SLICE_BYTES",
    "BodyRefused",
    "BodyTimeout",
    "ClientGone",
    "ShapeScan",
    "is_strict_json",
    "read_body",
    "shape_problem",
    "slices",
    "value_ceiling",
    "value_count",
]

MAX_BODY_VALUES = 3_000_000
"""Most JSON values one body may hold, whatever its operation's schema allows: 100,000
Cartesian plot pairs with their sensors hold 2.7 million. Parsing a body at this bound
costs at most about 450 MB (measured: about 150 bytes a value at worst)."""

SLICE_BYTES = 2**20
"""Large bodies are scanned a slice of this size per C call: a call over a whole 64 MiB body
would hold the interpreter (and so the event loop) for tens of milliseconds."""

Receive = Callable[[], Awaitable[MutableMapping[str, Any]]]


class BodyTimeout(Exception):
    """The body did not arrive within the deadline; ``received`` is what did."""

    def __init__(self, received: bytes, deadline_s: float) -> None:
        super().__init__(
            f"the body did not arrive within {deadline_s:g} s ({len(received)} bytes received)"
        )
        self.received = received
        self.deadline_s = deadline_s


class BodyRefused(Exception):
    """The bytes received show the body cannot be a valid request (``reason``); ``received``
    is the body up to the piece that showed it (the rest was drained unread), and
    ``drained`` says whether the whole body arrived within the deadline."""

    def __init__(self, received: bytes, reason: str, drained: bool) -> None:
        super().__init__(reason)
        self.received = received
        self.reason = reason
        self.drained = drained


class ClientGone(Exception):
    """The client disconnected before sending its whole body."""


class ShapeScan:
    """Sizes up a body from its bytes, fed piece by piece as they arrive.

    Two things cannot be in a valid request of at most ``ceiling`` JSON values: more values
    than that (:func:`value_count`'s bound, accumulated), and a run of more than
    :data:`SLICE_BYTES` bytes with no JSON structure (``, : [ ] { }``): no string, number or
    whitespace of a valid request is that long, and a parser would copy it whole. The
    reasons name no position, so the received part, scanned again, is refused alike.
    """

    def __init__(self, ceiling: int) -> None:
        self.ceiling = ceiling
        self.values = 1
        self.plain = 0  # bytes since the last structural character
        self.problem: str | None = None

    def feed(self, body: bytes) -> str | None:
        """Scan the next piece; the reason the body is refused, once there is one."""
        for piece in slices(body):
            if self.problem is not None:
                break
            self.values += value_count(piece) - 1
            first = _STRUCTURE.search(piece)
            if first is None:
                self.plain += len(piece)
            else:
                self.plain += first.start()
                if self.plain <= SLICE_BYTES:
                    self.plain = len(piece) - 1 - max(piece.rfind(c) for c in b",:[]{}")
            if self.values > self.ceiling:
                self.problem = f"holds more than {self.ceiling} JSON values; no valid request does"
            elif self.plain > SLICE_BYTES:
                self.problem = (
                    f"has more than {SLICE_BYTES} bytes without JSON structure; "
                    "no string, number or whitespace of a valid request is that "
                    "long"
                )
        return self.problem


async def read_body(receive: Receive, deadline_s: float, scan: ShapeScan | None = None) -> bytes:
    """The whole request body; :class:`BodyTimeout` after ``deadline_s`` seconds, and
    :class:`BodyRefused` once ``scan`` refuses what has arrived."""
    chunks: list[bytes] = []
    refused: str | None = None
    try:
        async with asyncio.timeout(deadline_s):
            while True:
                message = await receive()
                if message["type"] == "http.disconnect":
                    raise ClientGone
                if refused is None:
                    chunk = message.get("body", b"")
                    chunks.append(chunk)
                    if scan is not None:
                        refused = scan.feed(chunk)
                if not message.get("more_body", False):
                    break
    except TimeoutError:
        if refused is None:
            raise BodyTimeout(b"".join(chunks), deadline_s) from None
        raise BodyRefused(b"".join(chunks), refused, drained=False) from None
    if refused is not None:
        raise BodyRefused(b"".join(chunks), refused, drained=True)
    return chunks[0] if len(chunks) == 1 else b"".join(chunks)


def is_strict_json(body: bytes) -> bool:
    """True for a body that is one JSON value without NaN or Infinity tokens."""
    try:
        from_json(body, allow_inf_nan=False)
    except ValueError:
        return False
    return True


def slices(body: bytes) -> Iterator[bytes]:
    """``body`` in pieces of :data:`SLICE_BYTES` (each a copy made when it is taken)."""
    return (body[start : start + SLICE_BYTES] for start in range(0, len(body), SLICE_BYTES))


def shape_problem(body: bytes, ceiling: int) -> str | None:
    """Why ``body`` cannot be a valid request of at most ``ceiling`` JSON values, judged
    from its bytes alone (:class:`ShapeScan`); None when it may be one."""
    return ShapeScan(ceiling).feed(body)


_STRUCTURE = re.compile(rb"[,:\[\]{}]")


def value_count(body: bytes) -> int:
    """An upper bound on the number of JSON values in ``body``, from its bytes alone.

    In well-formed JSON every value but the root follows an opening bracket or brace, or a
    comma, so values <= 1 + commas + brackets + braces (counting those inside strings too
    only raises the bound).
    """
    count = 1
    for start in range(0, len(body), SLICE_BYTES):
        stop = start + SLICE_BYTES
        count += (
            body.count(b",", start, stop)
            + body.count(b"[", start, stop)
            + body.count(b"{", start, stop)
        )
    return count


@cache
def value_ceiling(model: type[BaseModel]) -> int:
    """The most JSON values a valid body of ``model`` can hold, at most
    :data:`MAX_BODY_VALUES`: every optional field present, every list at its longest."""
    schema = model.model_json_schema()
    return int(min(_values(schema, schema.get("$defs", {}), ()), MAX_BODY_VALUES))


def _values(node: dict[str, Any], defs: dict[str, Any], seen: tuple[str, ...]) -> float:
    """Most values under one JSON schema node; ``math.inf`` where nothing bounds them."""
    if "$ref" in node:
        name = node["$ref"].rsplit("/", 1)[-1]
        return math.inf if name in seen else _values(defs[name], defs, (*seen, name))
    for key in ("anyOf", "oneOf", "allOf"):
        if key in node:
            return max(_values(n, defs, seen) for n in node[key])
    kind = node.get("type")
    if kind == "object" or "properties" in node:
        extra = node.get("additionalProperties", True)
        if extra is not False:
            return math.inf
        return 1 + sum(_values(p, defs, seen) for p in node.get("properties", {}).values())
    if kind == "array":
        prefix = node.get("prefixItems", [])
        count = 1 + sum(_values(p, defs, seen) for p in prefix)
        items = node.get("items")
        if items is None or items is False:
            return count
        if "maxItems" not in node:
            return math.inf
        return count + (node["maxItems"] - len(prefix)) * _values(items, defs, seen)
    if kind is None and "const" not in node and "enum" not in node:
        return math.inf  # an untyped value: anything
    return 1
