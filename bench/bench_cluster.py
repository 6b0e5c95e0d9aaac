"""initiation.evaluate in-process and on a LocalCluster of 1 and 2 workers: time and identity.

Run from the repository root (needs ``pip install -e ".[cluster]"``)::

    python bench/bench_cluster.py                    # 4,000 runs at clutter 250
    python bench/bench_cluster.py --runs 400         # quick

The evaluation is the README's score configuration on Mu et al.'s scenario at clutter 250
(the largest run count the schema's work limit lets one request make there: 4,000 runs x
4 scans x 255 plots). Each way runs it once through
:func:`plotgate.core.initiation.evaluate.evaluate` with the mapper of
:func:`plotgate.service.cluster.cluster`; the cluster's start (about a second) is timed
apart. The answers must be equal bit for bit. The machine has 2 cores, which the workers
and the scheduler share.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from plotgate.core.initiation import InitiationConfig
from plotgate.core.initiation.evaluate import evaluate
from plotgate.core.initiation.simulate import mu_scenario
from plotgate.service.cluster import cluster, mapper

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=4000)
    parser.add_argument("--seed", type=int, default=2026)
    args = parser.parse_args(argv)
    config = InitiationConfig(
        **json.loads((ROOT / "docs/examples/score_initiation.json").read_text())
    )
    scenario = mu_scenario(250.0)
    rows, answers = [], []
    for workers in (None, 1, 2):
        start = time.perf_counter()
        with cluster(local_workers=workers):
            ready = time.perf_counter()
            ev = evaluate(scenario, config, args.runs, args.seed, mapper=mapper())
            done = time.perf_counter()
        answers.append((ev.true.tolist(), ev.false.tolist(), ev.mean_true, ev.mean_false))
        rows.append((workers, ready - start, done - ready))
    base = rows[0][2]
    print(
        f"{args.runs} runs at clutter 250, seed {args.seed}: {answers[0][2]:.3f} targets, "
        f"{answers[0][3]:.3f} false tracks a run\n"
    )
    print("| where | cluster start, s | evaluation, s | speed-up over in-process |")
    print("|---|---:|---:|---:|")
    for workers, up, took in rows:
        where = "in-process" if workers is None else f"LocalCluster, {workers} worker(s)"
        print(f"| {where} | {up:.1f} | {took:.1f} | {base / took:.2f}x |")
    identical = all(a == answers[0] for a in answers)
    print(f"\nbit-identical answers: {identical}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
