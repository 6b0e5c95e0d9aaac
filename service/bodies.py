"""Request bodies: received within a deadline, sized up before they are parsed.

A body is read from the ASGI ``receive`` channel with :func:`read_body`, which gives up
after ``deadline_s`` (:class:`BodyTimeout`, answered 408): a client that sends half a body
and stops does not hold the server for ever.

Before a body is parsed it is sized up with :func:`value_count` against the operation's
:func:`value_ceiling`. Parsing JSON costs memory per *value*, not per byte: measured with
pydantic on this machine, a million empty objects (3 MB of body) cost about 380 MB before
validation could refuse them, a million zeros about 150 MB. So a body that holds more JSON
values than any valid request of its operation could hold is refused before anything is
built from it, whatever its size in bytes. The count is an upper bound taken from the raw
bytes (one value per comma, per opening bracket or brace, plus the root): it never refuses
a valid body, and it costs a few ``bytes.count`` passes, cut into slices so a large body
never holds the interpreter for long.
"""

import asyncio
import math
import re
from collections.abc import Awaitable, Callable, Iterator, MutableMapping
from functools import cache
from typing import Any

from pydantic import BaseModel
from pydantic_core import from_json

__all__ = ["MAX_BODY_VALUES", "SLICE_BYTES", "BodyTimeout", "ClientGone", "is_strict_json",
           "read_body", "shape_problem", "slices", "value_ceiling", "value_count"]

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
        super().__init__(f"the body did not arrive within {deadline_s:g} s "
                         f"({len(received)} bytes received)")
        self.received = received
        self.deadline_s = deadline_s


class ClientGone(Exception):
    """The client disconnected before sending its whole body."""


async def read_body(receive: Receive, deadline_s: float) -> bytes:
    """The whole request body, or :class:`BodyTimeout` after ``deadline_s`` seconds."""
    chunks: list[bytes] = []
    try:
        async with asyncio.timeout(deadline_s):
            while True:
                message = await receive()
                if message["type"] == "http.disconnect":
                    raise ClientGone
                chunks.append(message.get("body", b""))
                if not message.get("more_body", False):
                    break
    except TimeoutError:
        raise BodyTimeout(b"".join(chunks), deadline_s) from None
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
    return (body[start:start + SLICE_BYTES] for start in range(0, len(body), SLICE_BYTES))


def shape_problem(body: bytes, ceiling: int) -> str | None:
    """Why ``body`` cannot be a valid request whose values are at most ``ceiling``, judged
    from its bytes alone; None when it may be.

    Two things are refused: more values than ``ceiling`` (:func:`value_count`), and a run of
    :data:`SLICE_BYTES` with no JSON structure in it (no ``, : [ ] { }``): no string, number
    or whitespace of a valid request is that long, and a parser would copy it whole.
    """
    values = value_count(body)
    if values > ceiling:
        return f"holds up to {values} JSON values; a valid request holds at most {ceiling}"
    for index, piece in enumerate(slices(body)):
        if len(piece) == SLICE_BYTES and _STRUCTURE.search(piece) is None:
            return (f"has no JSON structure in bytes {index * SLICE_BYTES} to "
                    f"{(index + 1) * SLICE_BYTES}: no value of a valid request is that long")
    return None


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
        count += (body.count(b",", start, stop) + body.count(b"[", start, stop)
                  + body.count(b"{", start, stop))
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
