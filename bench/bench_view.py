"""How long ``plotgate view`` takes against the time to read the same recording.

The recording is bench_reading's: the service's recorder writes ``--exchanges`` gates.test
exchanges of 100 candidates (a flush per exchange). Then, best of ``--repeat`` each, wall
and CPU time of this process:

- **read**: :class:`plotgate.clients.recordings.Reader` over the folder, every message
  checked and paired (what ``inspect`` and ``cat`` cost);
- **read + values**: the same with each exchange's request and response values built (the
  least anything that draws an exchange must do);
- **scenes only**: the scene messages of every exchange built and encoded, from values
  already built (:class:`plotgate.service.scenes.Encoded`): the drawing's own cost;
- **view**: :func:`plotgate.clients.view.view`, the ``plotgate view`` code path: read, draw,
  encode, and write the originals and the scenes to a zstd-chunked MCAP.

    python bench/bench_view.py [--exchanges 15000 --repeat 3]

The issue's aim: view within 2x the time to read.
"""

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from bench.bench_reading import record  # noqa: E402 - after the sys.path line
from plotgate.clients.recordings import Reader  # noqa: E402
from plotgate.clients.view import view  # noqa: E402
from plotgate.service.scenes import Encoded  # noqa: E402


def timed(work: Callable[[], object], repeat: int) -> tuple[float, float]:
    """Best wall and best CPU seconds of ``repeat`` runs."""
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        work()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=15_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
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

        def draw() -> None:
            for ex in exchanges:
                scenes.exchange(ex.operation, ex.request, ex.response, ex.log_time)

        rows = {
            "read (checked, paired)": timed(lambda: sum(1 for _ in Reader(folder)), args.repeat),
            "read + values built": timed(values, args.repeat),
            "scenes only (built and encoded)": timed(draw, args.repeat),
            "plotgate view (read, draw, write)": timed(
                lambda: view(folder, out, scenes), args.repeat
            ),
        }
        size = out.stat().st_size
    read_wall, read_cpu = rows["read (checked, paired)"]
    print(f"{args.exchanges:,} gates.test exchanges of 100 candidates, best of {args.repeat}")
    print(f"view's output: {size / 2**20:.1f} MiB\n")
    print("| stage | wall s | CPU s | exchanges/s (CPU) | x read (CPU) |")
    print("|---|---:|---:|---:|---:|")
    for name, (wall, cpu) in rows.items():
        print(
            f"| {name} | {wall:.2f} | {cpu:.2f} | {args.exchanges / cpu:,.0f} | "
            f"{cpu / read_cpu:.2f} |"
        )
    print(f"\nview / read: {rows['plotgate view (read, draw, write)'][1] / read_cpu:.2f}x (CPU)")


if __name__ == "__main__":
    main()
