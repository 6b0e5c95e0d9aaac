"""MCAP files read record by record, whatever their bytes: damage is reported, never raised.

mcap's own ``StreamReader`` stops at the first bad record, believes every declared length
and decompresses a chunk whole, so one flipped byte hides the rest of a file and a chunk
declaring a terabyte (or a small one that inflates to gigabytes) takes the memory with
it. :class:`Scan` reads a file the way a recovery tool must:

- **Bounded memory.** A record is held whole only when it is a Schema, Channel, Message,
  Metadata or Header record of at most ``max_record_bytes`` (a declared size above it is
  damage); a chunk is never held whole: its compressed bytes are streamed from the file
  and decompressed in pieces of :data:`PIECE_BYTES`, and a chunk that inflates past its
  declared size, or declares more than ``max_chunk_bytes``, is damage.
- **Every record checked before it is believed.** A chunk's records are read only after
  the whole chunk has decompressed to its declared size and matched its CRC (two passes
  over a large chunk, so nothing from a damaged chunk is ever yielded); records whose
  fields do not add up to their declared length are damage.
- **Resynchronization.** After damage the file is searched, from the next byte, for the
  next record whose every length adds up (a Chunk, Schema, Channel, Metadata, DataEnd or
  Footer record followed by a plausible opcode), and reading goes on there: every intact
  chunk after a damaged one is kept.
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
from collections.abc import Generator, Iterator
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
    "NotMcap",
    "NotRegular",
    "Scan",
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
"""A chunk up to this size (uncompressed) is decompressed once and kept for its second pass;
a larger one is decompressed twice, so memory never holds it whole."""

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


class Scan:
    """Read one MCAP file: iterate to get each intact record (:class:`Located`) and each
    piece of damage (:class:`Damage`), in file order.

    Raises :class:`NotMcap` (before yielding anything) when the file does not start with
    the MCAP magic (an empty file included), :class:`NotRegular` when it is not a regular
    file, and ``OSError`` when it cannot be read. After the iteration,
    ``complete`` says whether the file ended with its footer and magic, and the counters
    say what was kept and dropped.
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
        self.chunks = 0
        """Chunks whose records were read (intact)."""
        self.chunks_damaged = 0
        self.dropped_messages = 0
        """Messages of damaged chunks, as counted by the message indexes that follow them."""
        self.skipped_bytes = 0
        """Bytes passed over while looking for the next record after damage."""
        self._fd = -1
        self._after_damaged_chunk = False

    def __iter__(self) -> Iterator[Located | Damage]:
        self._fd = open_regular(self.path)
        try:
            self.size = self.stopped_at = os.fstat(self._fd).st_size
            if os.pread(self._fd, len(MAGIC), 0) != MAGIC:
                raise NotMcap(not_mcap(self.path, self.size))
            start, stop = self.span or (len(MAGIC), self.size)
            for item in self._summary_channels():
                if start == len(MAGIC) or not isinstance(item, Damage):
                    yield item  # its damage is the first span's to report
            yield from self._records(start, min(stop, self.size))
            if not self.complete and stop >= self.size:
                yield Damage(
                    self.size,
                    "the file ends without its footer (its writer did not "
                    "finish it: killed, or still writing)",
                )
        finally:
            os.close(self._fd)

    def _pread(self, n: int, at: int) -> bytes:
        return os.pread(self._fd, n, at)

    def _records(self, pos: int, stop: int) -> Iterator[Located | Damage]:
        in_summary = False
        while pos < stop:
            head = self._pread(9, pos)
            if len(head) < 9:
                self.skipped_bytes += len(head)
                yield Damage(
                    pos,
                    f"{len(head)} bytes of an incomplete record at the end "
                    "(the writer stopped mid-record)",
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
                    yield Located(pos, None, _parse(opcode, self._pread(length, pos + 9)))
                except _Malformed as exc:
                    pos = yield from self._resync(pos, f"malformed {NAMES[opcode]} record: {exc}")
                    continue
            elif opcode == MESSAGE_INDEX and self._after_damaged_chunk and length >= 6:
                self.dropped_messages += struct.unpack("<I", self._pread(4, pos + 11))[0] // 16
            elif opcode == DATA_END:
                in_summary = True
            pos = end
        self.stopped_at = pos

    def _footer(self, pos: int, length: int) -> bool:
        """True when the footer at ``pos`` ends the file with the closing magic."""
        self.complete = (
            length == 20
            and pos + FOOTER_BYTES + len(MAGIC) == self.size
            and self._pread(len(MAGIC), pos + FOOTER_BYTES) == MAGIC
        )
        return self.complete

    def _resync(self, pos: int, reason: str | None) -> Generator[Damage, None, int]:
        """Report damage at ``pos`` and return where the next intact record starts (the
        file's end when there is none)."""
        found = self._next_record(pos + 1)
        stop = self.size if found is None else found
        self.skipped_bytes += stop - pos
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

    def _chunk(self, pos: int, length: int) -> Generator[Located | Damage, None, bool]:
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
        if compression not in COMPRESSIONS:
            problem = f"unknown compression {compression!r}"
        elif size > self.max_chunk_bytes:
            problem = (
                f"declares {size} bytes uncompressed, more than the "
                f"{self.max_chunk_bytes} this reader decompresses"
            )
        else:
            kept, problem = self._check_chunk(compression, data_at, records, size, crc)
        if problem is not None:
            self.chunks_damaged += 1
            self._after_damaged_chunk = True
            yield Damage(pos, f"damaged chunk ({problem}); its {length + 9} bytes skipped")
            return True
        stream = (
            io.BytesIO(kept)
            if kept is not None
            else _decompressed(compression, _Region(self._fd, data_at, records))
        )
        self.chunks += 1
        try:
            yield from self._chunk_records(pos, stream, size)
        except Exception as exc:  # noqa: BLE001 - the file changed between the two passes
            yield Damage(pos, f"the chunk stopped decompressing on its second reading: {exc}")
        return True

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

    def _chunk_records(self, pos: int, stream: BinaryIO, size: int) -> Iterator[Located | Damage]:
        inner = 0
        while inner < size:
            head = _read(stream, 9)
            if len(head) < 9:
                yield Damage(pos, "a record is cut off by the chunk's end", inner)
                return
            opcode, length = struct.unpack("<BQ", head)
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
                return
            try:
                yield Located(pos, inner, _parse(opcode, _read(stream, length)))
            except _Malformed as exc:
                yield Damage(pos, f"malformed {NAMES[opcode]} record: {exc}", inner)
            inner += 9 + length

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
