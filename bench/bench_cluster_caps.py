"""The largest evaluation a cluster takes: 10^4 runs at clutter 250 through a live server.

Issue 29's must-show. ``plotgate serve`` runs in a subprocess twice: alone, where the
request is refused at parse (422 naming the cap), and with ``PLOTGATE_DASK_SCHEDULER`` on a
LocalCluster of N single-threaded worker processes on 127.0.0.1 started by this script,
where it is accepted and run. The request is the README's score configuration on Mu et
al.'s scenario at clutter 250, 10^4 runs (1.02e7 simulated plots). Reported: the status,
the wall time of the request (the cluster's start apart) and the server process's peak
RSS while it ran, sampled every 0.1 s with psutil (the results are gathered there).

    python bench/bench_cluster_caps.py [--workers 2] [--runs 10000]
"""

import argparse
import json
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx
import psutil
from distributed import LocalCluster

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.support.servers import serve  # noqa: E402


def _body(runs: int) -> dict:
    config = json.loads((ROOT / "docs/examples/score_initiation.json").read_text())
    return {"config": config, "scenario": {"clutter": 250.0}, "runs": runs, "seed": 2026}


def _peak_rss(pid: int, stop: threading.Event, peak: list[int]) -> None:
    """The largest RSS of process ``pid`` until ``stop``, into ``peak[0]``."""
    proc = psutil.Process(pid)
    while not stop.wait(0.1):
        try:
            peak[0] = max(peak[0], proc.memory_info().rss)
        except psutil.Error:
            return


def _post(url: str, body: dict, pid: int) -> tuple[int, float, int, str]:
    stop, peak = threading.Event(), [psutil.Process(pid).memory_info().rss]
    sampler = threading.Thread(target=_peak_rss, args=(pid, stop, peak), daemon=True)
    sampler.start()
    start = time.perf_counter()
    try:
        r = httpx.post(url + "/v1/initiation/evaluate", json=body, timeout=3600.0)
    finally:
        seconds = time.perf_counter() - start
        stop.set()
        sampler.join()
    detail = r.json().get("detail", "") if r.status_code >= 400 else ""
    if r.status_code == 200:
        a = r.json()
        detail = f"{a['mean_true']:.3f} targets, {a['mean_false']:.3f} false tracks a run"
    return r.status_code, seconds, peak[0], detail


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--runs", type=int, default=10_000)
    args = parser.parse_args(argv)
    body = _body(args.runs)
    env = {"PLOTGATE_DASK_TIMEOUT_S": "3600"}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        with serve(Path(tmp) / "alone", env=env, ready_s=300) as (proc, url):
            rows.append(("no scheduler", 0.0, *_post(url, body, proc.pid)))
        start = time.perf_counter()
        with LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=":0",
        ) as local:
            started = time.perf_counter() - start
            env["PLOTGATE_DASK_SCHEDULER"] = local.scheduler_address
            with serve(Path(tmp) / "cluster", env=env, ready_s=300) as (proc, url):
                rows.append(
                    (f"{args.workers} local workers", started, *_post(url, body, proc.pid))
                )
    print(f"{args.runs} runs at clutter 250 (score configuration), seed 2026\n")
    print(
        "| server | cluster start, s | status | request wall, s | server peak RSS, MiB | answer |"
    )
    print("|---|---:|---:|---:|---:|---|")
    for where, started, status, seconds, peak, detail in rows:
        print(
            f"| {where} | {started:.1f} | {status} | {seconds:.1f} | {peak / 2**20:.0f} | "
            f"{detail[:200]} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
