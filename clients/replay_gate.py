"""``plotgate replay`` as a CI gate: its per-field tolerances (``--tolerances``), its
reports for CI (``--junit``, ``--summary-md``, ``--html``), tolerances learned from noise
(``--calibrate``, ``--runs``), latency as a regression (``--max-latency-ratio``) and
load from real traffic (``--pace``).

:func:`add_gate_arguments` adds the options to the replay command; :func:`prepare`
checks them and reads the tolerance file before the replay; :func:`finish` writes the
reports after it and turns a latency regression into exit 1; :func:`calibrate` is
``--calibrate``.
"""

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from plotgate.clients.replay import ReplayReport
    from plotgate.clients.tolerances import Rules

__all__ = ["Gate", "add_gate_arguments", "calibrate", "finish", "gate_rules", "prepare"]


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def _pace(text: str) -> float:
    from plotgate.clients.pace import speed_of

    try:
        return speed_of(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _runs(text: str) -> int:
    value = int(text) if text.isdigit() else 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def add_gate_arguments(parser: argparse.ArgumentParser) -> None:
    """The gate's options of ``plotgate replay``."""
    gate = parser.add_argument_group("CI gate")
    gate.add_argument(
        "--tolerances",
        type=Path,
        metavar="FILE",
        help="per-field tolerances: a TOML file of [[rule]] tables (operation glob, JSON "
        "path, rtol/atol/ignore/decision; docs/replay_tolerances.toml); the most specific "
        "rule wins, --rtol/--atol judge the rest",
    )
    gate.add_argument("--junit", type=Path, metavar="FILE", help="write JUnit XML here")
    gate.add_argument(
        "--summary-md", type=Path, metavar="FILE", help="write a Markdown job summary here"
    )
    gate.add_argument(
        "--html", type=Path, metavar="FILE", help="write a self-contained HTML report here"
    )
    gate.add_argument(
        "--calibrate",
        type=Path,
        metavar="OUT",
        help="replay --runs times, or against two known-good servers (--server A --server "
        "B), and write to OUT the tolerance file that passes every disagreement seen (with "
        "a margin); fields that never differed get no rule",
    )
    gate.add_argument(
        "--runs",
        type=_runs,
        default=3,
        metavar="N",
        help="with --calibrate: replays (default %(default)s)",
    )
    gate.add_argument(
        "--pace",
        type=_pace,
        metavar="1x|2x|max",
        help="with --server: send each exchange at its recorded time divided by this speed, "
        "open-loop (max: at once, 64 in flight); the report says if the sender fell behind",
    )
    gate.add_argument(
        "--max-latency-ratio",
        type=_positive,
        metavar="R",
        help="exit 1 when an operation's replayed p99 duration is over R times its recorded "
        "p99 (--server replays only: in-process durations are not the server's)",
    )


def gate_rules(args: argparse.Namespace) -> "Rules | None":
    """The rules of ``--tolerances`` over ``--rtol``/``--atol`` (None without the option);
    raises :class:`ToleranceFileError` for a file that cannot be used."""
    if args.tolerances is None:
        return None
    from plotgate.clients.tolerances import load_rules
    from plotgate.service.table import ENDPOINTS

    return load_rules(args.tolerances, args.rtol, args.atol, ENDPOINTS)


def _write(path: Path, make: Callable[["ReplayReport"], str], report: "ReplayReport") -> None:
    from plotgate.clients.replay_reports import write_report_file

    write_report_file(path, make(report))


def finish(args: argparse.Namespace, report: "ReplayReport", code: int) -> int:
    """Write the reports asked for and judge latency: the exit code after them (2 when a
    report cannot be written, said on stderr; 1 for a latency regression)."""
    from plotgate.clients.replay_reports import html_page, junit_xml, summary_markdown

    wanted: list[tuple[Path | None, Callable[[ReplayReport], str]]] = [
        (args.junit, junit_xml),
        (args.summary_md, summary_markdown),
        (args.html, html_page),
    ]
    slow = _latency_regressions(args, report)
    for line in slow:
        report.notes.append(line)
    for path, make in wanted:
        if path is None:
            continue
        try:
            _write(path, make, report)
        except OSError as exc:
            where = exc.filename or path
            print(f"plotgate replay: {where}: {exc.strerror or exc}", file=sys.stderr)
            return 2
    for line in slow:
        print(f"plotgate replay: {line}", file=sys.stderr)
    return max(code, 1) if slow and code != 2 else code


def _latency_regressions(args: argparse.Namespace, report: "ReplayReport") -> list[str]:
    ratio = args.max_latency_ratio
    if ratio is None:
        return []
    if args.server is None:
        print(
            "plotgate replay: --max-latency-ratio judges replays over HTTP only (--server): "
            "in-process durations are not a server's; not judged",
            file=sys.stderr,
        )
        return []
    found = []
    for operation, row in sorted(report.latency.items()):
        if row["replayed_p99"] > ratio * row["recorded_p99"]:
            found.append(
                f"LATENCY {operation}: replayed p99 {row['replayed_p99']:.4g} s is over "
                f"{ratio:g} x the recorded p99 {row['recorded_p99']:.4g} s"
            )
    return found


def calibrate(args: argparse.Namespace, replay_once: Callable[..., "ReplayReport"]) -> int:
    """``--calibrate OUT``: replay ``--runs`` times (``replay_once(observe=...)``), or
    against two servers (``--server A --server B``: :mod:`plotgate.clients.two_servers`),
    gather every disagreement, write the tolerance file; 0, or 2 when nothing was compared,
    the two servers answered different exchanges, or OUT cannot be written."""
    from plotgate.clients.calibrate import Noise, rules_toml
    from plotgate.clients.replay_reports import write_report_file

    noise = Noise()

    def observe(operation: str, recorded: Any, replayed: Any) -> None:
        noise.add(operation, recorded, replayed)

    compared = 0
    if getattr(args, "more_servers", ()):
        from plotgate.clients.two_servers import MisalignedAnswers, gather_two

        servers = args.server, args.more_servers[0]
        try:
            report = gather_two(servers, replay_once, noise, args.allow_empty)
        except MisalignedAnswers:
            print(
                f"plotgate replay: {servers[0]} and {servers[1]} answered different "
                "exchanges (a fault set aside by one): calibrate again",
                file=sys.stderr,
            )
            return 2
        compared, runs = report.compared, 0
    else:
        runs = args.runs
    for _ in range(runs):
        report = replay_once(observe=observe)
        noise.runs += 1
        compared += report.compared
        if report.exit_code(args.allow_empty) == 2:
            break
    if report.exit_code(args.allow_empty) == 2:
        print(report.text(), file=sys.stderr)
        return 2
    source = ", ".join(map(str, args.paths))
    try:
        write_report_file(args.calibrate, rules_toml(noise, args.rtol, args.atol, source))
    except OSError as exc:
        where = exc.filename or args.calibrate
        print(f"plotgate replay: {where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    print(
        f"{noise.runs} runs, {compared} answers compared: {len(noise.spreads)} fields "
        f"differed; rules written to {args.calibrate}"
    )
    return 0


@dataclass(frozen=True)
class Gate:
    """What the replay needs from the gate's options: the rules and the pace."""

    rules: "Rules | None"
    pace: float | None


def prepare(args: argparse.Namespace) -> Gate | int:
    """The gate's options checked (:func:`gate_rules`, ``--pace``), or 2 after a one-line
    message on stderr."""
    from plotgate.clients.tolerances import ToleranceFileError

    try:
        rules = gate_rules(args)
    except ToleranceFileError as exc:
        print(f"plotgate replay: --tolerances {args.tolerances}: {exc}", file=sys.stderr)
        return 2
    if args.pace is None:
        return Gate(rules, None)
    if args.server is None or args.out is not None or args.calibrate is not None:
        print(
            "plotgate replay: --pace sends to a live server (--server URL), without --out "
            "or --calibrate",
            file=sys.stderr,
        )
        return 2
    return Gate(rules, args.pace)
