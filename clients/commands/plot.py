"""``plotgate plot {fig2,fig5,compare}``: Konovalov's gating-probability figures."""

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
from plotgate.clients.commands.where import on_cluster


def add_command(sub: Any) -> None:
    from plotgate.clients.gate_figures import DEFAULT_FILES, FIGURES

    plo = command_parser(
        sub,
        "plot",
        summary="draw Konovalov's gating-probability figures (needs plotgate[plot])",
        description="fig2: ring gate, conditional probability against speed (at 20 and 50 km) "
        "and range (at 200 and 300 m/s) for three sensor errors (Konovalov, Fig. 2); fig5: "
        "the same for the combined gate, P_G 0.9 (Fig. 5); compare: unconditional "
        "probability against range for the ring, combined and expanded gates, whose points "
        "(seconds each) go to a Dask cluster with --dask or --local-workers (the conditional "
        "figures' curves cost milliseconds and stay in this process), with the same numbers. "
        "Prints the PNG's path.",
        exits=exit_status(
            (0, "the figure is written"),
            (
                2,
                "a usage error, matplotlib missing, no answer from the server, or no cluster",
            ),
        ),
    )
    plo.add_argument("figure", choices=FIGURES, help="which figure")
    plo.add_argument(
        "--out", type=Path, help="PNG to write (default " + ", ".join(DEFAULT_FILES.values()) + ")"
    )
    add_where(
        plo,
        "compute on this live server URL (default in-process)",
        "in-process, with the compare figure's points on this Dask scheduler",
        "in-process, with the compare figure's points on a local Dask cluster of N worker "
        "processes (started and stopped by the command)",
    )
    plo.add_argument(
        "--course-deg",
        type=float,
        default=0.0,
        help="target course, degrees clockwise from north (default 0)",
    )
    plo.add_argument(
        "--az-deg",
        type=float,
        default=0.0,
        help="azimuth of the first mark, degrees clockwise from north (default 0: due north)",
    )
    plo.add_argument(
        "--tau", type=float, default=5.0, help="interval between marks, s (default 5)"
    )
    plo.add_argument(
        "--v-min", type=float, default=100.0, help="gate's minimum speed, m/s (default 100)"
    )
    plo.add_argument(
        "--v-max", type=float, default=500.0, help="gate's maximum speed, m/s (default 500)"
    )
    plo.add_argument(
        "--points",
        type=at_least_two,
        help="values per curve (default 81 speeds, 96 ranges, 15 unconditional)",
    )
    plo.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.gate_figures import MissingMatplotlib, Setup, plot
    from plotgate.service.cluster import ClusterUnavailable

    setup = Setup(
        tau=args.tau,
        v_min=args.v_min,
        v_max=args.v_max,
        course_deg=args.course_deg,
        az_deg=args.az_deg,
    )
    try:
        out = on_cluster(
            args,
            lambda: plot(
                args.figure, args.out, server=args.server, setup=setup, points=args.points
            ),
        )
    except (MissingMatplotlib, PlotgateClientError, ClusterUnavailable) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0
