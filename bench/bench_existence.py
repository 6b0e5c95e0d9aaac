"""Existence confirmation (IPDA, issue 38) on Mu et al.'s scenario: tuning and report.

Tuning (``--seeds 2026 1 2 3``) sweeps existence_confirm per clutter level; the report
(default seeds 11-14, fixed before any figure) runs the documented configuration of each
level (``docs/examples/existence_clutter_<level>.json``) and the score configuration of
the README on the same runs. Run r of seed s is run r of
``evaluate(mu_scenario(clutter), config, runs, s)``. Figures: mean and its standard
error (sample standard deviation over the square root of the pooled runs).

    python bench/bench_existence.py --clutter 250 --runs 500            # report
    python bench/bench_existence.py --clutter 250 --runs 150 --seeds 2026 1 2 3 \\
        --confirm 0.8 0.85 0.9                                        # tuning
    python bench/bench_existence.py --quick     # clutter 250, 25 runs of seed 11 (CI)

The report of a level ends with its ``SUMMARY`` line of the front table (bench/README.md):
the documented configuration's targets and false tracks against the level's aim (issue 38),
beside the score configuration on the same runs when ``--score`` is given.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from plotgate.core.initiation import InitiationConfig
from plotgate.core.initiation.evaluate import evaluate
from plotgate.core.initiation.simulate import mu_scenario

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "docs" / "examples"
HELD_OUT = (11, 12, 13, 14)
AIMS = {20.0: (4.08, 0.02), 250.0: (4.05, 0.3), 500.0: (4.0, 2.0), 1000.0: (3.8, 5.0)}
"""Issue 38's aim of each clutter level: at least these targets initiated a run, at most
these false tracks."""


def level_config(clutter: float) -> dict[str, Any]:
    """The documented existence configuration of a clutter level."""
    settings: dict[str, Any] = json.loads(
        (EXAMPLES / f"existence_clutter_{clutter:g}.json").read_text()
    )
    return settings


def point(settings: dict[str, Any], clutter: float, runs: int, seeds: list[int]) -> dict:
    """Pooled targets and false tracks of ``runs`` runs of every seed."""
    config = InitiationConfig(**settings)
    start = time.perf_counter()
    cpu = time.process_time()
    results = [evaluate(mu_scenario(clutter), config, runs, s) for s in seeds]
    true = np.concatenate([r.true for r in results])
    false = np.concatenate([r.false for r in results])
    return {
        "clutter": clutter,
        "runs": int(true.size),
        "true": float(true.mean()),
        "se_true": float(true.std(ddof=1) / np.sqrt(true.size)),
        "false": float(false.mean()),
        "se_false": float(false.std(ddof=1) / np.sqrt(false.size)),
        "seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clutter", type=float, default=250.0, help="plots per scan (250)")
    parser.add_argument("--runs", type=int, default=500, help="runs per seed")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(HELD_OUT))
    parser.add_argument("--confirm", type=float, nargs="*", help="existence_confirm values")
    parser.add_argument("--score", action="store_true", help="also the README's score point")
    parser.add_argument("--quick", action="store_true", help="25 runs of seed 11, --score (CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.seeds, args.score = 25, [11], True
    base = level_config(args.clutter)
    grid = [{**base, "existence_confirm": c} for c in args.confirm] if args.confirm else [base]
    if args.score:
        score = json.loads((EXAMPLES / "score_initiation.json").read_text())
        grid.append(score)
    points = []
    for settings in grid:
        row = point(settings, args.clutter, args.runs, args.seeds)
        what = settings.get("existence_confirm", "score README")
        print(json.dumps({"setting": what, "seeds": args.seeds, **row}), flush=True)
        points.append(row)
    if not args.confirm:
        report(args.clutter, args.runs, args.seeds, points[0], points[1] if args.score else None)
    return 0


def report(clutter: float, runs: int, seeds: list[int], ours: dict, score: dict | None) -> None:
    """The SUMMARY line of the documented configuration at ``clutter``."""
    least_true, most_false = AIMS[clutter]
    pooled = f"{runs} runs x seeds {', '.join(map(str, seeds))}"
    summary(
        f"existence.clutter{clutter:g}",
        f"existence confirmation (IPDA), Mu et al.'s scenario, clutter {clutter:g}, {pooled}:"
        " targets / false tracks a run",
        "score confirmation (the README's), same runs" if score else "—",
        f"{ours['true']:.3f} ± {ours['se_true']:.3f} / {ours['false']:.3f}"
        + (f" (score: {score['true']:.3f} / {score['false']:.3f})" if score else ""),
        f">= {least_true} / <= {most_false}",
        ours["true"] >= least_true and ours["false"] <= most_false,
    )


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    raise SystemExit(main())
