"""The raw-bytes MCAP writer of ``plotgate view`` against mcap's readers: its messages,
schemas, channels, summary and indexes read back as mcap's own ``Writer`` writes them."""

import io

import pytest
from mcap.reader import make_reader
from mcap.records import Chunk, ChunkIndex, DataEnd, Footer, MessageIndex, Statistics
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from plotgate.clients.scene_file import SceneFile

T = 1_764_000_000_000_000_000
MESSAGES = [
    (1 + i % 3, T + (i * 7919) % 5000 * 1_000_000, bytes([i % 256]) * (i % 97)) for i in range(600)
]
"""(channel, log time, data): times not in order, some messages empty."""


def written(chunk_bytes: int, mcap_writer: bool = False) -> bytes:
    stream = io.BytesIO()
    if mcap_writer:
        writer = Writer(stream, chunk_size=chunk_bytes, compression=CompressionType.ZSTD)
        writer.start(profile="", library="test")
        schema = writer.register_schema("s", "jsonschema", b"{}")
        for topic in ("a", "b", "c"):
            writer.register_channel(topic, "json", schema if topic != "c" else 0)
        for channel, t, data in MESSAGES:
            writer.add_message(channel, t, data, t)
        writer.finish()
    else:
        scene = SceneFile(stream, "test", chunk_bytes)
        schema = scene.schema("s", "jsonschema", b"{}")
        for topic in ("a", "b", "c"):
            scene.channel(topic, "json", schema if topic != "c" else 0)
        for channel, t, data in MESSAGES:
            scene.message(channel, t, data)
        scene.finish()
    return stream.getvalue()


def read(data: bytes, order: bool = False) -> list[tuple]:
    reader = make_reader(io.BytesIO(data))
    return [
        (c.topic, c.message_encoding, s.name if s else None, m.log_time, m.publish_time, m.data)
        for s, c, m in reader.iter_messages(log_time_order=order)
    ]


@pytest.mark.parametrize("chunk_bytes", [1, 4096, 2**20])
def test_what_it_writes_reads_as_mcaps_writer_output(chunk_bytes):
    ours, theirs = written(chunk_bytes), written(chunk_bytes, mcap_writer=True)
    for order in (False, True):  # file order; by time, through the chunk and message indexes
        assert read(ours, order) == read(theirs, order)
    summary = make_reader(io.BytesIO(ours)).get_summary()
    reference = make_reader(io.BytesIO(theirs)).get_summary()
    assert summary is not None and reference is not None
    assert summary.statistics == reference.statistics
    assert summary.schemas == reference.schemas and summary.channels == reference.channels
    assert [(i.message_start_time, i.message_end_time) for i in summary.chunk_indexes] == [
        (i.message_start_time, i.message_end_time) for i in reference.chunk_indexes
    ]


def test_crcs_indexes_and_offsets_check():
    data = written(4096)
    records = list(StreamReader(io.BytesIO(data), validate_crcs=True, emit_chunks=True).records)
    chunks = [(r, i) for i, r in enumerate(records) if isinstance(r, Chunk)]
    assert len(chunks) > 5 and all(r.compression == "zstd" for r, _ in chunks)
    [statistics] = [r for r in records if isinstance(r, Statistics)]
    assert statistics.chunk_count == len(chunks) and statistics.message_count == len(MESSAGES)
    indexes = [r for r in records if isinstance(r, ChunkIndex)]
    for index in indexes:  # each names where its chunk and message indexes are
        chunk = StreamReader(
            io.BytesIO(data[index.chunk_start_offset :]), skip_magic=True, emit_chunks=True
        )
        assert isinstance(next(iter(chunk.records)), Chunk)
        for at in index.message_index_offsets.values():
            message_index = StreamReader(io.BytesIO(data[at:]), skip_magic=True)
            assert isinstance(next(iter(message_index.records)), MessageIndex)
    assert isinstance(records[-1], Footer) and any(isinstance(r, DataEnd) for r in records)


def test_a_file_without_messages_is_a_valid_mcap():
    stream = io.BytesIO()
    SceneFile(stream, "test", 100).finish()
    reader = make_reader(io.BytesIO(stream.getvalue()))
    assert list(reader.iter_messages()) == []
    summary = reader.get_summary()
    assert summary is not None and summary.statistics.message_count == 0
