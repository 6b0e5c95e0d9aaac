"""The choices of a discriminated union, for a 422 that says what to write.

A plot is cartesian or polar by its ``frame``, a gate ring, ellipse, ... by its ``kind``:
pydantic picks the model by that tag. Without the tag its error says "Unable to extract
tag using discriminator 'frame'", which names neither the tag's values nor what to do.
:func:`tag_reason` rewrites it as ``missing 'frame': 'cartesian' or 'polar'``, the
choices found by following the error's location through the request model to the union
(the choices differ from union to union: ``gates.design`` takes two kinds of gate of
seven).
"""

import types
import typing
from collections.abc import Sequence
from typing import Any, Literal

from pydantic import BaseModel
from pydantic.fields import FieldInfo

__all__ = ["choices_at", "tag_reason"]

_Step = tuple[Any, Any]
"""A type met on the way and the discriminator its field declared (None: none)."""


def tag_reason(error: dict[str, Any], model: type[BaseModel] | None) -> str | None:
    """The reason for pydantic's error dict ``error`` when it is a missing or unknown tag
    of a discriminated union of ``model``, naming the tag's choices; None for any other
    error (or a location that cannot be followed: pydantic's own words then stand)."""
    if error["type"] not in ("union_tag_not_found", "union_tag_invalid") or model is None:
        return None
    found = choices_at(model, error["loc"])
    if found is None:
        return None
    tag, choices = found
    quoted = [repr(c) for c in choices]
    options = quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
    if error["type"] == "union_tag_not_found":
        return f"missing {tag!r}: {options}"
    return f"{tag!r} is {error['ctx']['tag']!r}, not one of the choices: {options}"


def choices_at(model: type[BaseModel], loc: Sequence[int | str]) -> tuple[str, list[str]] | None:
    """The tag and its choices (in the union's order) of the discriminated union at
    ``loc`` (pydantic's error location) in ``model``, or None when ``loc`` leads elsewhere."""
    step: _Step | None = (model, None)
    for part in loc:
        if step is None:
            return None
        step = _into(*_unwrap(*step), part)
    if step is None:
        return None
    kind, tag = _unwrap(*step)
    if not isinstance(tag, str) or not _is_union(kind):
        return None
    choices = [v for member in typing.get_args(kind) for v in _tag_values(member, tag)]
    return tag, choices


def _unwrap(kind: Any, tag: Any) -> _Step:
    """``kind`` without ``Annotated`` (keeping a discriminator it declares) and without
    ``| None``."""
    while True:
        if typing.get_origin(kind) is typing.Annotated:
            kind, *metadata = typing.get_args(kind)
            for meta in metadata:
                if isinstance(meta, FieldInfo) and meta.discriminator is not None:
                    tag = meta.discriminator
            continue
        if _is_union(kind):
            members = [m for m in typing.get_args(kind) if m is not type(None)]
            if len(members) == 1:
                kind = members[0]
                continue
        return kind, tag


def _into(kind: Any, tag: Any, part: int | str) -> _Step | None:
    """One step of a location: a union member by its tag, a list item, a model's field."""
    if isinstance(tag, str) and _is_union(kind):
        members = [m for m in typing.get_args(kind) if part in _tag_values(m, tag)]
        return (members[0], None) if members else None
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if isinstance(part, int) and origin in (list, tuple, Sequence) and args:
        return args[0] if origin is not tuple or args[-1] is Ellipsis else args[part], None
    if isinstance(kind, type) and issubclass(kind, BaseModel) and isinstance(part, str):
        for name, info in kind.model_fields.items():
            if part in (name, info.alias):
                return info.annotation, info.discriminator
    if origin is dict and isinstance(part, str) and len(args) == 2:
        return args[1], None
    return None


def _is_union(kind: Any) -> bool:
    return typing.get_origin(kind) in (typing.Union, types.UnionType)


def _tag_values(member: Any, tag: str) -> tuple[Any, ...]:
    if not (isinstance(member, type) and issubclass(member, BaseModel)):
        return ()
    info = member.model_fields.get(tag)
    if info is None or typing.get_origin(info.annotation) is not Literal:
        return ()
    return typing.get_args(info.annotation)
