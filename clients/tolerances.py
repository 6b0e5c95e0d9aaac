"""Per-field tolerances of replay's comparison, read from a TOML file a team keeps beside
its recordings (``plotgate replay --tolerances FILE``).

A file is a list of rules::

    [[rule]]
    name = "gating probability"       # optional; "rule N" (its place in the file) otherwise
    operation = "gates.probability"   # glob over operation names (default "*")
    path = "P_G[*]"                    # JSON path in the answer: keys (globs), [*] for items
    rtol = 1e-6                        # and/or atol; or ignore = true; or decision = true
    reason = "quadrature to 1e-8"      # why: kept with the rule, shown nowhere else

A rule judges the field its path names and everything under it (``tracks`` covers
``tracks[3].x`` and ``tracks.length``). A key segment is a glob (``*_deg``); ``[*]`` stands
for any index of a list and matches only an index. ``rtol``/``atol`` replace the global
``--rtol``/``--atol`` there (a missing one keeps the global value); ``ignore`` drops every
difference there; ``decision`` makes numbers exact there (booleans and strings always are).

The most specific rule wins: the one whose path has the most segments, then the most
literal characters in its path, then in its operation; then the first in the file. Where no
rule matches, the global tolerances judge, named :data:`DEFAULT`.
"""

import fnmatch
import math
import re
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "DEFAULT",
    "Judged",
    "Rule",
    "Rules",
    "ToleranceFileError",
    "load_rules",
    "pattern_of",
    "segments",
]

DEFAULT = "default (--rtol/--atol)"
"""The name of what judges a field no rule matches."""

_INDEX = re.compile(r"\[\d+\]")
_SEGMENT = re.compile(r"\[\*\]|[^.\[\]]+")
_KEYS = frozenset({"name", "operation", "path", "rtol", "atol", "ignore", "decision", "reason"})


class ToleranceFileError(ValueError):
    """A tolerance file that cannot be used; its text names the file and the rule."""


@dataclass(frozen=True)
class Judged:
    """How one field is compared: ``rtol``, ``atol``, or ``ignore``; ``rule`` names it."""

    rtol: float
    atol: float
    ignore: bool
    rule: str


@dataclass(frozen=True)
class Rule:
    """One rule of a tolerance file (the module says what each part does)."""

    name: str
    operation: str = "*"
    path: str = "*"
    rtol: float | None = None
    atol: float | None = None
    ignore: bool = False
    decision: bool = False
    reason: str = ""
    parts: tuple[str, ...] = field(default=(), compare=False)

    def rank(self) -> tuple[int, int, int]:
        """Specificity: path segments, literal characters of path, then of operation."""
        return (len(self.parts), _literal(self.path), _literal(self.operation))

    def covers(self, operation: str, path: tuple[str, ...]) -> bool:
        return (
            fnmatch.fnmatchcase(operation, self.operation)
            and len(path) >= len(self.parts)
            and all(_segment_matches(p, s) for p, s in zip(path, self.parts, strict=False))
        )


def _literal(pattern: str) -> int:
    return sum(c not in "*?[]" for c in pattern)


def _segment_matches(segment: str, pattern: str) -> bool:
    if pattern == "[*]" or segment == "[*]":
        return pattern == segment
    return fnmatch.fnmatchcase(segment, pattern)


def pattern_of(path: str) -> str:
    """A difference's path with every list index as ``[*]``: ``a[3].b`` -> ``a[*].b``."""
    return _INDEX.sub("[*]", path)


def segments(path: str) -> tuple[str, ...]:
    """A path (or pattern) cut into keys and ``[*]``: ``a[*].b`` -> ``("a", "[*]", "b")``."""
    return tuple(_SEGMENT.findall(pattern_of(path)))


class Rules:
    """The rules of one file, resolved per (operation, field) once and remembered."""

    def __init__(self, rules: Iterable[Rule], rtol: float, atol: float) -> None:
        self.rules = tuple(rules)
        self.rtol, self.atol = rtol, atol
        self._default = Judged(rtol, atol, False, DEFAULT)
        self._resolved: dict[tuple[str, str], Judged] = {}

    def with_defaults(self, rtol: float, atol: float) -> "Rules":
        """The same rules over other global tolerances."""
        return Rules(self.rules, rtol, atol)

    def at(self, operation: str, path: str) -> Judged:
        """How the field at ``path`` (``a[3].b``; ``""`` the whole answer) is judged."""
        key = (operation, pattern_of(path))
        found = self._resolved.get(key)
        if found is None:
            found = self._resolved[key] = self._resolve(operation, segments(key[1]))
        return found

    def _resolve(self, operation: str, path: tuple[str, ...]) -> Judged:
        best: Rule | None = None
        for rule in self.rules:
            if rule.covers(operation, path) and (best is None or rule.rank() > best.rank()):
                best = rule
        if best is None:
            return self._default
        if best.ignore:
            return Judged(self.rtol, self.atol, True, best.name)
        if best.decision:
            return Judged(0.0, 0.0, False, best.name)
        rtol = self.rtol if best.rtol is None else best.rtol
        atol = self.atol if best.atol is None else best.atol
        return Judged(rtol, atol, False, best.name)

    def for_operation(self, operation: str) -> "OperationRules":
        return OperationRules(self, operation)


class OperationRules:
    """:class:`Rules` bound to one operation: what :func:`plotgate.clients.compare.diff`
    asks per field."""

    __slots__ = ("operation", "rules")

    def __init__(self, rules: Rules, operation: str) -> None:
        self.rules, self.operation = rules, operation

    def at(self, path: str) -> Judged:
        return self.rules.at(self.operation, path)


def load_rules(
    path: Path | str, rtol: float, atol: float, operations: Iterable[str] | None = None
) -> Rules:
    """Read and check a tolerance file; raises :class:`ToleranceFileError` (one line,
    naming the file and the rule) for anything it cannot use: not TOML, an unknown key, a
    tolerance that is not a finite number >= 0, a path that is not keys and ``[*]``, a rule
    that sets nothing or both ``ignore`` and a tolerance, an operation glob that matches no
    operation in ``operations`` (a misspelt name would otherwise judge nothing)."""
    try:
        document = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ToleranceFileError(f"{path}: cannot be read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ToleranceFileError(f"{path}: not TOML: {exc}") from None
    extra = sorted(set(document) - {"rule"})
    if extra:
        raise ToleranceFileError(f"{path}: unknown table {extra[0]!r} (only [[rule]] tables)")
    tables = document.get("rule", [])
    if not isinstance(tables, list):
        raise ToleranceFileError(f"{path}: 'rule' must be an array of tables ([[rule]])")
    known = sorted(operations) if operations is not None else None
    rules = [_rule(table, i + 1, known) for i, table in enumerate(tables)]
    seen: dict[str, int] = {}
    for i, rule in enumerate(rules):
        if rule.name in seen:
            raise ToleranceFileError(
                f"{path}: rule {i + 1} ({rule.name!r}): the name of rule {seen[rule.name]} too"
            )
        seen[rule.name] = i + 1
    return Rules(rules, rtol, atol)


def _rule(table: Any, number: int, operations: list[str] | None) -> Rule:
    where = f"rule {number}"
    if not isinstance(table, dict):
        raise ToleranceFileError(f"{where}: not a table")
    if isinstance(table.get("name"), str):
        where += f" ({table['name']!r})"
    try:
        return _checked(table, number, operations)
    except ToleranceFileError as exc:
        raise ToleranceFileError(f"{where}: {exc}") from None


def _checked(table: dict[str, Any], number: int, operations: list[str] | None) -> Rule:
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise ToleranceFileError(f"unknown key {unknown[0]!r} (known: {', '.join(sorted(_KEYS))})")
    for key in ("name", "operation", "path", "reason"):
        if key in table and not isinstance(table[key], str):
            raise ToleranceFileError(f"{key} must be a string")
    for key in ("ignore", "decision"):
        if key in table and not isinstance(table[key], bool):
            raise ToleranceFileError(f"{key} must be true or false")
    for key in ("rtol", "atol"):
        value = table.get(key)
        if key in table and (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not 0 <= value < math.inf
        ):
            raise ToleranceFileError(f"{key} must be a finite number >= 0, got {value!r}")
    path = table.get("path", "*")
    parts = _path_parts(path)
    settings = [k for k in ("rtol", "atol") if k in table] + [
        k for k in ("ignore", "decision") if table.get(k)
    ]
    if not settings:
        raise ToleranceFileError("sets none of rtol, atol, ignore = true, decision = true")
    if len(settings) > 1 and ({"ignore", "decision"} & set(settings)):
        raise ToleranceFileError(f"sets {' and '.join(settings)}: choose one kind")
    operation = table.get("operation", "*")
    if operations is not None and not fnmatch.filter(operations, operation):
        raise ToleranceFileError(f"operation {operation!r} matches no operation of this build")
    return Rule(
        table.get("name", f"rule {number}"),
        operation,
        path,
        None if "rtol" not in table else float(table["rtol"]),
        None if "atol" not in table else float(table["atol"]),
        table.get("ignore", False),
        table.get("decision", False),
        table.get("reason", ""),
        parts,
    )


def _path_parts(path: str) -> tuple[str, ...]:
    parts = tuple(_SEGMENT.findall(path))
    rebuilt = "".join(p if p == "[*]" else f".{p}" for p in parts).lstrip(".")
    if not path or rebuilt != path or any("[" in p and p != "[*]" for p in parts):
        raise ToleranceFileError(
            f"path {path!r} is not keys joined by '.' with [*] for list items (e.g. 'a[*].b')"
        )
    return parts
