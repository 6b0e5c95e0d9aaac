"""How fast recordings are read: plotgate's reader against the C-level limit, in both forms.

Writes one recording with the service's recorder (gates.test exchanges of 100 candidates, a
flush per exchange as under load; as many files as rotation makes), and copies its records
into the two forms a recording takes:

- **compacted**: chunked, LZ4-compressed, indexed (mcap's writer, 1 MiB chunks), the form of
  a closed file;
- **unchunked**: message records at top level (``use_chunking=False``), the form of a live
  file being written.

Then reads each form, best of ``--repeat``:

- the **C-level limit**: every chunk decompressed by the C codec, plus every message parsed
  by msgspec (values built), no checks, no pairing; and the same with msgspec validating each
  message's JSON without building its values (what the reader's check costs at least);
- mcap's ``StreamReader`` with CRCs checked, records only (the baseline of an ordinary
  reader);
- :class:`plotgate.clients.recordings.Reader`: every message checked (every byte of JSON,
  its envelope, UTF-8, depth, long integers), requests and responses paired: what inspect,
  cat and replay read; then the same with every exchange's values built (``request`` and
  ``response``), as replay needs them.

First, the aim's workload: :func:`plotgate.clients.inspect.inspect` (what ``plotgate inspect``
runs, its imports paid: start-up subtracted) over the recording as the recorder wrote it,
against mcap's own Python reader (``StreamReader``, CRCs checked, records only) over the
same files; the aim is 50,000 exchanges/s of wall-clock.

    python bench/bench_reading.py [--exchanges 12000 --repeat 3] [--quick]

``--quick`` reads 2,000 exchanges once (CI: it asserts no times). The last lines are the
front table's row (``SUMMARY {json}``).

Figures are exchanges per second, from wall-clock and from CPU time; the ratios are to the
C-level limits of the same form measured in the same run (CPU time: other work on the
machine moves the wall-clock).
"""

import argparse
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import lz4.frame
import msgspec
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from plotgate.clients.inspect import inspect
from plotgate.clients.mcap_reader import Located, RecordReader
from plotgate.clients.recordings import Reader
from plotgate.service.recording import Recorder, request_record, response_record
from plotgate.service.registry import OPERATIONS, execute

CHUNK_BYTES = 2**20
AIM = 50_000
"""Exchanges per second of wall-clock the reading aims at (issue 40)."""


def record(folder: Path, exchanges: int) -> list[Path]:
    """The service's recording of ``exchanges`` gates.test exchanges: every file it wrote."""
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
    return sorted(folder.glob("*.mcap"))


def copy(files: list[Path], out: Path, chunked: bool) -> Path:
    """Every record of ``files`` in one file: chunked and compressed, or unchunked."""
    with open(out, "wb") as stream:
        writer = Writer(
            stream,
            chunk_size=CHUNK_BYTES,
            compression=CompressionType.LZ4 if chunked else CompressionType.NONE,
            use_chunking=chunked,
        )
        writer.start(library="bench_reading")
        schemas: dict[tuple[str, int], int] = {}
        channels: dict[tuple[str, int], int] = {}
        for path in files:
            for item in RecordReader(path):
                assert isinstance(item, Located), item
                record, key = item.record, str(path)
                if isinstance(record, Schema):
                    schemas[key, record.id] = writer.register_schema(
                        record.name, record.encoding, record.data
                    )
                elif isinstance(record, Channel):
                    channels[key, record.id] = writer.register_channel(
                        record.topic,
                        record.message_encoding,
                        schemas.get((key, record.schema_id), 0),
                        record.metadata,
                    )
                elif isinstance(record, Message):
                    writer.add_message(
                        channels[key, record.channel_id],
                        record.log_time,
                        record.data,
                        record.publish_time,
                        record.sequence,
                    )
        writer.finish()
    return out


def c_level(path: Path) -> tuple[Callable[[], int], Callable[[], int]]:
    """The C-level limit for ``path``: its chunks' compressed bytes (or its messages, when
    unchunked) taken out first, then timed: decompression plus a parse of every message,
    values built; and the same with msgspec validating each message without building it."""
    chunks, loose = [], []
    for record in StreamReader(str(path), skip_magic=False, emit_chunks=True).records:
        if isinstance(record, Chunk):
            chunks.append(record.data)
        elif isinstance(record, Message):
            loose.append(record.data)
    values = msgspec.json.Decoder()
    validate = msgspec.json.Decoder(msgspec.Struct)

    def messages(data: bytes) -> list[bytes]:
        """The message data of a decompressed chunk (MCAP Message records: opcode 5)."""
        out, at = [], 0
        while at < len(data):
            opcode, length = data[at], int.from_bytes(data[at + 1 : at + 9], "little")
            if opcode == 5:
                out.append(data[at + 9 + 22 : at + 9 + length])
            at += 9 + length
        return out

    inside = [m for chunk in chunks for m in messages(lz4.frame.decompress(chunk))]

    def run(decode: Callable[[bytes], object]) -> Callable[[], int]:
        def timed() -> int:
            for chunk in chunks:
                lz4.frame.decompress(chunk)
            for data in inside or loose:
                decode(data)
            return len(inside or loose) // 2

        return timed

    return run(values.decode), run(validate.decode)


def best(read: Callable[[], object], repeat: int) -> tuple[float, float]:
    """The shortest of ``repeat`` runs, in seconds: wall-clock, and this process's CPU time
    (on a machine shared with other work, the CPU time is the steadier figure)."""
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        read()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def readers(path: Path) -> dict[str, Callable[[], object]]:
    full, validated = c_level(path)

    def built() -> int:
        count = 0
        for exchange in Reader(path):
            count += exchange.request is not None and exchange.response is not None
        return count

    return {
        "C-level limit: decompress + parse (values built)": full,
        "C-level limit: decompress + validate (msgspec)": validated,
        "mcap StreamReader (CRCs checked, records only)": lambda: sum(
            1 for _ in StreamReader(str(path), validate_crcs=True).records
        ),
        "Reader (checked, paired)": lambda: sum(1 for _ in Reader(path)),
        "Reader + values built": built,
    }


def mcap_records(files: list[Path]) -> int:
    """mcap's own Python reader over ``files``: every record, CRCs checked."""
    return sum(1 for f in files for _ in StreamReader(str(f), validate_crcs=True).records)


def summary(n: int, inspected: tuple[float, float], peer: tuple[float, float]) -> None:
    """The front table's row: ``inspect`` against the aim, mcap's Python reader beside it."""
    rate = n / inspected[0]
    row = {
        "row": "reading",
        "workload": f"plotgate inspect of {n:,} gates.test exchanges as recorded "
        "(in process: start-up subtracted; wall)",
        "peer": f"mcap StreamReader (Python, CRCs checked, records only): "
        f"{n / peer[0]:,.0f} exchanges/s",
        "measured": f"{rate:,.0f} exchanges/s ({n / inspected[1]:,.0f}/s of CPU; "
        f"{peer[0] / inspected[0]:.2f}x mcap's Python reader)",
        "aim": f">= {AIM:,}/s",
        "met": rate >= AIM,
    }
    print("SUMMARY " + json.dumps(row))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exchanges", type=int, default=12_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="2,000 exchanges, once (CI)")
    args = parser.parse_args()
    if args.quick:
        args.exchanges, args.repeat = 2_000, 1
    n = args.exchanges
    with tempfile.TemporaryDirectory() as tmp:
        files = record(Path(tmp) / "recorded", n)
        size = sum(p.stat().st_size for p in files) / 2**20
        print(f"{n} exchanges; best of {args.repeat}; rates in exchanges/s")
        inspected = best(lambda: inspect(files), args.repeat)
        peer = best(lambda: mcap_records(files), args.repeat)
        paired = best(lambda: sum(1 for _ in Reader(files)), args.repeat)
        print(f"as recorded ({len(files)} files, {size:.1f} MiB):")
        for name, (wall, cpu) in (
            ("inspect()", inspected),
            ("Reader (checked, paired)", paired),
            ("mcap StreamReader (CRCs checked, records only)", peer),
        ):
            print(f"  {name}: {n / wall:,.0f}/s wall, {n / cpu:,.0f}/s CPU")
        print(
            "| form | reader | wall s | CPU s | /s (wall) | /s (CPU) | x limit, built "
            "(CPU) | x limit, validated (CPU) |"
        )
        print("|---|---|---:|---:|---:|---:|---:|---:|")
        for form, chunked in (("compacted", True), ("unchunked", False)):
            path = copy(files, Path(tmp) / f"{form}.mcap", chunked)
            name = f"{form} ({path.stat().st_size / 2**20:.1f} MiB)"
            times = {reader: best(read, args.repeat) for reader, read in readers(path).items()}
            built, validated = (cpu for _, cpu in list(times.values())[:2])
            for reader, (wall, cpu) in times.items():
                print(
                    f"| {name} | {reader} | {wall:.3f} | {cpu:.3f} "
                    f"| {n / wall:,.0f} | {n / cpu:,.0f} "
                    f"| {built / cpu:.2f} | {validated / cpu:.2f} |"
                )
        summary(n, inspected, peer)


if __name__ == "__main__":
    main()
