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
    parser.add_argument("--clutter", type=float, required=True)
    parser.add_argument("--runs", type=int, default=500, help="runs per seed")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(HELD_OUT))
    parser.add_argument("--confirm", type=float, nargs="*", help="existence_confirm values")
    parser.add_argument("--score", action="store_true", help="also the README's score point")
    args = parser.parse_args(argv)
    base = level_config(args.clutter)
    grid = [{**base, "existence_confirm": c} for c in args.confirm] if args.confirm else [base]
    if args.score:
        score = json.loads((EXAMPLES / "score_initiation.json").read_text())
        grid.append(score)
    for settings in grid:
        row = point(settings, args.clutter, args.runs, args.seeds)
        what = settings.get("existence_confirm", "score README")
        print(json.dumps({"setting": what, "seeds": args.seeds, **row}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
