"""MCAP files read record by record, whatever their bytes: damage is reported, never raised.

mcap's own ``StreamReader`` stops at the first bad record, believes every declared length
and decompresses a chunk whole, so one flipped byte hides the rest of a file and a chunk
declaring a terabyte (or a small one that inflates to gigabytes) takes the memory with
it. :class:`RecordReader` reads a file the way a recovery tool must:

- **Bounded memory, C-speed bytes.** A record is held whole only when it is a Schema,
  Channel, Message, Metadata or Header record of at most ``max_record_bytes`` (a declared
  size above it is damage). Records outside chunks (the unchunked form a live recorder
  writes) are read a block of :data:`BLOCK_BYTES` at a time. A chunk of at most
  :data:`INLINE_CHUNK_BYTES` is decompressed by one call of the C codec, told to stop one
  byte past the declared size; a larger one is never held whole: its compressed bytes are
  streamed from the file and decompressed in pieces of :data:`PIECE_BYTES`. A chunk that
  inflates past its declared size, or declares more than ``max_chunk_bytes``, is damage.
- **Every record checked before it is believed.** A chunk's records are read only after
  the whole chunk has decompressed to its declared size and matched its CRC (two passes
  over a large chunk, so nothing from a damaged chunk is ever yielded); records whose
  fields do not add up to their declared length are damage.
- **Resynchronization.** After damage the file is searched, from the next byte, for the
  next record whose every length adds up (a Chunk, Schema, Channel, Metadata, DataEnd or
  Footer record followed by a plausible opcode), and reading goes on there: every intact
  chunk after a damaged one is kept.
- **An unfinished tail is not damage** (see :class:`RecordReader`): a live file, or one whose
  writer was killed, ends with a record cut short or without its footer.
- **Channels of a damaged first chunk.** mcap's writer puts every Schema and Channel
  record in the first chunk; when the file has a summary section whose CRC checks, its
  copies of them are read first, so the messages of intact chunks stay readable when the
  first chunk is lost.

The data section's CRC (``DataEnd``, which plotgate's recorder does not write) is not
checked. Format: https://mcap.dev/spec.
"""

import errno
import io
import os
import re
import stat
import struct
import zlib
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import lz4.frame
import zstandard
from mcap.records import Channel, Header, McapRecord, Message, Metadata, Schema

__all__ = [
    "MAGIC",
    "MAX_CHUNK_BYTES",
    "MAX_RECORD_BYTES",
    "Damage",
    "Located",
    "Messages",
    "NotMcap",
    "NotRegular",
    "RecordReader",
    "check_regular",
    "location",
    "not_mcap",
    "open_regular",
]

MAGIC = b"\x89MCAP0\r\n"
MAX_RECORD_BYTES = 2**27
"""Largest record held in memory (128 MiB): a message of a 64 MiB body (the service's
``PLOTGATE_MAX_BODY_BYTES``) with room for its JSON escapes."""
MAX_CHUNK_BYTES = 2**30
"""Largest uncompressed chunk decompressed (1 GiB; streamed, so this bounds time, not
memory)."""
PIECE_BYTES = 2**20
"""Decompression and CRC work in pieces of this size."""
INLINE_CHUNK_BYTES = 2**22
"""A chunk up to this size (compressed and uncompressed) is decompressed in one call of the C
codec and kept for its records; a larger one is decompressed twice, a piece at a time, so
memory never holds it whole."""
BLOCK_BYTES = 2**22
"""Records outside chunks are read from the file in blocks of this size."""

HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX = 1, 2, 3, 4, 5, 6, 7
METADATA, DATA_END = 0x0C, 0x0F
NAMES = {
    1: "Header",
    2: "Footer",
    3: "Schema",
    4: "Channel",
    5: "Message",
    6: "Chunk",
    7: "MessageIndex",
    8: "ChunkIndex",
    9: "Attachment",
    0x0A: "AttachmentIndex",
    0x0B: "Statistics",
    0x0C: "Metadata",
    0x0D: "MetadataIndex",
    0x0E: "SummaryOffset",
    0x0F: "DataEnd",
}
HELD = {HEADER, SCHEMA, CHANNEL, MESSAGE, METADATA}
"""Records read whole; every other record is skipped by its length without being read."""
RESYNC = {FOOTER, SCHEMA, CHANNEL, CHUNK, METADATA, DATA_END}
"""Records whose fields must add up to their declared length: where reading starts again."""
_RESYNC_BYTES = re.compile(b"[" + b"".join(re.escape(bytes([op])) for op in RESYNC) + b"]")
FOOTER_BYTES = 9 + 20
_MESSAGE_HEAD = struct.Struct("<BQHIQQ").unpack_from
"""A record's opcode and length, and a Message record's fields before its data."""
COMPRESSIONS = ("", "lz4", "zstd")


class NotMcap(Exception):
    """The file does not start with the MCAP magic: it is not a recording at all."""


class NotRegular(OSError):
    """The path is a FIFO, socket, device or folder, not a regular file. Readers open
    only regular files: opening a FIFO blocks until a writer comes, which may be never."""


_KINDS = {
    stat.S_IFIFO: "a FIFO",
    stat.S_IFSOCK: "a socket",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFDIR: "a folder",
}


def check_regular(path: Path | str, mode: int) -> None:
    """Raise :class:`NotRegular` unless ``mode`` (an ``st_mode`` of ``path``) is a
    regular file's."""
    if not stat.S_ISREG(mode):
        kind = _KINDS.get(stat.S_IFMT(mode), "a special file")
        raise NotRegular(
            errno.EINVAL,
            f"{kind}, not a regular file (readers open only regular files)",
            str(path),
        )


def open_regular(path: Path | str) -> int:
    """A read-only descriptor of the regular file ``path``; :class:`NotRegular` for
    anything else, at once.

    The path is looked at before it is opened, and opened non-blocking, so that a FIFO
    put there between the two still cannot block; the descriptor is checked again.
    """
    check_regular(path, os.stat(path).st_mode)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        check_regular(path, os.fstat(fd).st_mode)
    except NotRegular:
        os.close(fd)
        raise
    return fd


def not_mcap(path: Path | str, size: int) -> str:
    """Why ``path`` (of ``size`` bytes) is not a recording: empty, or no MCAP magic."""
    if size == 0:
        return f"{path} is empty (0 bytes), not an MCAP file"
    return f"{path} is not an MCAP file (it does not start with the MCAP magic)"


def location(offset: int, inner: int | None) -> str:
    """Where a record is: its file offset, and for one inside a chunk (the chunk's
    offset) its byte offset among the chunk's uncompressed records."""
    where = f"offset {offset}"
    if inner is not None:
        where += f" (chunk), byte {inner} of its records"
    return where


@dataclass(frozen=True)
class Damage:
    """Something in a file that is not an intact record, and what was skipped for it.

    ``offset`` is the file offset of the record (for a record inside a chunk, of the chunk,
    and ``inner`` its byte offset among the chunk's uncompressed records).
    """

    offset: int
    reason: str
    inner: int | None = None

    def __str__(self) -> str:
        return f"{location(self.offset, self.inner)}: {self.reason}"


@dataclass(frozen=True)
class Located:
    """An intact record and where it is (``inner`` as in :class:`Damage`)."""

    offset: int
    inner: int | None
    record: McapRecord


class _Malformed(ValueError):
    pass


class _Fields:
    """Reads a record's fields from its bytes, refusing to read past them."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.at = 0

    def take(self, n: int) -> bytes:
        if n > len(self.data) - self.at:
            raise _Malformed(
                f"a field runs {n - (len(self.data) - self.at)} bytes past the record's end"
            )
        piece = self.data[self.at : self.at + n]
        self.at += n
        return piece

    def u16(self) -> int:
        return struct.unpack("<H", self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack("<I", self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack("<Q", self.take(8))[0]

    def text(self) -> str:
        try:
            return self.take(self.u32()).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _Malformed(f"a string is not UTF-8 ({exc.reason})") from None

    def pairs(self) -> dict[str, str]:
        inner = _Fields(self.take(self.u32()))
        out = {}
        while inner.at < len(inner.data):
            key = inner.text()
            out[key] = inner.text()
        return out

    def end(self) -> None:
        if self.at != len(self.data):
            raise _Malformed(f"{len(self.data) - self.at} bytes left over after its fields")


def _parse(opcode: int, data: bytes) -> McapRecord:
    """One held record from its bytes (:class:`_Malformed` when they do not add up)."""
    f = _Fields(data)
    if opcode == MESSAGE:
        channel_id, sequence, log_time, publish_time = struct.unpack("<HIQQ", f.take(22))
        return Message(
            channel_id=channel_id,
            sequence=sequence,
            log_time=log_time,
            publish_time=publish_time,
            data=data[22:],
        )
    record: McapRecord
    if opcode == HEADER:
        record = Header(profile=f.text(), library=f.text())
    elif opcode == SCHEMA:
        record = Schema(id=f.u16(), name=f.text(), encoding=f.text(), data=f.take(f.u32()))
        if record.id == 0:
            raise _Malformed("schema id 0 is reserved")
    elif opcode == CHANNEL:
        record = Channel(
            id=f.u16(),
            schema_id=f.u16(),
            topic=f.text(),
            message_encoding=f.text(),
            metadata=f.pairs(),
        )
    else:
        record = Metadata(name=f.text(), metadata=f.pairs())
    f.end()
    return record


class _Region(io.RawIOBase):
    """``length`` bytes of an open file from ``start``, read with ``os.pread``."""

    def __init__(self, fd: int, start: int, length: int) -> None:
        self.fd, self.pos, self.left = fd, start, length

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: memoryview | bytearray) -> int:  # type: ignore[override]
        n = min(len(buffer), self.left)
        data = os.pread(self.fd, n, self.pos) if n else b""
        buffer[: len(data)] = data
        self.pos += len(data)
        self.left -= len(data)
        return len(data)


def _decompressed(compression: str, source: io.RawIOBase) -> BinaryIO:
    """A reader of a chunk's uncompressed records, decompressing as it is read."""
    if compression == "lz4":
        return lz4.frame.LZ4FrameFile(io.BufferedReader(source, PIECE_BYTES), mode="rb")
    if compression == "zstd":
        return zstandard.ZstdDecompressor(max_window_size=2**27).stream_reader(
            io.BufferedReader(source, PIECE_BYTES)
        )
    return io.BufferedReader(source, PIECE_BYTES)


def _read(stream: BinaryIO, n: int) -> bytes:
    """Up to ``n`` bytes (fewer only at the end), in pieces so a large ``n`` allocates
    nothing up front."""
    pieces, left = [], n
    while left:
        piece = stream.read(min(left, PIECE_BYTES))
        if not piece:
            break
        pieces.append(piece)
        left -= len(piece)
    return b"".join(pieces)


class _Blocks:
    """A file's first ``size`` bytes, read a block of :data:`BLOCK_BYTES` at a time: the
    records of an unchunked file cost one ``pread`` per block, not two per record."""

    def __init__(self, fd: int, size: int) -> None:
        self.fd, self.size = fd, size
        self.start, self.data = 0, b""

    def read(self, n: int, at: int) -> bytes:
        n = max(0, min(n, self.size - at))
        offset = at - self.start
        if 0 <= offset and offset + n <= len(self.data):
            return self.data[offset : offset + n]
        if n > BLOCK_BYTES:
            return os.pread(self.fd, n, at)
        self.start, self.data = at, os.pread(self.fd, min(BLOCK_BYTES, self.size - at), at)
        return self.data[:n]


@dataclass
class Messages:
    """Intact Message records that follow one another: a chunk's, or top-level ones.

    Each of ``records`` is ``(where, channel_id, sequence, log_time, publish_time, data)``:
    ``where`` is the record's file offset for a top-level record (``chunk`` None), its byte
    offset among the chunk's uncompressed records otherwise (``chunk`` the chunk's offset).
    Plain tuples, not :class:`~mcap.records.Message` objects: a recording holds millions.
    """

    chunk: int | None
    records: list[tuple[int, int, int, int, int, bytes]]
    size: int
    """Bytes of message data."""

    def located(self, index: int) -> tuple[int, int | None]:
        """``(offset, inner)`` of record ``index``, as :class:`Located` and :class:`Damage`
        give them."""
        where = self.records[index][0]
        return (where, None) if self.chunk is None else (self.chunk, where)


_OneMessage = tuple[int | None, int, int, int, int, int, bytes]
"""A Message record as :meth:`RecordReader._records` yields it: its chunk (None at top level), then
the fields of a :class:`Messages` record."""


def _message(chunk: int | None, where: int, data: bytes) -> _OneMessage:
    """A Message record's fields from its bytes (:class:`_Malformed` when too short)."""
    if len(data) < 22:
        raise _Malformed(f"a field runs {22 - len(data)} bytes past the record's end")
    return (chunk, where, *struct.unpack_from("<HIQQ", data), data[22:])


class RecordReader:
    """Read one MCAP file: iterate to get each intact record (:class:`Located`) and each
    piece of damage (:class:`Damage`), in file order; :meth:`runs` gives the same with the
    Message records in batches (:class:`Messages`), as the fast readers want them.

    Raises :class:`NotMcap` (before yielding anything) when the file does not start with
    the MCAP magic (an empty file included), :class:`NotRegular` when it is not a regular
    file, and ``OSError`` when it cannot be read. After the iteration, ``complete`` says
    whether the file ended with its footer and magic, ``unfinished`` (for a file without
    them) what its tail is, and the counters say what was kept and dropped.

    **An unfinished tail is not damage.** A file without its footer whose last bytes are a
    record cut short (a header of fewer than 9 bytes, a record of a known opcode declaring
    more bytes than the file has, a footer without all of its closing magic) after which
    nothing readable follows is what a writer leaves while it writes, or when it was killed:
    that is ``unfinished``, not :class:`Damage`. Whether its writer still writes it is the
    readers' question (:mod:`plotgate.clients.live`).
    """

    def __init__(
        self,
        path: Path | str,
        *,
        max_record_bytes: int = MAX_RECORD_BYTES,
        max_chunk_bytes: int = MAX_CHUNK_BYTES,
        span: tuple[int, int] | None = None,
    ) -> None:
        self.path = Path(path)
        self.span = span
        """Read only the records that start in [start, stop) (a range of whole chunks of a
        file whose summary indexes them; None: the whole file). The summary's schemas and
        channels are read first all the same; the missing footer is reported only by a span
        that runs to the file's end."""
        self.stopped_at = 0
        """Where reading stopped: the first record at or past the span's end (past it when
        damage was skipped across the end), or the file's size."""
        self.max_record_bytes = max_record_bytes
        self.max_chunk_bytes = max_chunk_bytes
        self.size = 0
        self.complete = False
        self.unfinished: str | None = None
        """For a file without its footer: what its tail is (a record cut short, or the end
        of its last whole record)."""
        self.chunks = 0
        """Chunks whose records were read (intact)."""
        self.chunks_damaged = 0
        self.dropped_messages = 0
        """Messages of damaged chunks, as counted by the message indexes that follow them."""
        self.skipped_bytes = 0
        """Bytes passed over while looking for the next record after damage."""
        self._fd = -1
        self._blocks = _Blocks(-1, 0)
        self._after_damaged_chunk = False

    def __iter__(self) -> Iterator[Located | Damage]:
        for item in self.runs():
            if isinstance(item, Messages):
                for i, (_, channel, sequence, log_time, publish_time, data) in enumerate(
                    item.records
                ):
                    offset, inner = item.located(i)
                    message = Message(
                        channel_id=channel,
                        sequence=sequence,
                        log_time=log_time,
                        publish_time=publish_time,
                        data=data,
                    )
                    yield Located(offset, inner, message)
            else:
                yield item

    def runs(self) -> Iterator[Located | Damage | Messages]:
        """The file's records as :meth:`__iter__` gives them, Message records in batches
        of consecutive ones (at most about :data:`BLOCK_BYTES` of data each)."""
        batch: list[tuple[int, int, int, int, int, bytes]] = []
        chunk: int | None = None
        size = 0
        for item in self._read():
            if type(item) is tuple:
                if batch and (item[0] != chunk or size > BLOCK_BYTES):
                    yield Messages(chunk, batch, size)
                    batch, size = [], 0
                chunk = item[0]
                batch.append(item[1:])
                size += len(item[6])
                continue
            if batch:
                yield Messages(chunk, batch, size)
                batch, size = [], 0
            yield item  # type: ignore[misc]
        if batch:
            yield Messages(chunk, batch, size)

    def _read(self) -> Iterator[Located | Damage | Messages | _OneMessage]:
        self._fd = open_regular(self.path)
        try:
            self.size = self.stopped_at = os.fstat(self._fd).st_size
            self._blocks = _Blocks(self._fd, self.size)
            if self._pread(len(MAGIC), 0) != MAGIC:
                raise NotMcap(not_mcap(self.path, self.size))
            start, stop = self.span or (len(MAGIC), self.size)
            for item in self._summary_channels():
                if start == len(MAGIC) or not isinstance(item, Damage):
                    yield item  # its damage is the first span's to report
            yield from self._records(start, min(stop, self.size))
            # the file's tail is the last span's to judge
            if not self.complete and stop >= self.size and self.unfinished is None:
                self.unfinished = "it ends after a whole record, without its footer"
        finally:
            os.close(self._fd)

    def _pread(self, n: int, at: int) -> bytes:
        return self._blocks.read(n, at)

    def _records(self, pos: int, stop: int) -> Iterator[Located | Damage | Messages | _OneMessage]:
        in_summary = False
        while pos < stop:
            head = self._pread(9, pos)
            if len(head) < 9:
                self.skipped_bytes += len(head)
                self.unfinished = (
                    f"its last {len(head)} bytes, at offset {pos}, are the start of a record"
                )
                return
            opcode, length = struct.unpack("<BQ", head)
            rest = self.size - pos - 9
            problem = None
            if opcode not in NAMES:
                problem = f"not a record: opcode {opcode:#04x}"
            elif length > rest:
                problem = (
                    f"{NAMES[opcode]} record declares {length} bytes, only {rest} "
                    "remain (cut short, or its length is damaged)"
                )
            elif opcode in HELD and length > self.max_record_bytes:
                problem = (
                    f"{NAMES[opcode]} record declares {length} bytes, more than the "
                    f"{self.max_record_bytes} this reader holds"
                )
            if problem is not None:
                if opcode in NAMES and length > rest and self._cut_short(pos, opcode, length):
                    return
                pos = yield from self._resync(pos, problem)
                continue
            end = pos + 9 + length
            if opcode == FOOTER:
                if self._footer(pos, length):
                    return
                yield Damage(
                    pos, "a footer that is not followed by the closing magic at the file's end"
                )
            elif in_summary:
                pass  # summary records: the schemas and channels were read first
            elif opcode == CHUNK:
                ok = yield from self._chunk(pos, length)
                if not ok:
                    pos = yield from self._resync(pos, None)
                    continue
            elif opcode in HELD:
                try:
                    data = self._pread(length, pos + 9)
                    if opcode == MESSAGE:
                        yield _message(None, pos, data)
                    else:
                        yield Located(pos, None, _parse(opcode, data))
                except _Malformed as exc:
                    pos = yield from self._resync(pos, f"malformed {NAMES[opcode]} record: {exc}")
                    continue
            elif opcode == MESSAGE_INDEX and self._after_damaged_chunk and length >= 6:
                self.dropped_messages += struct.unpack("<I", self._pread(4, pos + 11))[0] // 16
            elif opcode == DATA_END:
                in_summary = True
            pos = end
        self.stopped_at = pos

    def _cut_short(self, pos: int, opcode: int, length: int) -> bool:
        """Whether the record at ``pos``, which declares more bytes than the file has, is an
        unfinished tail (a length a writer could write, nothing readable after it) rather
        than damage; noted if so."""
        most = self.max_record_bytes if opcode in HELD else self.max_chunk_bytes
        if length > most or self._next_record(pos + 1) is not None:
            return False
        self.skipped_bytes += self.size - pos
        self.unfinished = (
            f"its last {self.size - pos} bytes, at offset {pos}, are a {NAMES[opcode]} "
            f"record cut short (it declares {length} bytes)"
        )
        return True

    def _footer(self, pos: int, length: int) -> bool:
        """True when the footer at ``pos`` ends the file with the closing magic, or with the
        start of it (then the file is unfinished, not damaged)."""
        after = self._pread(len(MAGIC), pos + FOOTER_BYTES)
        ends_here = length == 20 and pos + FOOTER_BYTES + len(after) == self.size
        self.complete = ends_here and after == MAGIC
        if ends_here and not self.complete and MAGIC.startswith(after):
            self.skipped_bytes += len(after)
            self.unfinished = f"its footer, at offset {pos}, lacks its closing magic"
            return True
        return self.complete

    def _resync(self, pos: int, reason: str | None) -> Generator[Damage, None, int]:
        """Report damage at ``pos`` and return where the next intact record starts (the
        file's end when there is none)."""
        found = self._next_record(pos + 1)
        stop = self.size if found is None else found
        self.skipped_bytes += stop - pos
        if found is None:
            self.unfinished = f"its last {stop - pos} bytes, from offset {pos}, are damaged"
        if reason is not None:
            after = (
                "nothing readable after it"
                if found is None
                else f"{stop - pos} bytes skipped, reading again at offset {stop}"
            )
            yield Damage(pos, f"{reason}; {after}")
        return stop

    def _next_record(self, start: int) -> int | None:
        """The first offset from ``start`` where a record of :data:`RESYNC` starts whose
        fields add up to its declared length, followed by the file's end or a known opcode."""
        pos = start
        while pos < self.size:
            block = self._pread(PIECE_BYTES + 9, pos)
            for match in _RESYNC_BYTES.finditer(block, 0, PIECE_BYTES):
                i = match.start()
                if i + 9 <= len(block):
                    (length,) = struct.unpack_from("<Q", block, i + 1)
                    if pos + i + 9 + length > self.size:
                        continue  # the common case for a stray byte: a length past the end
                if self._fits(pos + i):
                    return pos + i
            pos += PIECE_BYTES
        return None

    def _fits(self, pos: int) -> bool:
        head = self._pread(9, pos)
        if len(head) < 9:
            return False
        opcode, length = struct.unpack("<BQ", head)
        end = pos + 9 + length
        if end > self.size or end < self.size and self._pread(1, end)[0] not in NAMES:
            return False
        if opcode == DATA_END:
            return length == 4
        if opcode == FOOTER:
            return length == 20 and self._pread(len(MAGIC), end) == MAGIC
        try:
            if opcode == CHUNK:
                self._chunk_head(pos, length)
            elif length > self.max_record_bytes:
                return False
            else:
                _parse(opcode, self._pread(length, pos + 9))
        except _Malformed:
            return False
        return True

    def _chunk_head(self, pos: int, length: int) -> tuple[int, int, str, int, int]:
        """A chunk's uncompressed size, CRC, compression, and where and how long its
        records are; :class:`_Malformed` when its lengths do not add up."""
        f = _Fields(self._pread(min(length, 48), pos + 9))
        f.take(16)  # message start and end times
        size, crc, name_length = f.u64(), f.u32(), f.u32()
        if name_length > 8:
            raise _Malformed(f"a compression name of {name_length} bytes")
        compression = f.take(name_length).decode("ascii", "replace")
        records = f.u64()
        if 32 + name_length + 8 + records != length:
            raise _Malformed("its lengths do not add up to the record's")
        return size, crc, compression, pos + 9 + 32 + name_length + 8, records

    def _chunk(
        self, pos: int, length: int
    ) -> Generator[Located | Damage | Messages | _OneMessage, None, bool]:
        """Yield a chunk's records once the whole chunk has checked out; damage otherwise.
        Returns False when the chunk's own fields do not add up (its length is not to be
        believed), True otherwise."""
        self._after_damaged_chunk = False
        try:
            size, crc, compression, data_at, records = self._chunk_head(pos, length)
        except _Malformed as exc:
            yield Damage(pos, f"malformed Chunk record: {exc}")
            return False
        problem = None
        kept = None
        if compression not in COMPRESSIONS:
            problem = f"unknown compression {compression!r}"
        elif size > self.max_chunk_bytes:
            problem = (
                f"declares {size} bytes uncompressed, more than the "
                f"{self.max_chunk_bytes} this reader decompresses"
            )
        else:
            kept = self._whole_chunk(compression, data_at, records, size, crc)
            if kept is None:
                kept, problem = self._check_chunk(compression, data_at, records, size, crc)
        if problem is not None:
            self.chunks_damaged += 1
            self._after_damaged_chunk = True
            yield Damage(pos, f"damaged chunk ({problem}); its {length + 9} bytes skipped")
            return True
        self.chunks += 1
        if kept is not None:
            yield from self._held_chunk(pos, kept)
            return True
        stream = _decompressed(compression, _Region(self._fd, data_at, records))
        try:
            yield from self._chunk_records(pos, lambda n: _read(stream, n), size)
        except Exception as exc:  # noqa: BLE001 - the file changed between the two passes
            yield Damage(pos, f"the chunk stopped decompressing on its second reading: {exc}")
        return True

    def _whole_chunk(
        self, compression: str, at: int, length: int, size: int, crc: int
    ) -> bytes | None:
        """A small chunk's records, decompressed in one call of the C codec, when it checks
        out at once (its size, its end, its CRC); None for a large chunk, and for anything
        else, which :meth:`_check_chunk` then reads piece by piece to say what is wrong."""
        if size > INLINE_CHUNK_BYTES or length > INLINE_CHUNK_BYTES:
            return None
        data = self._pread(length, at)
        try:
            if compression == "lz4":
                lz4_frame = lz4.frame.LZ4FrameDecompressor()
                out = lz4_frame.decompress(data, max_length=size + 1)
                if not lz4_frame.eof or lz4_frame.unused_data:
                    return None
            elif compression == "zstd":
                reader = zstandard.ZstdDecompressor(max_window_size=2**27).stream_reader(data)
                out = reader.read(size + 1)
                if reader.read(1):
                    return None
            else:
                out = data
        except Exception:  # noqa: BLE001 - damage: the piecewise check says which
            return None
        if len(out) != size or crc != 0 and zlib.crc32(out) != crc:
            return None
        return out

    def _check_chunk(
        self, compression: str, at: int, length: int, size: int, crc: int
    ) -> tuple[bytes | None, str | None]:
        """Decompress a chunk in pieces: its size and CRC. Returns the records when the
        chunk is small enough to keep, and what is wrong (None when nothing)."""
        keep = size <= INLINE_CHUNK_BYTES
        pieces: list[bytes] = []
        count, computed = 0, 0
        try:
            stream = _decompressed(compression, _Region(self._fd, at, length))
            while piece := stream.read(PIECE_BYTES):
                count += len(piece)
                if count > size:
                    return None, (f"inflates past its declared {size} bytes (a compression bomb?)")
                computed = zlib.crc32(piece, computed)
                if keep:
                    pieces.append(piece)
        except Exception as exc:  # noqa: BLE001 - lz4, zstd and EOF errors all mean damage
            return None, f"does not decompress: {type(exc).__name__}: {exc}"
        if count != size:
            return None, f"decompresses to {count} bytes, declares {size}"
        if crc != 0 and computed != crc:
            return None, f"CRC mismatch: stored {crc}, computed {computed}"
        return (b"".join(pieces) if keep else None), None

    def _chunk_records(
        self, pos: int, read: Callable[[int], bytes], size: int
    ) -> Iterator[Located | Damage | _OneMessage]:
        """The records of a chunk read from a stream."""
        inner = 0
        while inner < size:
            head = read(9)
            if len(head) < 9:
                yield Damage(pos, "a record is cut off by the chunk's end", inner)
                return
            opcode, length = struct.unpack("<BQ", head)
            whole = yield from self._chunk_record(pos, inner, opcode, length, size, read)
            if not whole:
                return
            inner += 9 + length

    def _held_chunk(
        self, pos: int, data: bytes
    ) -> Iterator[Located | Damage | Messages | _OneMessage]:
        """The records of a chunk held whole; its messages in batches, with no object per
        record (most of a recording's records are messages)."""
        batch: list[tuple[int, int, int, int, int, bytes]] = []
        batched = 0
        inner, size, most = 0, len(data), self.max_record_bytes
        while inner < size:
            if size - inner < 9:
                break
            if size - inner >= 31:  # room for a Message record's head: read it in one call
                opcode, length, channel, sequence, log_time, published = _MESSAGE_HEAD(data, inner)
            else:
                opcode, length = struct.unpack_from("<BQ", data, inner)
            end = inner + 9 + length
            if opcode == MESSAGE and 22 <= length <= most and end <= size:
                batch.append(
                    (inner, channel, sequence, log_time, published, data[inner + 31 : end])
                )
                batched += length - 22
                inner = end
                continue
            if batch:
                yield Messages(pos, batch, batched)
                batch, batched = [], 0
            read = io.BytesIO(data[inner + 9 : end]).read
            whole = yield from self._chunk_record(pos, inner, opcode, length, size, read)
            if not whole:
                return
            inner = end
        if batch:
            yield Messages(pos, batch, batched)
        if inner < size:
            yield Damage(pos, "a record is cut off by the chunk's end", inner)

    def _chunk_record(
        self,
        pos: int,
        inner: int,
        opcode: int,
        length: int,
        size: int,
        read: Callable[[int], bytes],
    ) -> Generator[Located | Damage | _OneMessage, None, bool]:
        """One record of a chunk of ``size`` bytes, at ``inner`` (its body from ``read``).
        Returns False when the rest of the chunk cannot be believed."""
        rest = size - inner - 9
        problem = None
        if opcode not in (SCHEMA, CHANNEL, MESSAGE):
            problem = f"no {NAMES.get(opcode, hex(opcode))} record belongs in a chunk"
        elif length > rest:
            problem = f"{NAMES[opcode]} record declares {length} bytes, {rest} remain"
        elif length > self.max_record_bytes:
            problem = (
                f"{NAMES[opcode]} record declares {length} bytes, more than the "
                f"{self.max_record_bytes} this reader holds"
            )
        if problem is not None:
            yield Damage(pos, f"{problem}; the rest of the chunk skipped", inner)
            return False
        try:
            if opcode == MESSAGE:
                yield _message(pos, inner, read(length))
            else:
                yield Located(pos, inner, _parse(opcode, read(length)))
        except _Malformed as exc:
            yield Damage(pos, f"malformed {NAMES[opcode]} record: {exc}", inner)
        return True

    def _summary_channels(self) -> Iterator[Located | Damage]:
        """The Schema and Channel records of the summary section, when the footer points
        at one whose CRC checks (or is not stored); damage when it points elsewhere or the
        CRC fails."""
        at = self.size - len(MAGIC) - FOOTER_BYTES
        if at <= len(MAGIC) or self._pread(len(MAGIC), self.size - len(MAGIC)) != MAGIC:
            return
        head = self._pread(FOOTER_BYTES, at)
        opcode, length, start, _, crc = struct.unpack("<BQQQI", head)
        if opcode != FOOTER or length != 20 or start == 0:
            return
        if not len(MAGIC) < start < at:
            yield Damage(
                at,
                f"the footer puts the summary at offset {start}, outside the file's "
                "data; the summary is not used",
            )
            return
        if crc != 0:
            computed = 0
            for piece_at in range(start, at + FOOTER_BYTES - 4, PIECE_BYTES):
                n = min(PIECE_BYTES, at + FOOTER_BYTES - 4 - piece_at)
                computed = zlib.crc32(self._pread(n, piece_at), computed)
            if computed != crc:
                yield Damage(
                    start,
                    f"the summary section fails its CRC (stored {crc}, "
                    f"computed {computed}); it is not used",
                )
                return
        pos = start
        while pos < at:
            op, n = struct.unpack("<BQ", self._pread(9, pos))
            if pos + 9 + n > at:
                return
            if op in (SCHEMA, CHANNEL) and n <= self.max_record_bytes:
                try:
                    yield Located(pos, None, _parse(op, self._pread(n, pos + 9)))
                except _Malformed:
                    return
            pos += 9 + n
