"""Recording's write path, in process: the MCAP writers side by side, and compaction.

**Writers.** ``--exchanges`` exchanges of two messages (a request and a response of
``--bytes`` bytes each), handed to the OS every ``--per-commit`` exchanges (1: an exchange
alone, as at 1 client; 6: a turn of the loop at 10 clients), into a file on ``--folder``:

- ``mcap chunked``: mcap's ``Writer`` with LZ4 chunks, ``flush()`` per commit (closes a
  chunk: the recorder before issue 25);
- ``mcap unchunked``: ``Writer(use_chunking=False)``, the stream flushed per commit;
- ``foxglove-sdk chunked`` / ``unchunked``: ``foxglove.open_mcap`` with a channel per
  topic (``jsonschema`` schema, ``json`` messages: the SDK logs raw bytes,
  ``BaseChannel.log(msg: bytes, log_time=...)``), ``MCAPWriter.flush()`` per commit; only
  when ``foxglove-sdk`` is installed (``pip install foxglove-sdk``);
- ``struct + writev``: :func:`plotgate.service.recording.records.message_header` and one
  ``writev`` per commit (:class:`plotgate.service.recording.files.RecordingFile`);
- ``Recorder``: the recorder itself in plain code (``request``, ``response``, ``flush``:
  the records, the write, the file check, the bookkeeping of exchanges in flight).

Each is timed per exchange, best of ``--repeat``.

**Steps at one client.** One exchange at a time on a running uvloop loop, as the service
records it with one client: each step's CPU time (``time.thread_time_ns`` around it, the
cost of reading the clock taken off), so the recording's share of a request is accounted
for to the call: the two records built, the request added (its exchange, its header, the
commit scheduled), the response added and committed at once (one ``writev``, one
``fstat``, the bookkeeping), the metrics' flush histogram, the loop's turn. ``writev``
and ``fstat`` alone, on another file, say what the system calls cost by themselves.

**Compaction.** The ``Recorder`` file compacted with LZ4 and with zstd chunks: time to
compact, size, and time for :class:`plotgate.clients.mcap_reader.RecordReader` and mcap's
reader to read every message back.

``--quick`` (CI: no time asserted) writes 1,000 exchanges once and compacts 300. The last
lines are the front table's rows (``SUMMARY {json}``, no aim: ``met`` null): the
``Recorder`` against the bare ``struct + writev`` floor per commit size, and zstd
compaction against LZ4.

    python bench/bench_record_writers.py [--exchanges 10000 --bytes 1400 --per-commit 1,6]
        [--quick]
"""

import argparse
import asyncio
import contextlib
import json
import os
import random
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from unittest import mock

import uvloop
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from plotgate.clients.mcap_reader import RecordReader
from plotgate.service.metrics import Metrics
from plotgate.service.recording import Recorder, compaction, request_record, response_record
from plotgate.service.recording.files import RecordingFile
from plotgate.service.recording.records import file_head, message_header
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas import request_schema, response_schema

OP = "gates.test"
TOPICS = (f"{OP}/request", f"{OP}/response")


def _channels() -> list[tuple[str, str, bytes]]:
    op = OPERATIONS[OP]
    schemas = (request_schema(op.request), response_schema(op.response))
    return [
        (topic, f"plotgate.{topic.replace('/', '.')}", json.dumps(schema).encode())
        for topic, schema in zip(TOPICS, schemas, strict=True)
    ]


Write = Callable[[Path, int, int, bytes], None]


def mcap_writer(chunked: bool) -> Write:
    def run(path: Path, exchanges: int, per_commit: int, message: bytes) -> None:
        with open(path, "wb") as stream:
            writer = Writer(stream, compression=CompressionType.LZ4, use_chunking=chunked)
            writer.start(profile="", library="plotgate")
            ids = [
                writer.register_channel(t, "json", writer.register_schema(n, "jsonschema", s))
                for t, n, s in _channels()
            ]
            for i in range(exchanges):
                now = time.time_ns()
                writer.add_message(ids[0], now, message, now)
                writer.add_message(ids[1], now, message, now)
                if (i + 1) % per_commit == 0:
                    writer.flush()
                    stream.flush()
            writer.finish()

    return run


def foxglove_writer(chunked: bool) -> Write:
    import foxglove

    def run(path: Path, exchanges: int, per_commit: int, message: bytes) -> None:
        context = foxglove.Context()
        options = foxglove.mcap.MCAPWriteOptions(
            compression=foxglove.mcap.MCAPCompression.Lz4, use_chunks=chunked
        )
        with foxglove.open_mcap(
            path, allow_overwrite=True, context=context, writer_options=options
        ) as writer:
            channels = [
                foxglove.Channel(
                    t,
                    message_encoding="json",
                    context=context,
                    schema=foxglove.Schema(name=n, encoding="jsonschema", data=s),
                )
                for t, n, s in _channels()
            ]
            for i in range(exchanges):
                now = time.time_ns()
                channels[0].log(message, log_time=now)
                channels[1].log(message, log_time=now)
                if (i + 1) % per_commit == 0:
                    writer.flush()

    return run


def struct_writev(path: Path, exchanges: int, per_commit: int, message: bytes) -> None:
    head, ids = file_head(_channels(), {})
    file = RecordingFile(path, 1, head)
    buffers: list[bytes] = []
    for i in range(exchanges):
        now = time.time_ns()
        buffers += (message_header(ids[TOPICS[0]], 2 * i, now, len(message)), message)
        buffers += (message_header(ids[TOPICS[1]], 2 * i + 1, now, len(message)), message)
        if (i + 1) % per_commit == 0:
            file.write(buffers)
            buffers = []
    file.close()


def recorder(path: Path, exchanges: int, per_commit: int, message: bytes) -> None:
    rec = Recorder(path.parent, [OPERATIONS[OP]], file_name=path.name).start()
    for i in range(exchanges):
        exchange = rec.request(OP, message)
        rec.response(exchange, message)
        if (i + 1) % per_commit == 0:
            rec.flush()
    with mock.patch("plotgate.service.recording.recorder.compact"):  # timed apart, below
        rec.close()


def writers() -> dict[str, Write]:
    found: dict[str, Write] = {
        "mcap chunked (before)": mcap_writer(True),
        "mcap unchunked": mcap_writer(False),
    }
    try:
        found["foxglove-sdk chunked"] = foxglove_writer(True)
        found["foxglove-sdk unchunked"] = foxglove_writer(False)
    except ImportError:
        print("foxglove-sdk not installed: pip install foxglove-sdk to measure it")
    found["struct + writev"] = struct_writev
    found["Recorder (plain code)"] = recorder
    return found


def _summary(row: str, workload: str, peer: str, measured: str) -> None:
    """One row of bench/README.md's front table (no aim here: ``met`` null)."""
    fields = {"row": row, "workload": workload, "peer": peer, "measured": measured}
    print(
        "SUMMARY "
        + json.dumps({**fields, "aim": "none (issue 40's aims are end to end)", "met": None})
    )


def time_writers(folder: Path, args: argparse.Namespace) -> dict[tuple[str, int], float]:
    """Seconds per exchange of every writer at every commit size, best of ``--repeat``."""
    message = b'{"request_id": "r", "body": "%s"}' % (b"x" * (args.bytes - 35))
    print(
        f"{args.exchanges} exchanges of two {len(message)}-byte messages; "
        f"us per exchange, best of {args.repeat}"
    )
    print("\n| writer | " + " | ".join(f"{n} per commit" for n in args.per_commit) + " |")
    print("|---|" + "---:|" * len(args.per_commit))
    took: dict[tuple[str, int], float] = {}
    for name, write in writers().items():
        cells = []
        for per_commit in args.per_commit:
            best = float("inf")
            for _ in range(args.repeat):
                path = folder / "w.mcap"
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()
                started = time.perf_counter()
                write(path, args.exchanges, per_commit, message)
                best = min(best, time.perf_counter() - started)
            took[name, per_commit] = best / args.exchanges
            cells.append(f"{best / args.exchanges * 1e6:.1f}")
        print(f"| {name} | " + " | ".join(cells) + " |")
    return took


STEP_BODY = b"""{"gate": {"kind": "combined", "tau": 5, "v_min": 100, "v_max": 500, "P_G": 0.9},
  "first": {"frame": "polar", "r": 50000, "az_deg": 0, "sigma_r": 200, "sigma_az_deg": 0.5},
  "candidates": [
    {"frame": "polar", "r": 51000, "az_deg": 0.5, "sigma_r": 200, "sigma_az_deg": 0.5},
    {"frame": "cartesian", "x": 0, "y": 52600, "covariance": [[40000, 0], [0, 40000]]},
    {"frame": "cartesian", "x": 0, "y": 60000, "covariance": [[40000, 0], [0, 40000]]}
  ]}"""
"""bench/bench_service.py's request: the README's combined-gate test."""

STEPS = (
    "request_record",
    "Recorder.arequest",
    "response_record",
    "Recorder.aresponse (alone: commit)",
    "Recorder.forget",
)
LOOP_TURN = "the loop's next turn (the driver's own, not counted)"


async def _steps(folder: Path, exchanges: int) -> dict[str, float]:
    """CPU ns of each recording step of one exchange at a time, summed over ``exchanges``."""
    metrics = Metrics(lambda: None)
    rec = Recorder(folder, OPERATIONS.values(), on_flush=metrics.flush.observe).start()
    answer = execute(OPERATIONS[OP], STEP_BODY).content
    clock = time.thread_time_ns
    spent = dict.fromkeys((*STEPS, LOOP_TURN), 0)
    for i in range(exchanges + 1000):  # the first thousand warm up, uncounted
        rid = f"{i:032x}"
        t0 = clock()
        asked = request_record(rid, OP, STEP_BODY, True, None)
        t1 = clock()
        exchange = await rec.arequest(OP, asked)
        t2 = clock()
        told = response_record(rid, OP, 200, 0.000321, answer)
        t3 = clock()
        await rec.aresponse(exchange, told)
        t4 = clock()
        rec.forget(exchange)
        t5 = clock()
        await asyncio.sleep(0)
        t6 = clock()
        if i >= 1000:
            took = (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5)
            for step, ns in zip((*STEPS, LOOP_TURN), took, strict=True):
                spent[step] += ns
    rec.close()
    return spent


def _syscalls(folder: Path, exchanges: int) -> dict[str, float]:
    """CPU ns of a commit's two system calls alone: ``writev`` of an exchange's four
    buffers to a file, and ``fstat`` of it."""
    head, ids = file_head(_channels(), {})
    file = RecordingFile(folder / "syscalls.mcap", 1, head)
    buffers = [message_header(ids[TOPICS[0]], 1, 0, 560), b"x" * 560]
    buffers += [message_header(ids[TOPICS[1]], 2, 0, 300), b"y" * 300]
    clock = time.thread_time_ns
    spent = {"writev alone": 0, "fstat alone": 0}
    for _ in range(exchanges):
        t0 = clock()
        os.writev(file.fd, buffers)
        t1 = clock()
        os.fstat(file.fd)
        t2 = clock()
        spent["writev alone"] += t1 - t0
        spent["fstat alone"] += t2 - t1
    file.close()
    file.path.unlink()
    return spent


def time_steps(folder: Path, args: argparse.Namespace) -> dict[str, float]:
    """Microseconds of CPU per exchange of every recording step at one client, best of
    ``--repeat`` (each step its own best), the clock's own cost taken off."""
    clock = time.thread_time_ns
    t0 = clock()
    for _ in range(10_000):
        clock()
    read_ns = (clock() - t0) / 10_000
    best: dict[str, float] = {}
    for _ in range(args.repeat):
        spent = uvloop.run(_steps(folder, args.exchanges))
        spent.update(_syscalls(folder, args.exchanges))
        for step, ns in spent.items():
            us = max(ns / args.exchanges - read_ns, 0.0) / 1e3
            best[step] = min(best.get(step, us), us)
    total = sum(best[step] for step in STEPS)
    print(
        f"\nrecording steps at one client, us of CPU per exchange, best of {args.repeat} "
        f"(clock read {read_ns:.0f} ns, taken off)"
    )
    print("| step | us | share |")
    print("|---|---:|---:|")
    for step, us in best.items():
        share = f"{us / total:.0%}" if step in STEPS else "(inside the commit)"
        share = "" if step == LOOP_TURN else share
        print(f"| {step} | {us:.2f} | {share} |")
    print(f"| all steps | {total:.2f} | 100% |")
    return {**best, "all": total}


def _read_scan(path: Path) -> int:
    return sum(1 for _ in RecordReader(path))


def _read_mcap(path: Path) -> int:
    with open(path, "rb") as f:
        return sum(1 for _ in make_reader(f).iter_messages(log_time_order=False))


def time_compaction(
    folder: Path, args: argparse.Namespace, source: Path, exchanges: int
) -> dict[str, float]:
    """Seconds to compact ``source`` with LZ4 and with zstd chunks."""
    size = source.stat().st_size / 2**20
    print(f"\ncompaction of {size:.1f} MiB ({exchanges} gates.test exchanges), best of")
    print(f"{args.repeat} reads (RecordReader: records only; mcap: make_reader().iter_messages())")
    print("| chunks | compact s | MiB | RecordReader records s | mcap messages s |")
    print("|---|---:|---:|---:|---:|")
    took: dict[str, float] = {}
    for codec in (CompressionType.LZ4, CompressionType.ZSTD):
        path = folder / f"{codec.name}.mcap"
        path.write_bytes(source.read_bytes())
        compaction.COMPRESSION = codec
        started = time.perf_counter()
        assert compaction.compact(path)
        took[codec.name.lower()] = time.perf_counter() - started
        reads = []
        for read in (_read_scan, _read_mcap):
            best = float("inf")
            for _ in range(args.repeat):
                started = time.perf_counter()
                read(path)
                best = min(best, time.perf_counter() - started)
            reads.append(best)
        print(
            f"| {codec.name.lower()} | {took[codec.name.lower()]:.2f} | "
            f"{path.stat().st_size / 2**20:.1f} | "
            f"{reads[0]:.2f} | {reads[1]:.2f} |"
        )
    return took


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=10_000)
    parser.add_argument("--bytes", type=int, default=1400)
    parser.add_argument("--per-commit", default="1,6")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--folder", type=Path, default=None, help="default: a temporary one")
    parser.add_argument("--quick", action="store_true", help="1,000 exchanges, once")
    args = parser.parse_args()
    args.per_commit = [int(n) for n in args.per_commit.split(",")]
    if args.quick:
        args.exchanges, args.repeat = 1000, 1
    with tempfile.TemporaryDirectory(dir=args.folder) as tmp:
        folder = Path(tmp)
        writing = time_writers(folder, args)
        steps = time_steps(folder, args)
        source = folder / "recorded.mcap"
        compacted = 300 if args.quick else args.exchanges
        recorded(source, compacted)
        compacting = time_compaction(folder, args, source, compacted)
    for n in args.per_commit:
        ours, floor = writing["Recorder (plain code)", n], writing["struct + writev", n]
        _summary(
            f"record_writers.recorder.per{n}",
            f"recording {args.exchanges} exchanges ({args.bytes}-byte messages), {n} per "
            "commit, in process",
            "struct + writev: the headers and one writev, nothing else",
            f"{ours * 1e6:.1f} us an exchange, {ours / floor:.2f}x the floor",
        )
    _summary(
        "record_writers.steps.c1",
        "recording one exchange at one client on a running loop (the service's request and "
        "answer), CPU",
        "its own writev + fstat, the system calls of a commit",
        f"{steps['all']:.1f} us an exchange, of which writev {steps['writev alone']:.1f} "
        f"and fstat {steps['fstat alone']:.1f}",
    )
    _summary(
        "record_writers.compaction.zstd",
        f"compacting {compacted} recorded gates.test exchanges (100 candidates)",
        "the same with LZ4 chunks",
        f"{compacting['zstd']:.2f} s, {compacting['zstd'] / compacting['lz4']:.2f}x LZ4",
    )


def recorded(path: Path, exchanges: int) -> None:
    """gates.test exchanges as recorded: 100 candidates at seeded random places (9 KB),
    the answer's own JSON, one commit each."""
    rng = random.Random(25)
    rec = Recorder(path.parent, [OPERATIONS[OP]], file_name=path.name).start()
    for i in range(exchanges):
        plots = [
            {
                "frame": "cartesian",
                "x": rng.uniform(-5e4, 5e4),
                "y": rng.uniform(0, 1e5),
                "covariance": [[1e4, 0], [0, 1e4]],
            }
            for _ in range(100)
        ]
        body = json.dumps(
            {"gate": {"kind": "ellipse", "P_G": 0.9}, "first": plots[0], "candidates": plots}
        ).encode()
        answer = execute(OPERATIONS[OP], body)
        exchange = rec.request(OP, request_record(f"r{i}", OP, body, True))
        rec.response(exchange, response_record(f"r{i}", OP, 200, 0.001, answer.content))
        rec.flush()
    with mock.patch("plotgate.service.recording.recorder.compact"):
        rec.close()


if __name__ == "__main__":
    main()
