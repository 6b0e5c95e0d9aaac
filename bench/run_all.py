"""Every bench of the front table, one after another, and the table rebuilt from their output.

Run from the repository root::

    python bench/run_all.py                      # full runs; rewrites bench/README.md's table
    python bench/run_all.py --quick              # each bench's quick mode (CI); writes nothing
    python bench/run_all.py --only gates initiation
    python bench/run_all.py --no-write           # full runs, the README left as it is

Each bench of :data:`BENCHES` runs as a subprocess of this interpreter (``sys.executable``)
from the repository root, its output captured, under a timeout. A bench reports its rows
at the end of its output, one line per row of the front table::

    SUMMARY {"row": "<stable id>", "workload": "...", "peer": "...", "measured": "...",
             "aim": "...", "met": true | false | null}

With ``--write`` (the default for full runs, refused with ``--quick``: quick sizes are not
the table's figures) the block between :data:`BEGIN` and :data:`END` of bench/README.md is
rebuilt: the date, the machine (CPUs, Python, numpy), then one row per SUMMARY line with
the command that made it. A row whose bench did not run this time (``--only``, or it
failed) keeps its previous line, marked as from the earlier run.

Exit status: 0 when every bench ran and printed its SUMMARY rows; 1 when one failed, timed
out or printed no SUMMARY (named, with the tail of its stderr); 2 on a usage error.
Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "bench" / "README.md"
BEGIN = "<!-- run_all:begin -->"
END = "<!-- run_all:end -->"
FIELDS = ("row", "workload", "peer", "measured", "aim", "met")
QUICK_TIMEOUT_S = 120.0
"""A quick run is meant to take <= 30 s; four times that on a loaded 2-core machine is a hang."""
TAIL_LINES = 15


@dataclass(frozen=True)
class Bench:
    """One bench: its script, the arguments of a full and of a quick run, the front-table
    rows it prints (their ids, in table order), and the timeout of a full run."""

    script: str
    full: tuple[str, ...]
    quick: tuple[str, ...]
    rows: tuple[str, ...]
    timeout_s: float = 1800.0

    @property
    def name(self) -> str:
        return Path(self.script).stem.removeprefix("bench_")

    def command(self, quick: bool) -> list[str]:
        return ["python", self.script, *(self.quick if quick else self.full)]


QUICK = ("--quick",)
BENCHES: tuple[Bench, ...] = (
    Bench(
        "bench/bench_service.py",
        (),
        QUICK,
        (
            *(f"service.recording.c{c}" for c in (1, 10, 50)),
            "service.recording.p99.c50",
            *(f"service.granian.c{c}" for c in (1, 10, 50)),
        ),
    ),
    Bench(
        "bench/bench_record_writers.py",
        (),
        QUICK,
        (
            "record_writers.recorder.per1",
            "record_writers.recorder.per6",
            "record_writers.steps.c1",
            "record_writers.compaction.zstd",
        ),
    ),
    Bench("bench/bench_reading.py", (), QUICK, ("reading",)),
    Bench("bench/bench_replay.py", (), QUICK, ("replay",)),
    Bench("bench/bench_view.py", (), QUICK, ("view-vs-read",)),
    Bench(
        "bench/bench_multistatic.py",
        (),
        QUICK,
        (
            "multistatic.single_shot.study",
            "multistatic.single_shot.spread",
            "multistatic.trajectory.own_start",
            "multistatic.trajectory.given_start",
        ),
    ),
    Bench(
        "bench/bench_solver_aims.py",
        (),
        QUICK,
        (
            "solvers.single_shot.study",
            "solvers.single_shot.spread",
            "solvers.trajectory.own_start",
            "solvers.trajectory.given_start",
        ),
    ),
    Bench(
        "bench/bench_probability.py",
        (),
        QUICK,
        (
            "probability.conditional.handler",
            "probability.conditional.core",
            *(
                f"probability.unconditional.konovalov.{k}"
                for k in ("ring", "combined", "expanded")
            ),
            *(
                f"probability.unconditional.axis26.{k}"
                for k in ("ring", "combined", "expanded", "ellipse", "first_association")
            ),
        ),
    ),
    Bench(
        "bench/bench_axis_ratio.py",
        (),
        QUICK,
        tuple(f"axis_ratio.26.{k}" for k in ("ring", "combined", "expanded", "first_association")),
    ),
    Bench("bench/bench_gates.py", (), QUICK, ("gates.EllipseGate", "gates.CombinedGate")),
    Bench(
        "bench/bench_initiation.py",
        (),
        QUICK,
        ("initiation.logic", "initiation.polar", "initiation.stonesoup"),
    ),
    Bench(
        "bench/bench_existence.py",
        ("--clutter", "250", "--runs", "500", "--score"),
        QUICK,
        ("existence.clutter250",),
    ),
    Bench("bench/bench_identification.py", ("--no-png",), QUICK, ("identification.picture",)),
    Bench("bench/bench_replay_start.py", (), QUICK, ("replay_start.first_exchange",)),
    Bench("bench/bench_lanes.py", (), QUICK, ("lanes.small_behind_large",)),
    Bench(
        "bench/bench_live_subscribers.py",
        (),
        QUICK,
        ("live_subscribers.memory", "live_subscribers.p50"),
    ),
    Bench(
        "bench/bench_bodies.py",
        (),
        QUICK,
        ("bodies.healthz", "bodies.peak_rss", "bodies.half_sent"),
    ),
    Bench(
        "bench/bench_worst_requests.py",
        (),
        QUICK,
        ("worst_requests.cpu", "worst_requests.memory"),
        timeout_s=3600.0,
    ),
)
"""The benches of the front table, in its order."""


@dataclass
class Outcome:
    """What one bench's run gave: its rows, or why it failed."""

    bench: Bench
    rows: list[dict[str, object]]
    seconds: float
    failure: str | None = None
    notes: tuple[str, ...] = ()


class Usage(Exception):
    """A command line this program refuses (exit status 2)."""


def parse_summary(stdout: str) -> list[dict[str, object]]:
    """The SUMMARY rows of a bench's output, in order; ValueError names a malformed one."""
    rows = []
    for line in stdout.splitlines():
        if not line.startswith("SUMMARY "):
            continue
        try:
            row = json.loads(line.removeprefix("SUMMARY "))
        except json.JSONDecodeError as error:
            raise ValueError(f"a SUMMARY line is not JSON ({error}): {line!r}") from None
        if not isinstance(row, dict) or set(row) != set(FIELDS):
            raise ValueError(f"a SUMMARY line lacks or adds fields (wants {FIELDS}): {line!r}")
        if row["met"] not in (True, False, None):
            raise ValueError(f"a SUMMARY line's met is not true, false or null: {line!r}")
        rows.append(row)
    return rows


def tail(text: str, lines: int = TAIL_LINES) -> str:
    return "\n".join("    " + line for line in text.rstrip().splitlines()[-lines:])


def run(bench: Bench, quick: bool, root: Path = ROOT) -> Outcome:
    """Run one bench in its own process group (killed whole on a timeout)."""
    argv = [sys.executable, *bench.command(quick)[1:]]
    timeout = QUICK_TIMEOUT_S if quick else bench.timeout_s
    start = time.perf_counter()
    try:
        proc = subprocess.Popen(
            argv,
            cwd=root,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
    except OSError as error:
        return Outcome(bench, [], 0.0, f"did not start: {error}")
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
        seconds = time.perf_counter() - start
        return Outcome(bench, [], seconds, f"timed out after {timeout:.0f} s\n{tail(stderr)}")
    except BaseException:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        return Outcome(bench, [], seconds, f"exited {proc.returncode}\n{tail(stderr or stdout)}")
    try:
        rows = parse_summary(stdout)
    except ValueError as error:
        return Outcome(bench, [], seconds, str(error))
    if not rows:
        return Outcome(bench, [], seconds, f"printed no SUMMARY line\n{tail(stderr or stdout)}")
    printed = [str(row["row"]) for row in rows]
    notes = [f"row {r} is not among BENCHES' rows of {bench.name}" for r in printed]
    notes = [n for n, r in zip(notes, printed, strict=True) if r not in bench.rows]
    notes += [f"row {r} not printed (kept from before)" for r in bench.rows if r not in printed]
    return Outcome(bench, rows, seconds, None, tuple(notes))


def machine() -> str:
    """The CPUs, Python and numpy of this run."""
    try:
        numpy = metadata.version("numpy")
    except metadata.PackageNotFoundError:
        numpy = "not installed"
    return (
        f"{os.cpu_count()} CPUs ({platform.machine()}), Python {platform.python_version()},"
        f" numpy {numpy}"
    )


def cell(value: object) -> str:
    return str(value).replace("|", "\\|").replace("\n", " ")


def met_cell(met: object) -> str:
    return "—" if met is None else "yes" if met else "**no**"


def render_row(row: dict[str, object], command: str) -> str:
    cells = [f"`{row['row']}`", *(cell(row[f]) for f in FIELDS[1:5])]
    return "| " + " | ".join([*cells, met_cell(row["met"]), f"`{command}`"]) + " |"


HEADER = (
    "| row | workload | peer | measured | aim | met | command |\n|---|---|---|---|---|---|---|"
)
ROW_ID = re.compile(r"^\| `([^`]+)` \|")
STAMP = re.compile(r"^Generated by `python bench/run_all.py` on (\S+)")


def previous_rows(block: str) -> tuple[dict[str, str], str | None]:
    """The rows of an earlier table by id, and the date it was generated (None if by hand)."""
    rows = {m.group(1): line for line in block.splitlines() if (m := ROW_ID.match(line))}
    stamp = next((m.group(1) for line in block.splitlines() if (m := STAMP.match(line))), None)
    return rows, stamp


def kept(line: str, stamp: str | None) -> str:
    """An earlier row carried over, its measured cell marked with the run it came from."""
    if stamp is None or "(from " in line:
        return line
    cells = line.split(" | ")
    cells[3] += f" (from the {stamp} run)"
    return " | ".join(cells)


def render_block(
    benches: Sequence[Bench], outcomes: Sequence[Outcome], old_block: str, when: datetime
) -> str:
    """The marker block's new text: the stamp, then the rows in the order of ``benches``,
    fresh where the bench ran, else as they were; rows of no bench last, as they were."""
    old, stamp = previous_rows(old_block)
    ran = {outcome.bench.name: outcome for outcome in outcomes}
    lines, placed = [], set()
    for bench in benches:
        outcome = ran.get(bench.name)
        fresh = {str(row["row"]): row for row in outcome.rows} if outcome else {}
        command = " ".join(bench.command(quick=False))
        for row_id in [*bench.rows, *(r for r in fresh if r not in bench.rows)]:
            if row_id in fresh:
                lines.append(render_row(fresh[row_id], command))
            elif row_id in old:
                lines.append(kept(old[row_id], stamp))
            placed.add(row_id)
    lines += [kept(line, stamp) for row_id, line in old.items() if row_id not in placed]
    return (
        f"{BEGIN}\nGenerated by `python bench/run_all.py` on {when:%Y-%m-%d %H:%M} UTC:"
        f" {machine()}.\n\n{HEADER}\n" + "\n".join(lines) + f"\n{END}"
    )


def rewrite(
    readme: Path, benches: Sequence[Bench], outcomes: Sequence[Outcome], when: datetime
) -> None:
    """Replace the marker block of ``readme`` (ValueError when it has none)."""
    text = readme.read_text()
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise ValueError(f"{readme} has no {BEGIN} ... {END} block")
    block = render_block(benches, outcomes, text[start : end + len(END)], when)
    readme.write_text(text[:start] + block + text[end + len(END) :])


def select(benches: Sequence[Bench], only: Sequence[str] | None) -> list[Bench]:
    if not only:
        return list(benches)
    names = {b.name: b for b in benches}
    unknown = [n for n in only if n not in names]
    if unknown:
        raise Usage(f"no bench named {', '.join(unknown)}; there are: {', '.join(names)}")
    return [b for b in benches if b.name in only]


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python bench/run_all.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--quick", action="store_true", help="each bench's quick mode (CI)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="these benches (bench_NAME.py)")
    parser.add_argument(
        "--write",
        action=argparse.BooleanOptionalAction,
        help="rewrite bench/README.md's table (default: on for full runs, off with --quick)",
    )
    args = parser.parse_args(argv)
    if args.quick and args.write:
        parser.error("--write with --quick: quick sizes are not the table's figures")
    args.write = not args.quick if args.write is None else args.write
    return args


def main(
    argv: Sequence[str] | None = None,
    benches: Sequence[Bench] = BENCHES,
    root: Path = ROOT,
    readme: Path = README,
) -> int:
    args = parse(argv)
    try:
        chosen = select(benches, args.only)
    except Usage as error:
        print(f"run_all: {error}", file=sys.stderr)
        return 2
    mode = "quick" if args.quick else "full"
    print(f"run_all: {len(chosen)} benches, {mode} runs; {machine()}", flush=True)
    outcomes = []
    start = time.perf_counter()
    for i, bench in enumerate(chosen, 1):
        command = " ".join(bench.command(args.quick))
        print(f"[{i}/{len(chosen)}] {command}", end=" ... ", flush=True)
        outcome = run(bench, args.quick, root)
        outcomes.append(outcome)
        if outcome.failure:
            print(f"FAILED ({outcome.seconds:.1f} s)", flush=True)
        else:
            print(f"{len(outcome.rows)} rows in {outcome.seconds:.1f} s", flush=True)
        for note in outcome.notes:
            print(f"    note: {note}", flush=True)
    failed = [o for o in outcomes if o.failure]
    print(f"\nrun_all: {len(outcomes) - len(failed)} of {len(outcomes)} benches ran", end="")
    print(f" in {time.perf_counter() - start:.0f} s of wall")
    for outcome in outcomes:
        for row in outcome.rows:
            print(f"  {row['row']}: {row['measured']} (aim {row['aim']}, met {row['met']})")
    for outcome in failed:
        print(f"\nFAILED {outcome.bench.script}: {outcome.failure}", file=sys.stderr)
    if args.write:
        try:
            rewrite(readme, benches, outcomes, datetime.now(UTC))
        except (OSError, ValueError) as error:
            print(f"run_all: the table was not rewritten: {error}", file=sys.stderr)
            return 1
        print(f"rewrote the table of {readme}")
    return 1 if failed else 0


def entry() -> int:
    """main, with an interrupt reported in one line (no traceback reaches the user)."""
    try:
        return main()
    except KeyboardInterrupt:
        print("\nrun_all: interrupted", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(entry())
