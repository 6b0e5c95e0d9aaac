"""How long ``plotgate replay FILE`` takes to reach its first exchange, and to end.

A recording of ``--exchanges`` gates.test requests (the endpoint's example body) is written
by the service, in process, into a temporary folder. Then ``--repeat`` times, a fresh
interpreter runs the CLI's ``main(["replay", folder])`` in process, as ``plotgate replay``
does, and reports the seconds from its first import to the first exchange answered, to
the report printed, and the wall clock of the whole process (its start and its exit
included). With ``--tree PATH`` (a checkout of another commit, e.g. ``git worktree add``),
each run is paired with one of that tree, in the same minutes: on a shared machine the
ratio is the figure to keep. The numba cache of each tree is warmed first.

    python bench/bench_replay_start.py [--exchanges 10 --repeat 5 --tree ../main]
    python bench/bench_replay_start.py --quick     # 1 run (CI)

Ends with the ``SUMMARY`` line of the front table (bench/README.md): this tree's median
seconds to the first exchange (and, with ``--tree``, the ratio to the other tree's).
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.table import ENDPOINTS

TIMED = """
import sys, time
t0 = time.perf_counter()
{use_tree}
from plotgate.clients import replay
answer = replay.InProcess._outcome
first = []
def timed(self, *args):
    outcome = answer(self, *args)
    first.append(first[0] if first else time.perf_counter() - t0)
    return outcome
replay.InProcess._outcome = timed
from plotgate.clients.cli import main
code = main(["replay", sys.argv[1]])
print(first[0], time.perf_counter() - t0, code, file=sys.stderr)
"""

USE_TREE = """
# another tree's package instead of this editable install's (its layers as pyproject maps
# them, linked under a temporary root)
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
sys.path.insert(0, {root!r})
"""


def record(folder: Path, exchanges: int) -> None:
    body = ENDPOINTS["gates.test"].example
    with TestClient(create_app(Settings(log_dir=folder, git_commit="bench"))) as client:
        for i in range(exchanges):
            answer = client.post("/v1/gates/test", json=body, headers={"x-request-id": f"r{i}"})
            assert answer.status_code == 200, answer.text


def package_root(tree: Path, into: Path) -> Path:
    """A folder holding ``plotgate`` laid out as installed, from the checkout ``tree``."""
    package = into / "plotgate"
    package.mkdir(parents=True)
    for source in (tree / "plotgate").glob("*.py"):
        (package / source.name).symlink_to(source.resolve())
    for layer in ("core", "service", "clients"):
        (package / layer).symlink_to((tree / layer).resolve())
    return into


def run(code: str, folder: Path) -> tuple[float, float, float]:
    """(first exchange, end, wall) seconds of one replay in a fresh interpreter."""
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code, str(folder)], capture_output=True, text=True, timeout=600
    )
    wall = time.perf_counter() - started
    first, end, status = done.stderr.split()[-3:]
    assert status == "0", done.stderr
    return float(first), float(end), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--tree", type=Path, help="another checkout to pair each run with")
    parser.add_argument("--quick", action="store_true", help="1 run (CI)")
    args = parser.parse_args()
    if args.quick:
        args.repeat = 1
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "recording"
        record(folder, args.exchanges)
        codes = {"this tree": TIMED.format(use_tree="")}
        if args.tree is not None:
            root = package_root(args.tree, Path(tmp) / "other")
            codes[str(args.tree)] = TIMED.format(use_tree=USE_TREE.format(root=str(root)))
        for code in codes.values():
            run(code, folder)  # warms that tree's numba cache
        runs: dict[str, list[tuple[float, float, float]]] = {name: [] for name in codes}
        for _ in range(args.repeat):
            for name, code in codes.items():
                runs[name].append(run(code, folder))
    print(f"plotgate replay of {args.exchanges} gates.test exchanges, {args.repeat} runs")
    print(f"{'tree':<28}{'first exchange (s)':<21}{'end (s)':<18}wall (s), median [min-max]")
    for name, times in runs.items():
        cells = []
        for column in zip(*times, strict=True):
            cells.append(f"{statistics.median(column):.2f} [{min(column):.2f}-{max(column):.2f}]")
        print(f"{name:<28}{cells[0]:<21}{cells[1]:<18}{cells[2]}")
    first = {name: statistics.median(t[0] for t in times) for name, times in runs.items()}
    ours = first.pop("this tree")
    other = next(iter(first.items()), None)
    print()
    summary(
        "replay_start.first_exchange",
        f"`plotgate replay` of {args.exchanges} gates.test exchanges: first exchange answered,"
        f" fresh interpreter, warm cache, median of {args.repeat}",
        f"the tree {other[0]}, same minutes" if other else "—",
        f"{ours:.2f} s" + (f", {ours / other[1]:.2f}x the peer" if other else ""),
        "—",
        None,
    )


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    main()
