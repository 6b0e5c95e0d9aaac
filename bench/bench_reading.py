"""How fast recordings are read: mcap's stream reader against plotgate's bounded reader.

Writes one recording with the service's recorder (gates.test exchanges of 100 candidates,
a flush per exchange as under load), then reads it, best of ``--repeat``:

- mcap's ``StreamReader`` with CRCs checked, records only, and with every message parsed
  by ``json.loads`` (how recordings were read before: the baseline);
- :class:`plotgate.clients.scan.Scan` (records only: bounded memory, CRC and size checks, resync);
- :class:`plotgate.clients.recordings.Reader` (every message parsed, checked and paired: what
  inspect, cat and replay read).

    python bench/bench_reading.py --exchanges 20000
"""

import argparse
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from mcap.records import Message
from mcap.stream_reader import StreamReader

from plotgate.clients.recordings import Reader
from plotgate.clients.scan import Scan
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.registry import OPERATIONS, execute


def record(folder: Path, exchanges: int) -> Path:
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
    [path] = folder.glob("*.mcap")
    return path


def best(read: Callable[[], int], repeat: int) -> tuple[float, int]:
    times, count = [], 0
    for _ in range(repeat):
        started = time.perf_counter()
        count = read()
        times.append(time.perf_counter() - started)
    return min(times), count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = record(Path(tmp), args.exchanges)
        size = path.stat().st_size
        readers = {
            "mcap StreamReader (CRCs checked)": lambda: sum(
                1 for _ in StreamReader(str(path), validate_crcs=True).records
            ),
            "mcap StreamReader + json.loads of each message (before)": lambda: sum(
                1
                for r in StreamReader(str(path), validate_crcs=True).records
                if isinstance(r, Message) and json.loads(r.data)
            ),
            "plotgate.clients.scan.Scan": lambda: sum(1 for _ in Scan(path)),
            "plotgate.clients.recordings.Reader (parsed, paired)": lambda: sum(
                1 for _ in Reader(path)
            ),
        }
        print(f"{path.name}: {size / 2**20:.1f} MiB, {args.exchanges} exchanges")
        print("| reader | best s | MiB/s | items |")
        print("|---|---:|---:|---:|")
        for name, read in readers.items():
            seconds, count = best(read, args.repeat)
            print(f"| {name} | {seconds:.2f} | {size / 2**20 / seconds:.0f} | {count} |")


if __name__ == "__main__":
    main()
