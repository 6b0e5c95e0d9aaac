"""Shared test builders: recordings."""

import io
from pathlib import Path


def chunk_per_exchange(path: Path) -> None:
    """Rewrite a recording with one LZ4 chunk per exchange (a flush after each response),
    as the recorder wrote files before compaction: the readers' tests of a damaged chunk
    need many small chunks, where a compacted file holds a megabyte per chunk."""
    from mcap.records import Channel, Message, Metadata, Schema
    from mcap.stream_reader import StreamReader
    from mcap.writer import CompressionType, Writer

    data = path.read_bytes()
    with open(path, "wb") as out:
        writer = Writer(out, compression=CompressionType.LZ4)
        writer.start(library="plotgate")
        for record in StreamReader(io.BytesIO(data)).records:
            if isinstance(record, Schema):
                writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel):
                writer.register_channel(
                    record.topic, record.message_encoding, record.schema_id, record.metadata
                )
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
            elif isinstance(record, Message):
                writer.add_message(
                    record.channel_id, record.log_time, record.data, record.publish_time
                )
                if b'"status": ' in record.data[:200]:
                    writer.flush()
        writer.finish()
