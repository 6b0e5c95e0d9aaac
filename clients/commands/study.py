"""``plotgate study [REQUEST.json]``: Fadeev et al.'s multistatic accuracy study."""

import argparse
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import add_where, at_least_two
from plotgate.clients.commands.output import json_object
from plotgate.clients.commands.where import on_cluster


def add_command(sub: Any) -> None:
    stu = sub.add_parser(
        "study",
        help="Fadeev et al.'s multistatic accuracy study: table and PNG (Fig. 3)",
        description="Monte Carlo of the multistatic solvers along a track (operation "
        "solves.study): curves 1-6 of Fadeev et al., Fig. 3 at every sample, checked against "
        "the CRLB. Default: the built-in scenario (one transmitter, three receivers at "
        "10 m/s, a target at 80 m/s crossing the baselines, 1000 runs: a few minutes); "
        "docs/examples/study_scenario.json is a quick one to start from. Each verdict "
        "carries its Monte Carlo standard error: NOT MET only for a shortfall beyond the "
        "noise (more than 2 standard errors; more at the worst of many samples), within "
        "noise when more runs would decide. The runs' solves go to a Dask cluster with --dask "
        "or --local-workers, with the same table. Exit 0, or 1 when a requirement is NOT MET "
        "(2: no cluster or no answer).",
    )
    stu.add_argument(
        "request", nargs="?", help="a JSON solves.study request (default: the built-in scenario)"
    )
    stu.add_argument("--runs", type=at_least_two, help="Monte Carlo runs (override)")
    stu.add_argument("--seed", type=int, help="noise seed (override)")
    stu.add_argument(
        "--no-tracks",
        action="store_true",
        help="skip curve 3 and the full track (most of the cost)",
    )
    stu.add_argument(
        "--table",
        type=Path,
        default=Path("multistatic_accuracy.md"),
        help="markdown table to write (default multistatic_accuracy.md)",
    )
    stu.add_argument(
        "--png",
        type=Path,
        default=Path("multistatic_accuracy.png"),
        help="figure to write (default multistatic_accuracy.png; needs plotgate[plot])",
    )
    stu.add_argument(
        "--no-png", dest="png", action="store_const", const=None, help="write no figure"
    )
    add_where(stu, "compute on this live server URL (default in-process)")
    stu.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.plots import MissingMatplotlib, matplotlib_classes
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
    try:
        if args.png is not None:
            matplotlib_classes()  # fail before computing for minutes
        answer = on_cluster(args, lambda: run_study(request, server=args.server))
    except (MissingMatplotlib, PlotgateClientError, ClusterUnavailable) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    args.table.parent.mkdir(parents=True, exist_ok=True)
    args.table.write_text(table(answer))
    written = [args.table]
    if args.png is not None:
        written.append(draw(answer, args.png))
    verdicts = checks(answer)
    for check in verdicts:
        print(f"{check.verdict}: {check.requirement}: {check.result}")
    print(
        f"NOT MET only for a shortfall beyond the Monte Carlo noise of {answer['runs']} runs "
        "(more than 2 standard errors; at the worst of n samples, the allowance noise alone "
        "passes 39 times in 40); within noise: more runs (--runs) decide"
    )
    print("wrote " + ", ".join(str(p) for p in written))
    return 1 if any(c.verdict == NOT_MET for c in verdicts) else 0
