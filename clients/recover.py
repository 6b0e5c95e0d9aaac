"""``plotgate recover FILE``: a complete, indexed copy of a file a killed server left.

A server killed mid-write leaves an MCAP file without its summary, index and footer (every
exchange a client saw answered is in it: the recorder flushes before it answers).
:func:`recover` reads every complete record in order (:mod:`clients.recordings`' reader,
which stops at the first truncated or damaged record), writes them into a new file with
its own summary and index (LZ4 chunks, like the recorder), and renames the damaged
original to ``<name>.partial`` so a replay of the folder reads each exchange once.
"""

from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel, Footer, Header, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from clients.recordings import Recording, _records

__all__ = ["Recovery", "recover"]


@dataclass(frozen=True)
class Recovery:
    """What :func:`recover` did."""

    source: Path
    output: Path
    messages: int
    was_complete: bool
    stopped_by: str | None


def recover(path: Path | str, out: Path | str | None = None, keep: bool = False) -> Recovery:
    """Copy every complete record of ``path`` into a complete, indexed MCAP file.

    Parameters
    ----------
    path : the damaged (or any) MCAP file.
    out : the copy to write; default ``<stem>.recovered.mcap`` next to it.
    keep : leave the original as it is (default: rename it to ``<name>.partial``).
    """
    path = Path(path)
    out = Path(out) if out is not None else path.with_name(f"{path.stem}.recovered.mcap")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    rec = Recording(path)
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    messages = 0
    complete = False
    with open(out, "wb") as stream:
        writer = Writer(stream, compression=CompressionType.LZ4)
        started = False
        for record in _records(path, rec):
            if isinstance(record, Header):
                writer.start(profile=record.profile, library=record.library)
                started = True
            elif not started:
                writer.start(profile="", library="plotgate recover")
                started = True
            if isinstance(record, Schema) and record.id not in schemas:
                schemas[record.id] = writer.register_schema(record.name, record.encoding,
                                                            record.data)
            elif isinstance(record, Channel) and record.id not in channels:
                channels[record.id] = writer.register_channel(
                    record.topic, record.message_encoding, schemas.get(record.schema_id, 0),
                    dict(record.metadata))
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
            elif isinstance(record, Message):
                writer.add_message(channels[record.channel_id], record.log_time, record.data,
                                   record.publish_time, record.sequence)
                messages += 1
            elif isinstance(record, Footer):
                complete = True
        if not started:
            writer.start(profile="", library="plotgate recover")
        writer.finish()
    if not keep and not complete:
        path.rename(path.with_name(path.name + ".partial"))
    return Recovery(path, out, messages, complete, rec.stopped_by)
