"""Fleet replay on Dask: 2 workers against 1 (and the serial replay), the same report.

Writes ``--exchanges`` gates.test exchanges (``--candidates`` plots each) with the service's
recorder, a group commit every ``--group`` exchanges, rotating every ``--file-mib`` MiB (so
the recording is several files, and exchanges split across rotations), then replays the
folder: in process (``plotgate replay``), and on a LocalCluster of 1 and of 2
single-threaded worker processes (``plotgate replay --local-workers``), each started and
warmed (operations imported) before its clock starts. The reports must be byte-identical
(the JSON of ``--report``); the speed-up of 2 workers against 1 should be >= 1.8x.

    python bench/bench_fleet_replay.py --exchanges 100000
"""

import argparse
import json
import tempfile
import time
from pathlib import Path

from plotgate.clients.fleet import Judging, fleet_replay
from plotgate.clients.replay import ReplayReport, replay
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.registry import OPERATIONS, execute


def record(folder: Path, exchanges: int, candidates: int, group: int, file_bytes: int) -> None:
    plots = [
        {"frame": "cartesian", "x": 100.0 * i, "y": 5e4, "covariance": [[1e4, 0], [0, 1e4]]}
        for i in range(candidates)
    ]
    body = json.dumps(
        {"gate": {"kind": "ellipse", "P_G": 0.9}, "first": plots[0], "candidates": plots}
    ).encode()
    answer = execute(OPERATIONS["gates.test"], body)
    assert answer.status == 200
    recorder = Recorder(folder, OPERATIONS.values(), max_bytes=file_bytes).start()
    for i in range(exchanges):
        ex = recorder.request("gates.test", request_record(f"r{i}", "gates.test", body))
        recorder.response(ex, response_record(f"r{i}", "gates.test", 200, 0.001, answer.content))
        recorder.forget(ex)
        if i % group == group - 1:
            recorder.flush()
    recorder.close()


def _warm(dask_worker: object = None) -> None:
    from plotgate.service.registry import OPERATIONS, execute

    execute(OPERATIONS["gates.test"], b'{"gate": {"kind": "ellipse"}, "first": 1}')


def on_cluster(folder: Path, workers: int, part_bytes: int) -> tuple[float, ReplayReport]:
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        Client(local) as client,
    ):
        client.run(_warm)
        started = time.perf_counter()
        report = fleet_replay(
            folder, Judging(), address=local.scheduler_address, part_bytes=part_bytes
        )
        return time.perf_counter() - started, report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--exchanges", type=int, default=10**6)
    parser.add_argument("--candidates", type=int, default=20)
    parser.add_argument("--group", type=int, default=50, help="exchanges per group commit")
    parser.add_argument("--file-mib", type=float, default=8.0, help="rotate at this size")
    parser.add_argument("--part-bytes", type=int, default=2**20, help="bytes of chunks per part")
    parser.add_argument("--no-serial", action="store_true", help="skip the serial replay")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        started = time.perf_counter()
        record(folder, args.exchanges, args.candidates, args.group, int(args.file_mib * 2**20))
        files = sorted(folder.glob("*.mcap"))
        size = sum(f.stat().st_size for f in files)
        print(
            f"recorded {args.exchanges} exchanges in {len(files)} files, {size / 2**20:.1f} MiB, "
            f"in {time.perf_counter() - started:.1f} s"
        )
        reports = {}
        times = {}
        texts = {}
        if not args.no_serial:
            _warm()
            started = time.perf_counter()
            reports["serial"] = replay(folder, progress=False)
            times["serial"] = time.perf_counter() - started
        for workers in (1, 2):
            times[workers], reports[workers] = on_cluster(folder, workers, args.part_bytes)
        for key, seconds in times.items():
            texts[key] = json.dumps(reports[key].to_json(), indent=2, default=str)
            print(
                f"{key!s:>6}: {seconds:8.1f} s, {args.exchanges / seconds:8.0f} exchanges/s, "
                f"report {len(texts[key])} bytes, exit {reports[key].exit_code()}",
                flush=True,
            )
        print(f"2 workers against 1: {times[1] / times[2]:.2f}x")
        if "serial" in times:
            print(f"2 workers against serial: {times['serial'] / times[2]:.2f}x")
        same = len(set(texts.values())) == 1
        print(f"reports byte-identical: {same}")
        assert same and reports[1].compared == args.exchanges


if __name__ == "__main__":
    main()
