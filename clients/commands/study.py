"""``plotgate study [REQUEST.json]``: Fadeev et al.'s multistatic accuracy study."""

import argparse
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import (
    add_where,
    at_least_two,
    command_parser,
    exit_status,
)
from plotgate.clients.commands.output import json_object
from plotgate.clients.commands.where import on_cluster

TABLE_NAME, FIGURE_NAME = "multistatic_accuracy.md", "multistatic_accuracy.png"
"""The files ``--out DIR`` writes."""


def add_command(sub: Any) -> None:
    stu = command_parser(
        sub,
        "study",
        summary="Fadeev et al.'s multistatic accuracy study: table and PNG (Fig. 3)",
        description="Monte Carlo of the multistatic solvers along a track (operation "
        "solves.study): curves 1-6 of Fadeev et al., Fig. 3 at every sample, checked against "
        "the CRLB. Default: the built-in scenario (one transmitter, three receivers at "
        "10 m/s, a target at 80 m/s crossing the baselines, 1000 runs: a few minutes); "
        "docs/examples/study_scenario.json is a quick one to start from (seconds). Each "
        "verdict carries its Monte Carlo standard error: NOT MET only for a shortfall beyond "
        "the noise (more than 2 standard errors; more at the worst of many samples), within "
        "noise when more runs would decide. The runs' solves go to a Dask cluster with --dask "
        "or --local-workers, with the same table.\n\n"
        "Prints the verdicts and a sentence that sums them up; writes files only where told: "
        "--out DIR (the table and the figure), --table FILE, --png FILE.",
        exits=exit_status(
            (0, "every requirement met, or within noise"),
            (1, "a requirement NOT MET"),
            (2, "a usage error, a request that is not a JSON object, no cluster or no answer"),
        ),
    )
    stu.add_argument(
        "request", nargs="?", help="a JSON solves.study request (default the built-in scenario)"
    )
    stu.add_argument("--runs", type=at_least_two, help="Monte Carlo runs (override)")
    stu.add_argument("--seed", type=int, help="noise seed (override)")
    stu.add_argument(
        "--no-tracks",
        action="store_true",
        help="skip curve 3 and the full track (most of the cost)",
    )
    stu.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help=f"write {TABLE_NAME} and {FIGURE_NAME} into this folder (default none)",
    )
    stu.add_argument("--table", type=Path, help="markdown table to write (default none)")
    stu.add_argument(
        "--png", type=Path, help="figure to write (default none; needs plotgate[plot])"
    )
    stu.add_argument("--no-png", action="store_true", help="with --out: write no figure")
    add_where(stu, "compute on this live server URL (default in-process)")
    stu.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.gate_figures import MissingMatplotlib, matplotlib_classes
    from plotgate.clients.study import DEFAULT_REQUEST, NOT_MET, checks, draw, run_study, table
    from plotgate.service.cluster import ClusterUnavailable

    request = dict(DEFAULT_REQUEST) if args.request is None else json_object(args.request)
    if request is None:
        return 2
    for key, value in (("runs", args.runs), ("seed", args.seed)):
        if value is not None:
            request[key] = value
    if args.no_tracks:
        request["tracks"] = False
    table_path, png_path = _targets(args)
    try:
        if png_path is not None:
            matplotlib_classes()  # fail before computing for minutes
        answer = on_cluster(args, lambda: run_study(request, server=args.server))
    except (MissingMatplotlib, PlotgateClientError, ClusterUnavailable) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    written = []
    if table_path is not None:
        table_path.parent.mkdir(parents=True, exist_ok=True)
        table_path.write_text(table(answer))
        written.append(table_path)
    if png_path is not None:
        written.append(draw(answer, png_path))
    verdicts = checks(answer)
    for check in verdicts:
        print(f"{check.verdict}: {check.requirement}: {check.result}")
    print(_sentence([c.verdict for c in verdicts], answer["runs"]))
    if written:
        print("wrote " + ", ".join(str(p) for p in written))
    else:
        print("wrote no file (--out DIR writes the table and the figure)")
    return 1 if any(c.verdict == NOT_MET for c in verdicts) else 0


def _targets(args: argparse.Namespace) -> tuple[Path | None, Path | None]:
    """The table and figure to write: --table and --png, else in --out's folder (the
    figure unless --no-png); None for each not asked for."""
    table_path, png_path = args.table, args.png
    if args.out is not None:
        table_path = table_path or args.out / TABLE_NAME
        png_path = png_path or (None if args.no_png else args.out / FIGURE_NAME)
    return table_path, png_path


def _sentence(verdicts: list[str], runs: int) -> str:
    """The verdicts summed up in a sentence a newcomer reads without the docs."""
    from plotgate.clients.study import NOT_MET, WITHIN_NOISE

    missed, unsure = verdicts.count(NOT_MET), verdicts.count(WITHIN_NOISE)
    if missed:
        return (
            f"Verdict: {missed} of {len(verdicts)} requirements NOT MET: the solvers miss "
            f"the accuracy asked of them by more than 2 standard errors of the Monte Carlo "
            f"noise of {runs} runs, more than chance explains."
        )
    if unsure:
        return (
            f"Verdict: nothing missed beyond the noise, but {unsure} of {len(verdicts)} "
            f"requirements are within the Monte Carlo noise of {runs} runs: more runs "
            "(--runs) decide."
        )
    return (
        f"Verdict: all {len(verdicts)} requirements met: over {runs} Monte Carlo runs the "
        "solvers come as close to the Cramer-Rao bound (the best accuracy the geometry "
        "allows) as asked."
    )
