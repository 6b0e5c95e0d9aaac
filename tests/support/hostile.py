"""A generator of hostile recordings, and a runner that puts the CLI through them.

:func:`corpus` writes, from one sound recording, the files ``plotgate inspect``,
``replay``, ``recover`` and ``cat`` must survive: the recording cut at every record
boundary and inside chunks (unfinished, as a killed writer leaves it: not damage); records
with wrong lengths and CRCs; compression bombs (one that lies about its size, one that
declares a terabyte, one honest 1 GiB of zeros); unknown channels, schemas
and opcodes; every wrong shape of message JSON among sound exchanges; and files that are
not MCAP at all. Each file comes with what a correct reader must find in it
(:class:`Expect`).

``python -m tests.support.hostile JOBS.json`` runs ``clients.cli.main`` on each job (a list
of arguments) in this one process, and prints per job a JSON line: exit status, what it
wrote, whether anything escaped ``main``, and the peak resident memory of the run
(``VmHWM`` from ``/proc/self/status``, reset before each run through
``/proc/self/clear_refs``).
"""

import io
import json
import struct
import sys
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import lz4.frame
import zstandard
from mcap.exceptions import McapError
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from plotgate.service.recording import request_record, response_record
from plotgate.service.registry import OPERATIONS
from plotgate.service.schemas import request_schema, response_schema

MAGIC = b"\x89MCAP0\r\n"
CHUNK, MESSAGE_INDEX = 6, 7


@dataclass(frozen=True)
class Expect:
    """What a correct reader finds in a hostile file."""

    mcap: bool = True
    """It starts with the MCAP magic (otherwise every command refuses it: exit 2)."""
    exchanges: int | None = None
    """Exchanges with both records intact (replay compares exactly these), when known."""
    damaged: bool = True
    """Something in it must be reported as damage (with an offset)."""
    unfinished: bool | None = False
    """It ends without its footer (a record cut short, or the end of a whole one): its
    state is unfinished, which is not damage; None when it may or may not be."""


def records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, length) of each top-level record of a sound MCAP file."""
    out, pos = [], len(MAGIC)
    while pos + 9 <= len(data) - len(MAGIC):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, opcode, length))
        pos += 9 + length
    return out


def chunk_ids(data: bytes) -> list[set[str]]:
    """The request ids with a message in each chunk of a sound file, in file order (mcap's
    own reader)."""
    from mcap.records import Chunk
    from mcap.stream_reader import breakup_chunk

    ids = []
    for record in StreamReader(io.BytesIO(data), emit_chunks=True).records:
        if isinstance(record, Chunk):
            ids.append(
                {
                    json.loads(inner.data)["request_id"]
                    for inner in breakup_chunk(record)
                    if isinstance(inner, Message)
                }
            )
    return ids


def answered(data: bytes) -> int:
    """Exchanges with both records in ``data``, by mcap's own reader (which stops at the
    first incomplete or damaged record): the independent count for a cut file."""
    topics: dict[int, str] = {}
    seen: dict[str, set[str]] = {"request": set(), "response": set()}
    try:
        for record in StreamReader(io.BytesIO(data), validate_crcs=True).records:
            if hasattr(record, "topic"):
                topics[record.id] = record.topic
            elif isinstance(record, Message):
                kind = topics[record.channel_id].rpartition("/")[2]
                seen[kind].add(json.loads(record.data)["request_id"])
    except (McapError, struct.error, EOFError, ValueError, RuntimeError):
        pass
    return len(seen["request"] & seen["response"])


class _Session:
    """A small sound session written with mcap's writer and the recorder's record bytes,
    into which one hostile thing can be put."""

    def __init__(self, compression: CompressionType = CompressionType.LZ4) -> None:
        self.stream = io.BytesIO()
        self.writer = Writer(self.stream, compression=compression)
        self.writer.start(library="hostile")
        self.channels = {}
        for kind, schema in (("request", request_schema), ("response", response_schema)):
            model = (
                OPERATIONS["gates.test"].request
                if kind == "request"
                else (OPERATIONS["gates.test"].response)
            )
            sid = self.writer.register_schema(
                f"plotgate.gates.test.{kind}", "jsonschema", json.dumps(schema(model)).encode()
            )
            self.channels[kind] = self.writer.register_channel(f"gates.test/{kind}", "json", sid)
        self.t = 1_700_000_000_000_000_000

    def add(self, kind: str, data: bytes, channel: int | None = None) -> None:
        self.t += 1000
        self.writer.add_message(
            self.channels[kind] if channel is None else channel, self.t, data, self.t
        )

    def exchange(self, rid: str, body: bytes, status: int, answer: bytes) -> None:
        self.add("request", request_record(rid, "gates.test", body))
        self.add("response", response_record(rid, "gates.test", status, 0.001, answer))

    def bytes(self) -> bytes:
        self.writer.finish()
        return self.stream.getvalue()


def _sound_exchanges(session: _Session, good: tuple[bytes, int, bytes], n: int) -> None:
    body, status, answer = good
    for i in range(n):
        session.exchange(f"ok-{i}", body, status, answer)


def _lz4_bomb(size: int) -> bytes:
    """An LZ4 frame of ``size`` zero bytes, made a mebibyte at a time."""
    compressor = lz4.frame.LZ4FrameCompressor()
    zeros = b"\0" * 2**20
    parts = [compressor.begin()]
    parts += [compressor.compress(zeros) for _ in range(size // 2**20)]
    parts.append(compressor.flush())
    return b"".join(parts)


def _chunk(data: bytes, compression: str, size: int, crc: int) -> bytes:
    name = compression.encode()
    content = (
        struct.pack("<QQQI", 0, 0, size, crc)
        + struct.pack("<I", len(name))
        + name
        + struct.pack("<Q", len(data))
        + data
    )
    return struct.pack("<BQ", CHUNK, len(content)) + content


def _with_chunk(sound: bytes, chunk: bytes) -> bytes:
    """``sound`` with ``chunk`` put before its first chunk."""
    at = next(pos for pos, opcode, _ in records(sound) if opcode == CHUNK)
    return sound[:at] + chunk + sound[at:]


def corpus(sound: bytes, good: tuple[bytes, int, bytes], out: Path) -> dict[str, Expect]:
    """Write the hostile files into ``out``; return what each holds.

    ``sound`` is a sound recording; ``good`` a (body, status, answer) of gates.test that
    this build answers the same way again.
    """
    files: dict[str, tuple[bytes, Expect]] = {}
    total = answered(sound)
    layout = records(sound)

    # the sound recording cut at every record boundary (and inside a few records)
    def cut(n: int) -> Expect:
        return Expect(exchanges=answered(sound[:n]), damaged=False, unfinished=True)

    for pos, opcode, length in layout:
        files[f"cut-at-{pos:07d}"] = (sound[:pos], cut(pos))
        if opcode == CHUNK:
            middle = pos + 9 + length // 2
            files[f"cut-inside-chunk-{pos:07d}"] = (sound[:middle], cut(middle))
    files["cut-before-the-closing-magic"] = (sound[:-4], cut(len(sound) - 4))

    chunks = [(pos, length) for pos, opcode, length in layout if opcode == CHUNK]
    first, second = chunks[0], chunks[len(chunks) // 2]
    in_chunk = chunk_ids(sound)

    def without(chunk: tuple[int, int]) -> Expect:
        """A chunk dropped: every exchange with a record in it is lost, no other."""
        return Expect(exchanges=total - len(in_chunk[chunks.index(chunk)]))

    def patched(at: int, value: bytes) -> bytes:
        return sound[:at] + value + sound[at + len(value) :]

    # wrong lengths and CRCs
    for name, value in (
        ("huge", 2**63 - 1),
        ("past-the-end", len(sound)),
        ("one-more", None),
        ("one-less", None),
        ("zero", 0),
    ):
        for which, (pos, length) in (("first", first), ("middle", second)):
            declared = value if value is not None else length + (1 if name == "one-more" else -1)
            files[f"chunk-length-{name}-{which}"] = (
                patched(pos + 1, struct.pack("<Q", declared)),
                without((pos, length)),
            )
    pos, length = second
    files["chunk-crc"] = (patched(pos + 9 + 24, struct.pack("<I", 12345)), without(second))
    files["chunk-uncompressed-size"] = (
        patched(pos + 9 + 16, struct.pack("<Q", 2**40)),
        without(second),
    )
    files["chunk-compressed-byte"] = (
        patched(pos + 9 + length - 5, bytes([sound[pos + 9 + length - 5] ^ 0xFF])),
        without(second),
    )
    files["chunk-compression-name"] = (patched(pos + 9 + 32, b"zip"), without(second))
    files["footer-summary-crc"] = (
        patched(len(sound) - 8 - 4, b"\0\0\0\1"),
        Expect(exchanges=total),
    )
    files["footer-summary-start-past-end"] = (
        patched(len(sound) - 8 - 20, struct.pack("<Q", 2**62)),
        Expect(exchanges=total),
    )
    index = next(pos for pos, opcode, _ in layout if opcode == MESSAGE_INDEX)
    files["message-index-length"] = (
        patched(index + 1, struct.pack("<Q", 2**40)),
        Expect(exchanges=total),
    )
    files["header-length"] = (
        patched(len(MAGIC) + 1, struct.pack("<Q", 2**50)),
        Expect(exchanges=total),
    )
    files["flipped-bytes-everywhere"] = (
        bytes(b ^ 0x5A if i % 997 == 500 else b for i, b in enumerate(sound)),
        Expect(unfinished=None),
    )

    # compression bombs: a GiB of zeros in 4 MiB of LZ4
    bomb = _lz4_bomb(2**30)
    files["bomb-lz4-lies-about-its-size"] = (
        _with_chunk(sound, _chunk(bomb, "lz4", 2**20, 0)),
        Expect(exchanges=total),
    )
    files["bomb-lz4-declares-a-terabyte"] = (
        _with_chunk(sound, _chunk(bomb, "lz4", 2**40, 0)),
        Expect(exchanges=total),
    )
    files["bomb-lz4-honest-gibibyte-of-zeros"] = (  # no CRC: zeros are not records
        _with_chunk(sound, _chunk(bomb, "lz4", 2**30, 0)),
        Expect(exchanges=total),
    )
    zstd_bomb = zstandard.ZstdCompressor().compress(b"\0" * 2**26)
    files["bomb-zstd-lies-about-its-size"] = (
        _with_chunk(sound, _chunk(zstd_bomb, "zstd", 2**16, 0)),
        Expect(exchanges=total),
    )

    body, status, answer = good

    def session(
        build: Callable[[_Session], None],
        n: int = 3,
        compression: CompressionType = CompressionType.LZ4,
    ) -> bytes:
        s = _Session(compression)
        _sound_exchanges(s, good, n)
        build(s)
        return s.bytes()

    # unknown channels, schemas and records
    def undeclared(s: _Session) -> None:
        s.add("request", request_record("x", "gates.test", body), channel=99)

    def foreign_topic(s: _Session) -> None:
        s.add(
            "request",
            b'{"request_id": "x", "operation": "gates.test"}',
            channel=s.writer.register_channel("/camera/image", "json", 0),
        )

    def protobuf(s: _Session) -> None:
        sid = s.writer.register_schema("x", "protobuf", b"\x01\x02")
        s.add(
            "request",
            b"\x08\x01",
            channel=s.writer.register_channel("gates.test/request", "protobuf", sid),
        )

    def missing_schema(s: _Session) -> None:
        s.add(
            "request",
            request_record("x", "gates.pairs", body),
            channel=s.writer.register_channel("gates.pairs/request", "json", 77),
        )

    def unknown_operation(s: _Session) -> None:
        sid = s.writer.register_schema(
            "plotgate.gates.nothing.request", "jsonschema", b'{"type": "object"}'
        )
        s.add(
            "request",
            b'{"request_id": "x", "operation": "gates.nothing", "body": {}}',
            channel=s.writer.register_channel("gates.nothing/request", "json", sid),
        )

    for name, build in (
        ("message-on-undeclared-channel", undeclared),
        ("foreign-topic", foreign_topic),
        ("protobuf-channel", protobuf),
        ("channel-with-missing-schema", missing_schema),
        ("unknown-operation-never-answered", unknown_operation),
    ):
        files[name] = (
            session(build),
            Expect(exchanges=3, damaged=name != "unknown-operation-never-answered"),
        )
    plain = session(lambda s: None, compression=CompressionType.NONE)
    at = next(pos for pos, opcode, _ in records(plain) if opcode == CHUNK)
    for name, opcode in (("unknown-opcode", 0x42), ("private-opcode", 0x85), ("opcode-zero", 0)):
        stray = struct.pack("<BQ", opcode, 4) + b"junk"
        files[name] = (plain[:at] + stray + plain[at:], Expect(exchanges=3))
    files["uncompressed-chunks-sound"] = (plain, Expect(exchanges=3, damaged=False))
    files["zstd-chunks-sound"] = (
        session(lambda s: None, compression=CompressionType.ZSTD),
        Expect(exchanges=3, damaged=False),
    )

    # every wrong shape of message JSON, among three sound exchanges
    deep = (
        b'{"request_id": "x", "operation": "gates.test", "body": '
        + b"[" * 10**5
        + b"]" * 10**5
        + b"}"
    )
    shapes = {
        "not-json": b'{"request_id": ',
        "not-utf8": b'{"request_id": "x\xff", "operation": "gates.test", "body": {}}',
        "utf8-bom": b'\xef\xbb\xbf{"request_id": "x", "operation": "gates.test", "body": {}}',
        "empty": b"",
        "a-list": b'[{"request_id": "x", "operation": "gates.test"}]',
        "a-string": b'"request"',
        "a-number": b"42",
        "null": b"null",
        "missing-request-id": b'{"operation": "gates.test", "body": {}}',
        "request-id-a-number": b'{"request_id": 7, "operation": "gates.test", "body": {}}',
        "request-id-too-long": b'{"request_id": "' + b"a" * 200 + b'", "operation": '
        b'"gates.test", "body": {}}',
        "request-id-with-spaces": b'{"request_id": "a b", "operation": "gates.test", "body": {}}',
        "operation-of-another-channel": b'{"request_id": "x", "operation": "solves.noise", '
        b'"body": {}}',
        "5000-digit-integer": b'{"request_id": "x", "operation": "gates.test", "body": '
        b'{"candidates": ' + b"7" * 5000 + b"}}",
        "nested-1e5-deep": deep,
        "nested-300-deep": b'{"request_id": "x", "operation": "gates.test", "body": '
        + b"[" * 300
        + b"]" * 300
        + b"}",
        "nan-token": b'{"request_id": "x", "operation": "gates.test", "body": {"a": NaN}}',
        "raw-not-text": b'{"request_id": "x", "operation": "gates.test", "raw": [1]}',
        "replay-of-not-an-id": b'{"request_id": "x", "operation": "gates.test", "body": {}, '
        b'"replay_of": {"a": 1}}',
    }
    for name, data in shapes.items():
        files[f"request-{name}"] = (
            session(lambda s, d=data: s.add("request", d)),
            Expect(exchanges=3),
        )
    responses = {
        "status-a-string": b'"200", "duration_s": 0.1, "result": {}}',
        "status-999": b'999, "duration_s": 0.1, "result": {}}',
        "no-duration": b'200, "result": {}}',
        "negative-duration": b'200, "duration_s": -1, "result": {}}',
        "duration-400-digits": b'200, "duration_s": ' + b"9" * 400 + b', "result": {}}',
        "duration-1e308": b'200, "duration_s": 1e308, "result": {}}',
        "200-without-result": b'200, "duration_s": 0.1}',
        "422-error-a-list": b'422, "duration_s": 0.1, "error": [1, 2]}',
        "422-error-without-fields": b'422, "duration_s": 0.1, "error": {"errors": 5}}',
    }
    for name, tail in responses.items():

        def build(s: _Session, tail: bytes = tail) -> None:
            s.add("request", request_record("y", "gates.test", body))
            s.add("response", b'{"request_id": "y", "operation": "gates.test", "status": ' + tail)

        files[f"response-{name}"] = (session(build), Expect(exchanges=3))

    # files that are not MCAP at all
    for name, data in (
        ("empty-file", b""),
        ("json-file", b'{"request_id": "x"}'),
        ("text-file", b"plotgate recordings\n" * 50),
        ("png-file", b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4),
        ("magic-cut", MAGIC[:5]),
        ("zeros", b"\0" * 4096),
    ):
        files[f"not-mcap-{name}"] = (data, Expect(mcap=False))
    files["magic-only"] = (MAGIC, Expect(exchanges=0, damaged=False, unfinished=True))
    files["magic-then-garbage"] = (  # damaged to its end, so without a footer too
        MAGIC + bytes(range(256)) * 16,
        Expect(exchanges=0, unfinished=True),
    )

    out.mkdir(parents=True, exist_ok=True)
    for name, (data, _) in files.items():
        (out / f"{name}.mcap").write_bytes(data)
    return {name: expect for name, (_, expect) in files.items()}


def _peak_kb() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    raise KeyError("VmHWM")


def run(args: list[str]) -> dict:
    """Run ``plotgate ARGS`` in this process: its exit status, output, peak memory."""
    from plotgate.clients.cli import main

    Path("/proc/self/clear_refs").write_text("5")  # peak resident memory from now on
    stdout = io.TextIOWrapper(io.BytesIO(), encoding="utf-8")
    stderr = io.StringIO()
    escaped = None
    with redirect_stdout(stdout), redirect_stderr(stderr):
        try:
            code = main(args)
        except SystemExit as exc:  # argparse: a usage error
            code = exc.code
        except BaseException as exc:  # noqa: BLE001 - what must never happen
            code, escaped = None, f"{type(exc).__name__}: {exc}"
    stdout.flush()
    return {
        "args": args,
        "code": code,
        "escaped": escaped,
        "peak_kb": _peak_kb(),
        "stdout": stdout.buffer.getvalue().decode("utf-8", "replace")[-20_000:],
        "stderr": stderr.getvalue()[-20_000:],
    }


if __name__ == "__main__":
    for job in json.loads(Path(sys.argv[1]).read_text()):
        print(json.dumps(run(job)), flush=True)
