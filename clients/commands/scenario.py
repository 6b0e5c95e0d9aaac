"""``plotgate scenario``: a simulated scenario and the tracks initiated in it (Mu et al.)."""

import argparse
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import command_parser, exit_status
from plotgate.clients.commands.output import json_object


def add_command(sub: Any) -> None:
    sce = command_parser(
        sub,
        "scenario",
        summary="draw a simulated scenario and its initiated tracks (Mu et al.)",
        description="Simulates Mu et al.'s scenario (5 ground targets at 25 m/s, P_D 0.8, "
        "Poisson clutter over a 15 km square) with initiation.simulate, initiates tracks "
        "with initiation.initiate scan by scan and draws the plots and the confirmed tracks "
        "as a PNG: true tracks green, false ones red dashed, missed targets grey dotted, the "
        "radar, the scan period and an inset zoomed on the targets. Prints the PNG's path.",
        exits=exit_status(
            (0, "the figure is written"),
            (
                2,
                "a usage error, a --config that is not a JSON object, matplotlib missing, "
                "or no answer from the server",
            ),
        ),
    )
    sce.add_argument(
        "--clutter",
        type=float,
        default=250.0,
        help="mean clutter plots per scan (default %(default)g)",
    )
    sce.add_argument("--scans", type=int, default=4, help="number of scans (default 4)")
    sce.add_argument("--seed", type=int, default=3, help="simulation seed (default 3)")
    sce.add_argument(
        "--mode",
        choices=("cartesian", "polar"),
        default="polar",
        help="initiation method (default polar)",
    )
    sce.add_argument("--v-max", type=float, default=30.0, help="largest speed, m/s (default 30)")
    sce.add_argument(
        "--config", help="a JSON file of initiation settings (overrides --mode and --v-max)"
    )
    sce.add_argument(
        "--out",
        type=Path,
        default=Path("scenario.png"),
        help="PNG to write (default scenario.png)",
    )
    sce.add_argument("--server", help="compute on this live server URL (default in-process)")
    sce.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.gate_figures import MissingMatplotlib
    from plotgate.clients.scenario_plot import default_settings, scenario_figure, simulate_request

    config = default_settings(args.mode, args.v_max)
    if args.config is not None:
        given = json_object(args.config)
        if given is None:
            return 2
        config = given
    request = simulate_request(args.clutter, args.scans, args.seed)
    try:
        out = scenario_figure(request, config, args.out, server=args.server)
    except (MissingMatplotlib, PlotgateClientError) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0
