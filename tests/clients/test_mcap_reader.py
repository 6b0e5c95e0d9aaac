"""Both forms of a recording read alike: chunked (compacted: LZ4, zstd or none, small chunks
decompressed whole, large ones streamed) and unchunked (message records at top level, as a
live recorder writes them), read in large blocks; held to mcap's own reader."""

import json
import os
import random
import struct

import pytest
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from plotgate.clients import mcap_reader
from plotgate.clients.mcap_reader import Damage, Located, RecordReader
from plotgate.clients.recordings import Reader
from plotgate.service.recording import request_record, response_record

RNG_SEED = 25


def _write(
    path, exchanges, *, chunked=True, compression=CompressionType.LZ4, chunk_size=2**20
) -> None:
    """A recording of ``exchanges`` (request id, body bytes) in the given form."""
    with open(path, "wb") as stream:
        writer = Writer(
            stream, chunk_size=chunk_size, compression=compression, use_chunking=chunked
        )
        writer.start(library="test")
        channels = {}
        for kind in ("request", "response"):
            schema = writer.register_schema(f"plotgate.gates.test.{kind}", "jsonschema", b"{}")
            channels[kind] = writer.register_channel(f"gates.test/{kind}", "json", schema)
        t = 1_700_000_000_000_000_000
        for rid, body in exchanges:
            answer = b'{"inside": [true]}'
            for kind, data in (
                ("request", request_record(rid, "gates.test", body)),
                ("response", response_record(rid, "gates.test", 200, 0.001, answer)),
            ):
                t += 1000
                writer.add_message(channels[kind], t, data, t, sequence=t % 1000)
        writer.finish()


def _exchanges(n: int, big: int = 0) -> list[tuple[str, bytes]]:
    """``n`` exchanges of varied sizes (some over a read block when ``big``)."""
    rng = random.Random(RNG_SEED)
    out = []
    for i in range(n):
        size = big if big and i % 7 == 3 else rng.randrange(0, 3000)
        out.append((f"r{i}", json.dumps({"pad": "x" * size, "v": rng.random()}).encode()))
    return out


def _messages(path) -> list[tuple[int, int, int, int, bytes]]:
    items = list(RecordReader(path))
    assert not [i for i in items if isinstance(i, Damage)]
    return [
        (m.channel_id, m.sequence, m.log_time, m.publish_time, m.data)
        for m in (i.record for i in items if isinstance(i, Located))
        if isinstance(m, Message)
    ]


def _mcaps_own(path) -> list[tuple[int, int, int, int, bytes]]:
    with open(path, "rb") as stream:
        return [
            (r.channel_id, r.sequence, r.log_time, r.publish_time, r.data)
            for r in StreamReader(stream, validate_crcs=True).records
            if isinstance(r, Message)
        ]


FORMS = {
    "lz4": {"compression": CompressionType.LZ4},
    "zstd": {"compression": CompressionType.ZSTD},
    "uncompressed-chunks": {"compression": CompressionType.NONE},
    "large-chunks-streamed": {"chunk_size": 3 * mcap_reader.INLINE_CHUNK_BYTES // 2},
    "unchunked": {"chunked": False},
}


@pytest.mark.parametrize("form", list(FORMS), ids=list(FORMS))
def test_every_form_reads_as_mcaps_own_reader_reads_it(form, tmp_path):
    path = tmp_path / "r.mcap"
    exchanges = _exchanges(40, big=mcap_reader.BLOCK_BYTES + 1000) + _exchanges(1000)
    _write(path, exchanges, **FORMS[form])
    assert _messages(path) == _mcaps_own(path)
    reader = Reader(path)
    got = [(ex.request_id, ex.request, ex.status) for ex in reader]
    assert len(got) == 1040 and all(status == 200 for _, _, status in got)
    [rec] = reader.files
    assert rec.state == "complete" and not rec.damage and rec.messages == 2080
    expected = Reader(tmp_path / "r.mcap")  # the values built read as json reads them
    assert [json.loads(ex.request_bytes) for ex in expected] == [r for _, r, _ in got]


def test_the_unchunked_form_is_read_a_block_at_a_time(tmp_path, monkeypatch):
    """Not two reads per record: a file of 20,000 small records takes a handful."""
    path = tmp_path / "r.mcap"
    _write(path, _exchanges(10_000), chunked=False)
    calls = []
    real = os.pread
    monkeypatch.setattr(
        mcap_reader.os, "pread", lambda fd, n, at: calls.append(n) or real(fd, n, at)
    )
    assert len(list(Reader(path))) == 10_000
    assert len(calls) < 10 + 3 * os.path.getsize(path) // mcap_reader.BLOCK_BYTES, len(calls)


def test_a_live_unchunked_file_cut_anywhere_in_its_last_record_is_unfinished(tmp_path):
    """A writer's last record, cut at any byte: every whole exchange read, no damage, the
    tail said; a byte changed mid-file is damage all the same."""
    path = tmp_path / "r.mcap"
    _write(path, _exchanges(4), chunked=False)
    data = path.read_bytes()
    last = _last_message(data)
    end = last + 9 + struct.unpack_from("<Q", data, last + 1)[0]
    for cut in range(last, len(data) - 8):
        path.write_bytes(data[:cut])
        reader = Reader(path)
        exchanges = [ex.request_id for ex in reader if ex.status is not None]
        [rec] = reader.files
        assert rec.state == "unfinished" and not rec.damage, (cut, rec.damage)
        assert exchanges == ["r0", "r1", "r2"] + (["r3"] if cut >= end else []), cut
    damaged = bytearray(data[:last])
    first = data.index(b'"request_id"')
    damaged[first - 40 : first - 30] = b"\xee" * 10  # inside a message record's header
    path.write_bytes(bytes(damaged))
    reader = Reader(path)
    list(reader)
    assert reader.files[0].damage and reader.files[0].state == "unfinished"


def _last_message(data: bytes) -> int:
    """The offset of the last Message record of an unchunked file, before its summary."""
    pos, last = 8, 0
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if opcode == 5:
            last = pos
        if opcode == 0x0F:  # DataEnd
            break
        pos += 9 + length
    return last


def test_a_bomb_in_a_small_chunk_is_stopped_at_its_declared_size(tmp_path):
    """The whole-chunk path asks the codec for one byte past the declared size, never more:
    64 MiB of zeros in a chunk declaring 100 bytes is damage, the rest of the file read."""
    import lz4.frame

    path = tmp_path / "r.mcap"
    _write(path, _exchanges(3))
    sound = path.read_bytes()
    bomb = lz4.frame.compress(b"\0" * 2**26)
    content = struct.pack("<QQQII", 0, 0, 100, 0, 3) + b"lz4" + struct.pack("<Q", len(bomb))
    chunk = struct.pack("<BQ", 6, len(content) + len(bomb)) + content + bomb
    at = _first_chunk(sound)
    path.write_bytes(sound[:at] + chunk + sound[at:])
    items = list(RecordReader(path))
    [damage] = [i for i in items if isinstance(i, Damage) and i.offset == at]  # (and the
    # summary's CRC, which no longer matches: its offsets moved)
    assert "inflates past its declared 100 bytes" in damage.reason
    assert sum(isinstance(i.record, Message) for i in items if isinstance(i, Located)) == 6


def _first_chunk(data: bytes) -> int:
    pos = 8
    while struct.unpack_from("<B", data, pos)[0] != 6:
        pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
    return pos


def test_a_tail_declaring_more_than_a_writer_writes_is_damage(tmp_path):
    """A last record declaring a terabyte is not a write in progress: it is damage."""
    path = tmp_path / "r.mcap"
    path.write_bytes(mcap_reader.MAGIC + struct.pack("<BQ", 5, 2**40) + b"x" * 100)
    reading = RecordReader(path)
    [damage] = list(reading)
    assert isinstance(damage, Damage) and "declares 1099511627776 bytes" in damage.reason
    assert reading.unfinished == "its last 109 bytes, from offset 8, are damaged"
