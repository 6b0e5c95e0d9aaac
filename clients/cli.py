"""The ``plotgate`` command: serve, call, replay, recover, inspect, plot, study, scenario.

``plotgate serve`` runs the service (flags override the ``PLOTGATE_*`` settings);
``plotgate call OPERATION [REQUEST.json]`` runs any operation (``solves.position``,
``gates.probability`` ...) on a JSON request, in-process or on a server, and prints the
answer; ``plotgate replay FILE_OR_DIR`` re-runs a recorded session and exits 1 if any
answer changed; ``plotgate recover FILE`` writes a complete, indexed copy of a file a
killed server left; ``plotgate inspect FILE_OR_DIR`` prints per-operation counts and
latencies; ``plotgate plot {fig2,fig5,compare}`` draws seed 000's gating-probability
figures; ``plotgate study`` runs seed 001's multistatic accuracy study (Fig. 3) and
writes its table and figure; ``plotgate scenario`` draws a simulated scenario and the
tracks initiated in it (seed 002's figures).
"""

import argparse
import json
import os
import sys
from pathlib import Path

__all__ = ["main"]


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from service.config import Settings
    from service.connections import HeaderDeadline

    overrides = {
        "PLOTGATE_HOST": args.host, "PLOTGATE_PORT": args.port,
        "PLOTGATE_WORKERS": args.workers, "PLOTGATE_LOG_DIR": args.log_dir,
        "PLOTGATE_RECORD": args.record,
    }
    os.environ.update({k: str(v) for k, v in overrides.items() if v is not None})
    settings = Settings()
    uvicorn.run(
        "service.app:create_app",
        factory=True,
        host=settings.host,
        port=settings.port,
        workers=settings.workers,
        http=HeaderDeadline,
        log_level="info",
    )
    return 0


def _call(args: argparse.Namespace) -> int:
    """Print the answer (exit 0) or the problem (exit 1) of one request."""
    body = (sys.stdin.buffer.read() if args.request in (None, "-")
            else Path(args.request).read_bytes())
    if args.server is None:
        from service.registry import OPERATIONS, execute

        outcome = execute(OPERATIONS[args.operation], body)
        status, content = outcome.status, outcome.content
    else:
        import httpx

        from clients.client import SLOW_TIMEOUT
        from service.schemas import ENDPOINTS

        path = ENDPOINTS[args.operation].path
        answer = httpx.post(args.server.rstrip("/") + path, content=body, timeout=SLOW_TIMEOUT,
                            headers={"content-type": "application/json"})
        status, content = answer.status_code, answer.content
    sys.stdout.write(json.dumps(json.loads(content), indent=2) + "\n")
    return 0 if status < 400 else 1


def _replay(args: argparse.Namespace) -> int:
    from clients.replay import replay

    report = replay(
        args.path, server=args.server, rtol=args.rtol, atol=args.atol, out=args.out,
        progress=None,
    )
    print(report.text())
    if args.report:
        Path(args.report).write_text(json.dumps(report.to_json(), indent=2, default=str))
    return 0 if report.ok else 1


def _recover(args: argparse.Namespace) -> int:
    from clients.recover import recover

    done = recover(args.path, args.out, keep=args.keep)
    state = "complete" if done.was_complete else f"truncated ({done.stopped_by})"
    print(f"{done.source}: {state}; {done.messages} messages copied to {done.output}")
    return 0


def _inspect(args: argparse.Namespace) -> int:
    from clients.inspect import format_inspection, inspect

    summary = inspect(args.path)
    print(json.dumps(summary, indent=2) if args.json else format_inspection(summary))
    return 0


def _plot(args: argparse.Namespace) -> int:
    from clients.errors import PlotgateClientError
    from clients.plots import MissingMatplotlib, Setup, plot

    setup = Setup(tau=args.tau, v_min=args.v_min, v_max=args.v_max,
                  course_deg=args.course_deg, az_deg=args.az_deg)
    try:
        out = plot(args.figure, args.out, server=args.server, setup=setup, points=args.points)
    except (MissingMatplotlib, PlotgateClientError) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0


def _study(args: argparse.Namespace) -> int:
    from clients.errors import PlotgateClientError
    from clients.plots import MissingMatplotlib, matplotlib_classes
    from clients.study import DEFAULT_REQUEST, checks, draw, run_study, table

    request = dict(DEFAULT_REQUEST if args.request is None
                   else json.loads(Path(args.request).read_text()))
    for key, value in (("runs", args.runs), ("seed", args.seed)):
        if value is not None:
            request[key] = value
    if args.no_tracks:
        request["tracks"] = False
    try:
        if args.png is not None:
            matplotlib_classes()  # fail before computing for minutes
        answer = run_study(request, server=args.server)
    except (MissingMatplotlib, PlotgateClientError) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    args.table.parent.mkdir(parents=True, exist_ok=True)
    args.table.write_text(table(answer))
    written = [args.table]
    if args.png is not None:
        written.append(draw(answer, args.png))
    for check in checks(answer):
        print(f"{'met' if check.passed else 'NOT MET'}: {check.requirement}: {check.result}")
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


def _scenario(args: argparse.Namespace) -> int:
    from clients.errors import PlotgateClientError
    from clients.plots import MissingMatplotlib
    from clients.scenario_plot import scenario_figure

    config = {"mode": args.mode, "v_max": args.v_max, "capture_gate": "combined",
              "a_max": 10.0, "K_A": 3.0}
    if args.config is not None:
        config = json.loads(Path(args.config).read_text())
    request = {"scenario": {"clutter": args.clutter, "scans": args.scans}, "seed": args.seed}
    try:
        out = scenario_figure(request, config, args.out, server=args.server)
    except (MissingMatplotlib, PlotgateClientError) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0


def _at_least_two(text: str) -> int:
    value = int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"must be at least 2, got {value}")
    return value


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="plotgate", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="run the HTTP service, recording to MCAP")
    serve.add_argument("--host", help="listen address (PLOTGATE_HOST, default 127.0.0.1)")
    serve.add_argument("--port", type=int, help="port (PLOTGATE_PORT, default 8000)")
    serve.add_argument("--workers", type=int, help="worker processes (PLOTGATE_WORKERS)")
    serve.add_argument("--log-dir", help="recordings folder (PLOTGATE_LOG_DIR, ./recordings)")
    serve.add_argument("--no-record", dest="record", action="store_const", const=False,
                       help="do not record (PLOTGATE_RECORD=false)")
    serve.set_defaults(func=_serve)

    rep = sub.add_parser("replay", help="re-run recorded requests and compare the answers")
    rep.add_argument("path", type=Path, help="an MCAP file or a folder of them")
    rep.add_argument("--server", help="replay against this live server URL (default in-process)")
    rep.add_argument("--rtol", type=float, default=1e-9, help="relative float tolerance")
    rep.add_argument("--atol", type=float, default=1e-12, help="absolute float tolerance")
    rep.add_argument("--out", type=Path, help="write the replayed session to this MCAP file")
    rep.add_argument("--report", type=Path, help="write the report as JSON here")
    rep.set_defaults(func=_replay)

    rec = sub.add_parser("recover", help="a complete, indexed copy of a killed server's file",
                         description="Copies every complete record of an MCAP file (one a "
                         "killed server left without summary and index) into a new file with "
                         "summary and index, and renames the damaged original to "
                         "<name>.partial so replaying the folder reads each exchange once.")
    rec.add_argument("path", type=Path, help="the MCAP file")
    rec.add_argument("--out", type=Path, help="the copy (default <stem>.recovered.mcap)")
    rec.add_argument("--keep", action="store_true", help="do not rename the original")
    rec.set_defaults(func=_recover)

    from service.schemas import ENDPOINTS

    call = sub.add_parser(
        "call", help="run one operation on a JSON request and print the answer",
        description="Runs in-process through this build's registry (what the server would "
        "answer), or on a live server with --server. Exit 0 on an answer, 1 on a problem.",
    )
    call.add_argument("operation", choices=sorted(ENDPOINTS), help="operation name")
    call.add_argument("request", nargs="?", help="JSON request file (default: stdin)")
    call.add_argument("--server", help="a live server URL (default in-process)")
    call.set_defaults(func=_call)

    ins = sub.add_parser("inspect", help="per-operation counts, errors and latencies")
    ins.add_argument("path", type=Path, help="an MCAP file or a folder of them")
    ins.add_argument("--json", action="store_true", help="print JSON instead of a table")
    ins.set_defaults(func=_inspect)

    from clients.plots import DEFAULT_FILES, FIGURES

    plo = sub.add_parser(
        "plot", help="draw seed 000's gating-probability figures (needs plotgate[plot])",
        description="fig2: ring gate, conditional probability against speed (20, 50 km) and "
        "range (200, 300 m/s) for three sensor errors (seed 000 Fig. 2); fig5: the same for "
        "the combined gate, P_G 0.9 (Fig. 5); compare: unconditional probability against "
        "range for the ring, combined and expanded gates.",
    )
    plo.add_argument("figure", choices=FIGURES, help="which figure")
    plo.add_argument("--out", type=Path,
                     help="PNG to write (default " + ", ".join(DEFAULT_FILES.values()) + ")")
    plo.add_argument("--server", help="compute on this live server URL (default in-process)")
    plo.add_argument("--course-deg", type=float, default=0.0,
                     help="target course, degrees clockwise from north (default 0)")
    plo.add_argument("--az-deg", type=float, default=0.0,
                     help="azimuth of the first mark, degrees (default 0: due north)")
    plo.add_argument("--tau", type=float, default=5.0, help="interval between marks, s (5)")
    plo.add_argument("--v-min", type=float, default=100.0, help="gate's minimum speed (100)")
    plo.add_argument("--v-max", type=float, default=500.0, help="gate's maximum speed (500)")
    plo.add_argument("--points", type=_at_least_two,
                     help="values per curve (default 81 speeds, 96 ranges, 15 unconditional)")
    plo.set_defaults(func=_plot)

    stu = sub.add_parser(
        "study", help="seed 001's multistatic accuracy study: table and PNG (Fig. 3)",
        description="Monte Carlo of the multistatic solvers along a track (operation "
        "solves.study): curves 1-6 of seed 001 Fig. 3 at every sample, checked against "
        "the CRLB. Default: the built-in scenario (one transmitter, three receivers at "
        "10 m/s, a target at 80 m/s crossing the baselines, 1000 runs: a few minutes).",
    )
    stu.add_argument("request", nargs="?",
                     help="a JSON solves.study request (default: the built-in scenario)")
    stu.add_argument("--runs", type=_at_least_two, help="Monte Carlo runs (override)")
    stu.add_argument("--seed", type=int, help="noise seed (override)")
    stu.add_argument("--no-tracks", action="store_true",
                     help="skip curve 3 and the full track (most of the cost)")
    stu.add_argument("--table", type=Path, default=Path("multistatic_accuracy.md"),
                     help="markdown table to write (default multistatic_accuracy.md)")
    stu.add_argument("--png", type=Path, default=Path("multistatic_accuracy.png"),
                     help="figure to write (default multistatic_accuracy.png; needs "
                     "plotgate[plot])")
    stu.add_argument("--no-png", dest="png", action="store_const", const=None,
                     help="write no figure")
    stu.add_argument("--server", help="compute on this live server URL (default in-process)")
    stu.set_defaults(func=_study)

    sce = sub.add_parser(
        "scenario", help="draw a simulated scenario and its initiated tracks (seed 002)",
        description="Simulates seed 002's scenario (5 ground targets at 25 m/s, P_D 0.8, "
        "Poisson clutter over a 15 km square) with initiation.simulate, initiates tracks "
        "with initiation.initiate and draws the plots and the confirmed tracks as a PNG.",
    )
    sce.add_argument("--clutter", type=float, default=250.0, help="clutter per scan (250)")
    sce.add_argument("--scans", type=int, default=4, help="number of scans (4)")
    sce.add_argument("--seed", type=int, default=3, help="simulation seed (3)")
    sce.add_argument("--mode", choices=("cartesian", "polar"), default="polar",
                     help="initiation method (polar)")
    sce.add_argument("--v-max", type=float, default=30.0, help="largest speed, m/s (30)")
    sce.add_argument("--config", help="a JSON file of initiation settings (overrides "
                     "--mode and --v-max)")
    sce.add_argument("--out", type=Path, default=Path("scenario.png"),
                     help="PNG to write (scenario.png)")
    sce.add_argument("--server", help="compute on this live server URL (default in-process)")
    sce.set_defaults(func=_scenario)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``plotgate`` console script."""
    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except FileNotFoundError as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
