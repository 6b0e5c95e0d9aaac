"""How long ``plotgate view`` takes against the time to read the same recording.

The recording is bench_reading's: the service's recorder writes ``--exchanges`` gates.test
exchanges of 100 candidates (a flush per exchange). Then, best of ``--repeat`` each, the
stages taken in turn within each round (so the machine's load falls on all of them alike),
wall and CPU time of this process:

- **read**: :class:`plotgate.clients.recordings.Reader` over the folder, every message
  checked and paired (what ``inspect`` and ``cat`` cost): the peer;
- **read + values**: the same with each exchange's request and response values built (what
  drawing one exchange at a time starts from);
- **scenes, one at a time**: every exchange's scene messages built and encoded from values
  already built (:meth:`plotgate.service.scenes.Encoded.exchange`: the drawing before
  issue 40);
- **scenes, batched**: the same from the records' bytes, 64 exchanges at a time
  (:meth:`~plotgate.service.scenes.Encoded.exchanges`: what ``view`` draws with);
- **view**: :func:`plotgate.clients.view.view`, the ``plotgate view`` code path: read, draw,
  encode, and write the originals and the scenes to a zstd-chunked MCAP.

    python bench/bench_view.py [--exchanges 15000 --repeat 3] [--quick]

``--quick`` (1,500 exchanges, one round) runs every stage for CI and asserts no time. The
issue's aim: view within 2x the time to read (CPU time; wall time is shown too). The last
line is the front table's row (``SUMMARY {...}``).
"""

import argparse
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from plotgate.clients.recordings import Reader
from plotgate.clients.view import BATCH, view
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.scenes import Encoded

AIM = 2.0


def record(folder: Path, exchanges: int) -> None:
    """The service's recording of ``exchanges`` gates.test exchanges of 100 candidates
    (bench_reading's)."""
    plots = [
        {"frame": "cartesian", "x": 100.0 * i, "y": 5e4, "covariance": [[1e4, 0], [0, 1e4]]}
        for i in range(100)
    ]
    body = json.dumps(
        {"gate": {"kind": "ellipse", "P_G": 0.9}, "first": plots[0], "candidates": plots}
    ).encode()
    answer = execute(OPERATIONS["gates.test"], body)
    assert answer.status == 200
    recorder = Recorder(folder, OPERATIONS.values()).start()
    for i in range(exchanges):
        ex = recorder.request("gates.test", request_record(f"r{i}", "gates.test", body))
        recorder.response(ex, response_record(f"r{i}", "gates.test", 200, 0.001, answer.content))
        recorder.flush()
        recorder.forget(ex)
    recorder.close()


def rounds(stages: dict[str, Callable[[], object]], repeat: int) -> dict[str, tuple[float, float]]:
    """Best wall and best CPU seconds of each stage, over ``repeat`` rounds of all."""
    best = {name: (float("inf"), float("inf")) for name in stages}
    for _ in range(repeat):
        for name, work in stages.items():
            wall, cpu = time.perf_counter(), time.process_time()
            work()
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            best[name] = (min(best[name][0], wall), min(best[name][1], cpu))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=15_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="1,500 exchanges, one round")
    args = parser.parse_args()
    if args.quick:
        args.exchanges, args.repeat = 1_500, 1
    scenes = Encoded()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "recording"
        record(folder, args.exchanges)
        exchanges = list(Reader(folder))
        for ex in exchanges:
            ex.request, ex.response  # noqa: B018 - built once, outside the timing below
        out = Path(tmp) / "scene.mcap"

        def values() -> None:
            for ex in Reader(folder):
                ex.request, ex.response  # noqa: B018 - the values, built

        def one_at_a_time() -> None:
            for ex in exchanges:
                scenes.exchange(ex.operation, ex.request, ex.response, ex.log_time)

        def batched() -> None:
            for start in range(0, len(exchanges), BATCH):
                scenes.exchanges(exchanges[start : start + BATCH])

        rows = rounds(
            {
                "read (checked, paired)": lambda: sum(1 for _ in Reader(folder)),
                "read + values built": values,
                "scenes, one at a time (from values)": one_at_a_time,
                "scenes, batched (from bytes)": batched,
                "plotgate view (read, draw, write)": lambda: view(folder, out, scenes),
            },
            args.repeat,
        )
        size = out.stat().st_size
    read_wall, read_cpu = rows["read (checked, paired)"]
    view_wall, view_cpu = rows["plotgate view (read, draw, write)"]
    print(f"{args.exchanges:,} gates.test exchanges of 100 candidates, best of {args.repeat}")
    print(f"view's output: {size / 2**20:.1f} MiB\n")
    print("| stage | wall s | CPU s | exchanges/s (CPU) | x read (CPU) |")
    print("|---|---:|---:|---:|---:|")
    for name, (wall, cpu) in rows.items():
        print(
            f"| {name} | {wall:.2f} | {cpu:.2f} | {args.exchanges / cpu:,.0f} | "
            f"{cpu / read_cpu:.2f} |"
        )
    ratio = view_cpu / read_cpu
    print(f"\nview / read: {ratio:.2f}x (CPU), {view_wall / read_wall:.2f}x (wall)")
    summary = {
        "row": "view-vs-read",
        "workload": f"plotgate view of {args.exchanges:,} gates.test exchanges (100 candidates)",
        "peer": "reading the same recording (Reader: checked, paired), same run",
        "measured": f"{ratio:.2f}x read (CPU; wall {view_wall / read_wall:.2f}x)",
        "aim": f"<= {AIM:g}x",
        "met": ratio <= AIM,
    }
    print("SUMMARY " + json.dumps(summary))


if __name__ == "__main__":
    main()
