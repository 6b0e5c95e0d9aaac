"""Tolerances learned from noise (Twitter's Diffy): replay one recording several times, or
against two known-good servers, and write the tolerance file that would have passed every
disagreement seen between a recorded answer and a replayed one, with a margin.

Per operation and field (list indices as ``[*]``, so one rule covers a list), the largest
relative difference ``|recorded - replayed| / |replayed|`` over the numbers whose replayed
value is not 0, and the largest absolute difference over those where it is, are kept; the
rule sets ``rtol`` (and ``atol`` where a 0 was met) to :data:`MARGIN` times them, rounded up
to one significant digit and never below the global tolerances. A field whose
non-numeric value (a string, a boolean, a list's length, a type) differed gets ``ignore``,
with the reason saying so. A field that never differed gets no rule.
"""

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from plotgate.clients.compare import is_number

__all__ = ["MARGIN", "Noise", "rules_toml"]

MARGIN = 10.0
"""Learned tolerances are this many times the largest difference seen."""


@dataclass
class _Spread:
    relative: float = 0.0
    absolute: float = 0.0
    """Largest |difference| where the replayed value is 0."""
    other: bool = False
    """A non-numeric value differed."""
    seen: int = 0


@dataclass
class Noise:
    """Disagreements gathered over runs, per (operation, field pattern)."""

    spreads: dict[tuple[str, str], _Spread] = field(default_factory=dict)
    runs: int = 0
    exchanges: int = 0

    def add(self, operation: str, recorded: Any, replayed: Any) -> None:
        """Take one exchange's recorded and replayed answers (results or problems)."""
        self.exchanges += 1
        for path, kind, value in _walk(recorded, replayed, ""):
            s = self.spreads.setdefault((operation, path or "result"), _Spread())
            s.seen += 1
            if kind == "relative":
                s.relative = max(s.relative, value)
            elif kind == "absolute":
                s.absolute = max(s.absolute, value)
            else:
                s.other = True


def _walk(a: Any, b: Any, path: str) -> Iterator[tuple[str, str, float]]:
    """(field pattern, 'relative' | 'absolute' | 'other', size) for each difference."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(a.keys() | b.keys()):
            sub = f"{path}.{key}" if path else str(key)
            if key not in a or key not in b:
                yield sub, "other", 0.0
            else:
                yield from _walk(a[key], b[key], sub)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            yield path, "other", 0.0
        elif a and all(map(is_number, a)) and all(map(is_number, b)):
            yield from _arrays(np.asarray(a, float), np.asarray(b, float), f"{path}[*]")
        else:
            for u, v in zip(a, b, strict=True):
                yield from _walk(u, v, f"{path}[*]")
    elif is_number(a) and is_number(b):
        yield from _arrays(np.asarray([a], float), np.asarray([b], float), path)
    elif a != b:
        yield path, "other", 0.0


def _arrays(x: np.ndarray, y: np.ndarray, path: str) -> Iterator[tuple[str, str, float]]:
    with np.errstate(invalid="ignore", over="ignore"):
        gap = np.abs(x - y)
    unequal = (x != y) & ~(np.isnan(x) & np.isnan(y))
    if not unequal.any():
        return
    if not np.isfinite(gap[unequal]).all():
        yield path, "other", 0.0
        return
    zero = unequal & (y == 0)
    rest = unequal & (y != 0)
    if rest.any():
        yield path, "relative", float(np.max(gap[rest] / np.abs(y[rest])))
    if zero.any():
        yield path, "absolute", float(np.max(gap[zero]))


def _ceil1(value: float) -> float:
    """Rounded up to one significant digit: 3.2e-7 -> 4e-7."""
    if value <= 0:
        return 0.0
    exponent = math.floor(math.log10(value))
    return math.ceil(value / 10.0**exponent) * 10.0**exponent


def rules_toml(noise: Noise, rtol: float, atol: float, source: str) -> str:
    """The tolerance file (TOML) that passes every disagreement in ``noise``."""
    lines = [
        f"# Learned by plotgate replay --calibrate from {noise.runs} runs over {source}:",
        f"# {noise.exchanges} answers compared; a rule per field that differed, at "
        f"{MARGIN:g} times the largest difference seen.",
    ]
    for (operation, path), s in sorted(noise.spreads.items()):
        lines += ["", "[[rule]]", f'operation = "{operation}"', f'path = "{path}"']
        if s.other:
            lines.append("ignore = true")
            lines.append(f'reason = "a non-numeric value differed in {s.seen} of the answers"')
            continue
        lines.append(f"rtol = {max(_ceil1(MARGIN * s.relative), rtol):.1e}")
        if s.absolute:
            lines.append(f"atol = {max(_ceil1(MARGIN * s.absolute), atol):.1e}")
        lines.append(
            f'reason = "differed {s.seen} times: at most {s.relative:.2e} relative, '
            f'{s.absolute:.2e} where the answer was 0"'
        )
    return "\n".join(lines) + "\n"
