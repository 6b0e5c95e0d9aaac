"""``plotgate recover FILE``: a complete, indexed copy of every intact record of a damaged file.

A server killed mid-write leaves an MCAP file without its summary, index and footer; a disk
or a copy can damage bytes anywhere. :func:`recover` reads the file with
:class:`plotgate.clients.mcap_reader.RecordReader`, which skips each damaged chunk or
record and goes on at the next intact one, writes every intact plotgate record (the
messages replay reads, checked as
:func:`plotgate.clients.recordings.parse_record` does, their channels and schemas, the metadata)
into a new file with its own summary and index (LZ4 chunks, like the recorder), and
reports what it dropped with its offset. The original is renamed to ``<name>.partial``
when anything in it was damaged or missing, so a replay of the folder reads each exchange
once.

A file that does not start with the MCAP magic is refused (:class:`Refused`) and left as
it is: it is not a recording, and an empty copy would pass for one. So is a path that is
not a regular file (a FIFO, socket, device or folder), at once: it is never opened to
read, where a FIFO would block. The copy is written through
:func:`plotgate.files.atomic_write` (a temporary beside it, renamed into place): an existing
``--out`` (or ``<name>.partial``) that is a link, FIFO, device or folder is refused, and
nothing is written through it.
"""

import os
from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Header, McapRecord, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from plotgate.clients.mcap_reader import (
    MAGIC,
    Damage,
    NotMcap,
    NotRegular,
    RecordReader,
    not_mcap,
    open_regular,
)
from plotgate.clients.recordings import (
    MAX_LISTED,
    SCENE,
    TRANSFORM,
    parse_record,
    plotgate_channel,
)
from plotgate.files import atomic_write, check_target

__all__ = ["Recovery", "Refused", "recover"]


class Refused(Exception):
    """recover will not touch this file (not MCAP, or the copy would overwrite it)."""


@dataclass
class Recovery:
    """What :func:`recover` kept and dropped."""

    source: Path
    output: Path
    was_complete: bool = False
    messages: int = 0
    chunks: int = 0
    """Intact chunks whose records were copied."""
    chunks_damaged: int = 0
    dropped_messages: int = 0
    """Messages of the damaged chunks, as their message indexes count them."""
    skipped_bytes: int = 0
    damage: list[str] = field(default_factory=list)
    damage_count: int = 0
    renamed: Path | None = None

    def text(self) -> str:
        state = "complete" if self.was_complete else "no footer (its writer did not finish)"
        lines = [
            f"{self.source}: {state}; {self.messages} messages from {self.chunks} intact "
            f"chunks copied to {self.output}"
        ]
        if self.damage_count:
            lines.append(
                f"dropped: {self.chunks_damaged} damaged chunks (holding "
                f"{self.dropped_messages} messages by their indexes), "
                f"{self.skipped_bytes} bytes skipped, {self.damage_count} damaged "
                "records in all:"
            )
            lines += [f"  {d}" for d in self.damage]
            if self.damage_count > len(self.damage):
                lines.append(f"  ... and {self.damage_count - len(self.damage)} more")
        if self.renamed is not None:
            lines.append(f"{self.source} renamed to {self.renamed}")
        return "\n".join(lines)


class _Copy:
    """Writes the intact plotgate records into the new file, renumbering schemas and
    channels; a message that is not a plotgate record (or is on a channel that is not a
    plotgate channel) is dropped as damage, so the copy holds only what replay reads."""

    def __init__(self, writer: Writer, recovery: Recovery) -> None:
        self.writer = writer
        self.recovery = recovery
        self.started = False
        self.waiting: list[McapRecord] = []
        self.schemas: dict[int, Schema] = {}
        self.written_schemas: dict[int, int] = {}
        self.channels: dict[int, tuple[str, str] | str] = {}
        self.written_channels: dict[int, int] = {}

    def __call__(self, record: McapRecord, offset: int, inner: int | None) -> None:
        if not self.started:
            if isinstance(record, Header):
                self.start(record.profile, record.library)
                return
            if isinstance(record, Schema | Channel):
                self.waiting.append(record)
                return
            self.start("", "plotgate recover")
        if isinstance(record, Schema):
            self.schemas.setdefault(record.id, record)
        elif isinstance(record, Channel) and record.id not in self.channels:
            self.channels[record.id] = plotgate_channel(record, set(self.schemas))
            if not isinstance(self.channels[record.id], str):
                self.written_channels[record.id] = self.writer.register_channel(
                    record.topic,
                    record.message_encoding,
                    self.schema(record.schema_id),
                    dict(record.metadata),
                )
        elif isinstance(record, Metadata):
            self.writer.add_metadata(record.name, dict(record.metadata))
        elif isinstance(record, Message):
            self.message(record, offset, inner)

    def schema(self, sid: int) -> int:
        if sid not in self.written_schemas:
            s = self.schemas[sid]
            self.written_schemas[sid] = self.writer.register_schema(s.name, s.encoding, s.data)
        return self.written_schemas[sid]

    def message(self, message: Message, offset: int, inner: int | None) -> None:
        channel = self.channels.get(message.channel_id)
        try:
            if channel is None:
                raise ValueError(
                    f"a message on channel {message.channel_id}, which no Channel record declared"
                )
            if isinstance(channel, str):
                raise ValueError(f"a message on {channel}")
            if channel not in (SCENE, TRANSFORM):  # plotgate view's scenes: copied as they are
                parse_record(channel[1], channel[0], message.data)
        except ValueError as exc:
            self.dropped(Damage(offset, str(exc), inner))
            return
        self.writer.add_message(
            self.written_channels[message.channel_id],
            message.log_time,
            message.data,
            message.publish_time,
            message.sequence,
        )
        self.recovery.messages += 1

    def start(self, profile: str, library: str) -> None:
        self.writer.start(profile=profile, library=library)
        self.started = True
        waiting, self.waiting = self.waiting, []
        for record in waiting:
            self(record, 0, None)

    def dropped(self, damage: Damage) -> None:
        self.recovery.damage_count += 1
        if len(self.recovery.damage) < MAX_LISTED:
            self.recovery.damage.append(str(damage))


def _check_magic(path: Path) -> None:
    """Refuse ``path`` unless it is a regular file that starts with the MCAP magic."""
    try:
        fd = open_regular(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"no such file: {path}") from None
    except NotRegular as exc:
        raise Refused(f"{path} is {exc.strerror}; left as it is") from None
    try:
        if os.pread(fd, len(MAGIC), 0) != MAGIC:
            raise Refused(f"{not_mcap(path, os.fstat(fd).st_size)}; left as it is")
    finally:
        os.close(fd)


def recover(path: Path | str, out: Path | str | None = None, keep: bool = False) -> Recovery:
    """Copy every intact record of ``path`` into a complete, indexed MCAP file.

    Parameters
    ----------
    path : the damaged (or any) MCAP file.
    out : the copy to write; default ``<stem>.recovered.mcap`` next to it.
    keep : leave the original as it is (default: rename it to ``<name>.partial`` when
        anything in it was damaged or missing).

    Raises :class:`Refused` for a file without the MCAP magic (left untouched) or a path
    that is not a regular file, ``FileNotFoundError`` for a missing one.
    """
    path = Path(path)
    out = Path(out) if out is not None else path.with_name(f"{path.stem}.recovered.mcap")
    _check_magic(path)
    check_target(out)
    if out.exists() and out.resolve() == path.resolve():
        raise Refused(f"the copy would overwrite {path}; name another with --out")
    recovery = Recovery(path, out)
    scan = RecordReader(path)
    try:
        with atomic_write(out) as stream:
            writer = Writer(stream, compression=CompressionType.LZ4)
            copy = _Copy(writer, recovery)
            for item in scan:
                if isinstance(item, Damage):
                    copy.dropped(item)
                else:
                    copy(item.record, item.offset, item.inner)
            if not copy.started:
                copy.start("", "plotgate recover")
            writer.finish()
    except NotMcap as exc:  # the file changed since its magic was read
        raise Refused(str(exc)) from None
    recovery.was_complete = scan.complete
    recovery.chunks, recovery.chunks_damaged = scan.chunks, scan.chunks_damaged
    recovery.dropped_messages, recovery.skipped_bytes = scan.dropped_messages, scan.skipped_bytes
    if not keep and (recovery.damage_count or not scan.complete):
        recovery.renamed = path.with_name(path.name + ".partial")
        check_target(recovery.renamed)
        path.rename(recovery.renamed)
    return recovery
