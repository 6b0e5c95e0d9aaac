"""Every figure in docs/figures, drawn by one command and stamped with what drew it.

Run from the repository root::

    python bench/figures.py                       # all of them into docs/figures
    python bench/figures.py --only fig2_ring scenario_score_250
    python bench/figures.py --stale               # name the stale ones; exit 1 if any

:data:`FIGURES` is the one list of the committed figures: each PNG's file name, the files
that draw it (its drawing modules and the input files it reads) and its inputs (the
requests and settings it is drawn from). Each PNG carries in a ``tEXt`` chunk keyed
:data:`KEY` the SHA-256 of those files and inputs (:func:`source_hash`), so
``tests/bench/test_figures.py`` finds a figure older than the code that draws it by
hashing, without drawing anything. The code that computes the numbers (core) is not
hashed: a change there that moves a figure is caught by the tests of the numbers, and
hashing it would call every figure stale at every core change.

Time on a quiet 2-core machine: about 5 minutes, most of it the accuracy study (1000
runs, about 3 minutes), the unconditional comparison (about 40 s) and the identification
Monte Carlo (about 1 minute); the operating curves are drawn from ``bench/results``
(``python bench/bench_curves.py`` recomputes them, about an hour). The accuracy study
also rewrites its table, ``docs/multistatic_accuracy.md``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import struct
import sys
import time
import zlib
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # bench.* when run as a script

from plotgate.clients.gate_figures import Setup  # noqa: E402
from plotgate.clients.scenario_plot import default_settings, simulate_request  # noqa: E402
from plotgate.clients.study import DEFAULT_REQUEST  # noqa: E402

FOLDER = ROOT / "docs" / "figures"
KEY = "plotgate:source-sha256"
"""The PNG tEXt keyword of the stamp."""
SCORE_CONFIG = "docs/examples/score_initiation.json"
SCENARIO = simulate_request()
"""Mu et al.'s scenario at clutter 250, as ``plotgate scenario`` simulates it by default."""
POLAR_CONFIG = default_settings("polar")
"""``plotgate scenario``'s default settings: the paper's polar method."""


@dataclass(frozen=True)
class Recipe:
    """How one committed figure is drawn: ``draw(out)`` writes the PNG at ``out``."""

    file: str
    sources: tuple[str, ...]
    """Files (from the repository root) whose text decides the picture."""
    draw: Callable[[Path], Any]
    inputs: dict[str, Any] = field(default_factory=dict)
    """What the figure is drawn from, besides the files (as JSON)."""


def _konovalov(figure: str) -> Callable[[Path], Any]:
    def draw(out: Path) -> Any:
        from plotgate.clients.gate_figures import plot

        return plot(figure, out)

    return draw


def _scenario(config: dict[str, Any] | None) -> Callable[[Path], Any]:
    def draw(out: Path) -> Any:
        from plotgate.clients.scenario_plot import scenario_figure

        settings = config or json.loads((ROOT / SCORE_CONFIG).read_text())
        return scenario_figure(SCENARIO, settings, out)

    return draw


def _study(out: Path) -> Any:
    from plotgate.clients.study import draw, run_study, table

    answer = run_study(DEFAULT_REQUEST)
    (ROOT / "docs" / "multistatic_accuracy.md").write_text(table(answer))
    return draw(answer, out)


def _identification(out: Path) -> Any:
    from bench.bench_identification import SEED, alpha_rows, beta_rows, figure

    runs = 100_000
    return figure(alpha_rows(runs, SEED)[1], beta_rows(runs, SEED)[1], out)


def _curves(out: Path) -> Any:
    from bench.bench_curves import RESULTS, figure, stonesoup_points

    rows = json.loads((RESULTS / "curves.json").read_text())
    stone = stonesoup_points(tuple(rows[0]["seeds"]))
    return figure(rows, stone, out)


_PLOTS = ("clients/gate_figures.py",)
FIGURES: dict[str, Recipe] = {
    "fig2_ring": Recipe(
        "fig2_ring.png", _PLOTS, _konovalov("fig2"), {"figure": "fig2", "setup": asdict(Setup())}
    ),
    "fig5_combined": Recipe(
        "fig5_combined.png",
        _PLOTS,
        _konovalov("fig5"),
        {"figure": "fig5", "setup": asdict(Setup())},
    ),
    "compare_unconditional": Recipe(
        "compare_unconditional.png",
        _PLOTS,
        _konovalov("compare"),
        {"figure": "compare", "setup": asdict(Setup())},
    ),
    "scenario_polar_250": Recipe(
        "scenario_polar_250.png",
        ("clients/scenario_plot.py", *_PLOTS),
        _scenario(POLAR_CONFIG),
        {"simulate": SCENARIO, "config": POLAR_CONFIG},
    ),
    "scenario_score_250": Recipe(
        "scenario_score_250.png",
        ("clients/scenario_plot.py", *_PLOTS, SCORE_CONFIG),
        _scenario(None),
        {"simulate": SCENARIO},
    ),
    "multistatic_accuracy": Recipe(
        "multistatic_accuracy.png", ("clients/study.py", *_PLOTS), _study, DEFAULT_REQUEST
    ),
    "identification_errors": Recipe(
        "identification_errors.png",
        ("bench/bench_identification.py",),
        _identification,
        {"runs": 100_000},
    ),
    "initiation_curves": Recipe(
        "initiation_curves.png",
        (
            "bench/bench_curves.py",
            "bench/results/curves.json",
            "bench/results/stonesoup_heldout.jsonl",
        ),
        _curves,
    ),
}
"""Every committed figure, by name (its file name without ``.png``)."""


def source_hash(recipe: Recipe, root: Path = ROOT) -> str:
    """SHA-256 (hex) of the recipe's source files, each with its path, and its inputs."""
    digest = hashlib.sha256()
    for name in sorted(recipe.sources):
        data = (root / name).read_bytes()
        digest.update(f"{name}\0{len(data)}\0".encode())
        digest.update(data)
    digest.update(json.dumps(recipe.inputs, sort_keys=True).encode())
    return digest.hexdigest()


_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """(type, body) of every chunk of a PNG; ValueError when it is not one."""
    if not data.startswith(_SIGNATURE):
        raise ValueError("not a PNG")
    chunks, at = [], len(_SIGNATURE)
    while at + 8 <= len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        if len(body) != length:
            raise ValueError(f"a {kind!r} chunk runs past the end of the file")
        chunks.append((kind, body))
        at += 12 + length
    return chunks


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def stamp(path: Path, value: str) -> None:
    """Put ``value`` under :data:`KEY` in the PNG at ``path``, in place of any earlier one."""
    text = KEY.encode("latin-1") + b"\0" + value.encode("latin-1")
    kept = [(k, b) for k, b in _chunks(path.read_bytes()) if not _is_stamp(k, b)]
    out = [_SIGNATURE, _chunk(*kept[0]), _chunk(b"tEXt", text)]  # right after IHDR
    out += [_chunk(k, b) for k, b in kept[1:]]
    path.write_bytes(b"".join(out))


def _is_stamp(kind: bytes, body: bytes) -> bool:
    return kind == b"tEXt" and body.split(b"\0", 1)[0] == KEY.encode("latin-1")


def stamp_of(path: Path) -> str | None:
    """The value under :data:`KEY` in the PNG at ``path``, or None."""
    for kind, body in _chunks(path.read_bytes()):
        if _is_stamp(kind, body):
            return body.split(b"\0", 1)[1].decode("latin-1")
    return None


def stale(folder: Path = FOLDER) -> list[str]:
    """Names of the figures in ``folder`` that are missing, damaged or older than what
    draws them."""
    return [name for name, recipe in FIGURES.items() if not _current(folder / recipe.file, recipe)]


def _current(png: Path, recipe: Recipe) -> bool:
    try:
        return stamp_of(png) == source_hash(recipe)
    except (OSError, ValueError):  # missing, unreadable or not a PNG: draw it again
        return False


def draw(name: str, folder: Path) -> Path:
    """Draw figure ``name`` into ``folder`` and stamp it."""
    recipe = FIGURES[name]
    out = folder / recipe.file
    recipe.draw(out)
    stamp(out, source_hash(recipe))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=FOLDER, help="(docs/figures)")
    parser.add_argument("--only", nargs="+", choices=sorted(FIGURES), metavar="NAME")
    parser.add_argument("--stale", action="store_true", help="name the stale figures only")
    args = parser.parse_args(argv)
    if args.stale:
        old = stale(args.folder)
        print("\n".join(old) if old else "every figure is up to date")
        return 1 if old else 0
    for name in args.only or FIGURES:
        start = time.perf_counter()
        out = draw(name, args.folder)
        print(f"{out} ({time.perf_counter() - start:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
