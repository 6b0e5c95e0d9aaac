"""Every heavy job in-process and on a LocalCluster of 1 and 2 workers: time, CPU, identity.

Run from the repository root (needs ``pip install -e ".[cluster]"``)::

    python bench/bench_cluster.py            # the full sizes below (about 15 minutes)
    python bench/bench_cluster.py --quick    # smaller jobs (about 2 minutes)

The jobs, each answered through the operation registry as the service and ``plotgate
call`` answer it (no work caps):

- ``initiation.evaluate``: the README's score configuration on Mu et al.'s scenario at
  clutter 250, 4,000 runs (160 chunks of 25 runs);
- ``solves.study``: the documented accuracy study (``plotgate study``'s default: 1,000
  runs, 200 samples, tracks; 10 chunks of 100 runs);
- ``identification.simulate``: 4,545,454 runs of 50 + 5 bearings (250 chunks of 18,181
  runs), ten times the one-core cap: the size a cluster takes (``Endpoint.cluster_caps``);
  the one-core cap's largest, 454,545 runs, is under a second of CPU, about the cost of
  Dask's own scheduling of its 25 chunks.

Each cluster is started once (its workers warmed: plotgate imported and its kernels loaded
by a tiny job of each kind) and runs every job; "start" is that start-up, "job" the job
alone, "job + start" the two together (what one ``plotgate call --local-workers N`` of
that job costs). CPU is the seconds of CPU of this process and of every worker during the
job. Answers must be equal byte for byte in-process and on every cluster (exit 1
otherwise). On a machine shared with other work the wall times are noisy; the CPU
seconds, and the ratios of runs measured in the same invocation, less so.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def jobs(quick: bool = False) -> dict[str, dict[str, Any]]:
    """The request of each job; ``quick``: a tenth of the runs, and the study on its first
    50 samples with 400 runs (4 chunks)."""
    from plotgate.clients.study import DEFAULT_REQUEST

    config = json.loads((ROOT / "docs/examples/score_initiation.json").read_text())
    study = {**DEFAULT_REQUEST}
    if quick:
        study.update(runs=400, sample_times=study["sample_times"][:50])
    return {
        "initiation.evaluate": {
            "runs": 400 if quick else 4000,
            "seed": 2026,
            "scenario": {"clutter": 250},
            "config": config,
        },
        "solves.study": study,
        "identification.simulate": {"runs": 454_545 if quick else 4_545_454, "seed": 2026},
    }


def answer(name: str, body: dict[str, Any]) -> bytes:
    """The operation's answer to ``body`` (raises on a problem: a bench answers)."""
    from plotgate.service.registry import OPERATIONS, execute

    outcome = execute(OPERATIONS[name], json.dumps(body).encode())
    if outcome.status != 200:
        raise RuntimeError(f"{name}: {outcome.status} {outcome.content[:300]!r}")
    return bytes(outcome.content)


def warm() -> None:
    """A tiny job of each kind: plotgate imported and its kernels loaded in this process."""
    tiny = jobs(quick=True)
    tiny["solves.study"].update(sample_times=[0.0, 0.1, 0.2, 0.3])
    for name, body in tiny.items():
        answer(name, {**body, "runs": 2})


@dataclass(frozen=True)
class Run:
    """One job run: its answer, wall seconds, and CPU seconds of each process (this one,
    then each worker)."""

    answer: bytes
    wall: float
    cpu: list[float]

    @property
    def busiest(self) -> float:
        """CPU seconds of the busiest worker (of this process, in-process): on a machine
        with a core free for each, the job's wall time."""
        return max(self.cpu[1:] or self.cpu)


def timed(name: str, body: dict[str, Any], cpu: Callable[[], list[float]]) -> Run:
    """The job's answer, wall seconds and the CPU seconds ``cpu`` counts meanwhile."""
    c0, t0 = cpu(), time.perf_counter()
    out = answer(name, body)
    wall = time.perf_counter() - t0
    return Run(out, wall, [b - a for a, b in zip(c0, cpu(), strict=True)])


def in_process(requests: dict[str, dict[str, Any]]) -> dict[str, Run]:
    warm()
    return {
        name: timed(name, body, lambda: [time.process_time()]) for name, body in requests.items()
    }


def on_cluster(workers: int, requests: dict[str, dict[str, Any]]) -> tuple[float, dict[str, Run]]:
    """Start-up seconds of a LocalCluster of ``workers``, and each job's run on it."""
    from distributed import Client, LocalCluster

    from plotgate.service.cluster import cluster, numba_threads

    t0 = time.perf_counter()
    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
            env={"NUMBA_NUM_THREADS": str(numba_threads(workers))},  # as --local-workers
        ) as local,
        Client(local) as monitor,
        cluster(address=local.scheduler_address),
    ):
        monitor.run(warm)
        start = time.perf_counter() - t0

        def cpu() -> list[float]:
            spent = monitor.run(time.process_time)
            return [time.process_time(), *(spent[w] for w in sorted(spent))]

        return start, {name: timed(name, body, cpu) for name, body in requests.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller jobs")
    args = parser.parse_args(argv)
    requests = jobs(args.quick)
    alone = in_process(requests)
    ways = {n: on_cluster(n, requests) for n in (1, 2)}
    print(
        "| job | runs | where | start, s | job, s | job + start, s | CPU s: all (busiest worker) |"
    )
    print("|---|---:|---|---:|---:|---:|---:|")
    for name, body in requests.items():
        run = alone[name]
        print(
            f"| {name} | {body['runs']} | in-process | 0 | {run.wall:.1f} | {run.wall:.1f} | "
            f"{sum(run.cpu):.1f} |"
        )
        for n, (start, results) in ways.items():
            run = results[name]
            print(
                f"| {name} | {body['runs']} | {n} worker(s) | {start:.1f} | {run.wall:.1f} | "
                f"{start + run.wall:.1f} | {sum(run.cpu):.1f} ({run.busiest:.1f}) |"
            )
    print("\n| job | 2 workers vs 1: job | job + start | busiest worker's CPU | all CPU, 2 / 1 |")
    print("|---|---:|---:|---:|---:|")
    for name in requests:
        (s1, one), (s2, two) = ((start, results[name]) for start, results in ways.values())
        print(
            f"| {name} | {one.wall / two.wall:.2f}x | {(s1 + one.wall) / (s2 + two.wall):.2f}x | "
            f"{one.busiest / two.busiest:.2f}x | {sum(two.cpu) / sum(one.cpu):.2f} |"
        )
    identical = all(
        results[name].answer == alone[name].answer
        for _, results in ways.values()
        for name in requests
    )
    print(f"\nbit-identical answers in-process and on 1 and 2 workers: {identical}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
