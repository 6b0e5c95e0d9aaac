"""The code blocks of a markdown page, and the comparison of what a block printed with the
output the page shows after it.

A block is fenced with three backticks and an info string: its language first (``sh``,
``python``, ``json``...), then ``output`` when it is the output of the runnable block just
before it. A line ``<!-- not run: why -->`` right before a block marks it as one a test
cannot run, and says why.
"""

import json
import re
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

__all__ = ["Block", "Shown", "blocks", "json_matches", "links", "text_matches"]

RUNNABLE = ("sh", "python")
NOT_RUN = re.compile(r"<!--\s*not run:\s*(.+?)\s*-->")
RELATIVE = 1e-12
"""A number shown in full matches a printed one within this relative difference..."""
ABSOLUTE = 1e-14
"""...or this absolute one (a difference of two rules near rounding)."""


@dataclass
class Block:
    """A fenced code block of ``page`` whose opening fence is at ``line`` (1-based)."""

    page: Path
    line: int
    language: str
    code: str
    is_output: bool = False
    not_run: str | None = None
    output: "Block | None" = None

    @property
    def runnable(self) -> bool:
        return self.language in RUNNABLE and not self.is_output

    def where(self) -> str:
        return f"{self.page.name}:{self.line}"


def blocks(page: Path) -> list[Block]:
    """The page's code blocks in order, each output block attached to the runnable block
    before it (only blank lines between the two)."""
    found: list[Block] = []
    lines = page.read_text().split("\n")
    i = 0
    previous_text = ""  # the last non-blank line outside a block
    since_block = True  # only blank lines since the last block closed
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            words = line[3:].split()
            start = i + 1
            i += 1
            while i < len(lines) and lines[i] != "```":
                i += 1
            marker = NOT_RUN.fullmatch(previous_text.strip())
            block = Block(
                page,
                start,
                words[0] if words else "",
                "\n".join(lines[start:i]) + "\n",
                is_output="output" in words[1:],
                not_run=marker.group(1) if marker else None,
            )
            if block.is_output:
                assert since_block and found and found[-1].runnable, (
                    f"{block.where()}: an output block must follow a runnable block"
                )
                found[-1].output = block
            found.append(block)
            previous_text, since_block = "", True
        elif line.strip():
            previous_text, since_block = line, False
        i += 1
    return found


class Shown(float):
    """A float as a page shows it, remembering its digits."""

    text: str

    def __new__(cls, text: str) -> "Shown":
        number = super().__new__(cls, text)
        number.text = text
        return number

    def matches(self, printed: float) -> bool:
        """Within half a unit of the last digit shown, or the full-digit tolerances."""
        half_unit = float(Decimal(1).scaleb(Decimal(self.text).as_tuple().exponent)) / 2
        difference = abs(float(self) - printed)
        return difference <= max(half_unit, RELATIVE * abs(printed), ABSOLUTE)


def documents(text: str, shown: bool) -> list[Any]:
    """Every JSON document of ``text``, one after another (a block may print several);
    floats as :class:`Shown` when ``shown``."""
    decoder = json.JSONDecoder(parse_float=Shown) if shown else json.JSONDecoder()
    found, at = [], 0
    while True:
        while at < len(text) and text[at].isspace():
            at += 1
        if at == len(text):
            return found
        document, at = decoder.raw_decode(text, at)
        found.append(document)


def json_matches(shown: Any, printed: Any, path: str = "") -> list[str]:
    """Where ``printed`` differs from what the page ``shown`` (empty when it matches): the
    string ``"..."`` stands for any value."""
    if shown == "...":
        return []
    if isinstance(shown, Shown):
        ok = isinstance(printed, int | float) and not isinstance(printed, bool)
        return (
            []
            if ok and shown.matches(printed)
            else [f"{path}: shown {shown.text}, printed {printed!r}"]
        )
    if isinstance(shown, dict) and isinstance(printed, dict):
        if shown.keys() != printed.keys():
            return [f"{path}: shown keys {sorted(shown)}, printed {sorted(printed)}"]
        return [d for k in shown for d in json_matches(shown[k], printed[k], f"{path}.{k}")]
    if isinstance(shown, list) and isinstance(printed, list):
        if len(shown) != len(printed):
            return [f"{path}: shown {len(shown)} items, printed {len(printed)}"]
        return [
            d
            for i, (s, p) in enumerate(zip(shown, printed, strict=True))
            for d in json_matches(s, p, f"{path}[{i}]")
        ]
    same = (
        shown == printed
        and type(shown) is type(printed)
        or (isinstance(shown, int) and not isinstance(shown, bool) and shown == printed)
    )
    return [] if same else [f"{path}: shown {shown!r}, printed {printed!r}"]


def text_matches(shown: str, printed: str) -> bool:
    """Line by line, trailing blanks ignored; ``...`` stands for any text, over any
    number of lines when it is a line of its own."""
    pattern = "\n".join(
        r"(?:.*\n)*?.*"
        if line.strip() == "..."
        else re.escape(line.rstrip()).replace(r"\.\.\.", ".*")
        for line in shown.rstrip("\n").split("\n")
    )
    normalized = "\n".join(line.rstrip() for line in printed.rstrip("\n").split("\n"))
    return re.fullmatch(pattern, normalized) is not None


LINK = re.compile(r"\]\(([^)\s]+)\)")


def links(page: Path) -> list[str]:
    """The targets of the page's markdown links and images, outside code blocks."""
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.S | re.M)
    return LINK.findall(text)
