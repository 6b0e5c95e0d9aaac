"""Recordings cut into parts for a fleet replay: whole files, and large files by chunks.

A file whose summary indexes its chunks (a finished or compacted recording) is cut into
ranges of whole chunks of about ``part_bytes`` each, so several workers read one large file
at once. The index is believed only as far as it checks: the footer closes the file, the
summary's CRC matches (or is not stored), and each indexed chunk lies inside the data
section, after the one before it, and starts with a Chunk opcode. Anything else (no summary:
a file still being written, unchunked, or cut short by a kill; a damaged summary) makes the
file one part, read whole by one worker, as the serial replay reads it. A part that reads
past its end anyway (damage skipped across the boundary) is caught when the parts are put
together (:mod:`plotgate.clients.fleet` reads that file again whole).

A file that this process cannot open, or that is not MCAP (empty, no magic), is not sent to
a worker at all (:attr:`Part.local`): it fails at once, as in the serial replay.
"""

import os
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

from plotgate.clients.mcap_reader import (
    CHUNK,
    FOOTER,
    FOOTER_BYTES,
    MAGIC,
    PIECE_BYTES,
    open_regular,
)

__all__ = ["CHUNK_INDEX", "PART_BYTES", "Part", "chunk_offsets", "parts"]

PART_BYTES = 8 * 2**20
"""Bytes of chunks per part: enough parts for the workers to share a large file evenly,
few enough that a part's fixed cost (a task, its file opened, its summary read) is small."""
CHUNK_INDEX = 0x08


@dataclass(frozen=True)
class Part:
    """Records of ``path`` that start in [start, stop); ``stop`` None: the whole file."""

    path: str
    start: int = len(MAGIC)
    stop: int | None = None
    local: bool = False
    """Read in this process: it cannot be opened here, or is not MCAP."""

    @property
    def span(self) -> tuple[int, int] | None:
        return None if self.stop is None else (self.start, self.stop)


def parts(files: list[Path], part_bytes: int = PART_BYTES) -> list[Part]:
    """Every file's parts, in file order and, within a file, in offset order."""
    found = []
    for path in files:
        try:
            fd = open_regular(path)
        except OSError:
            found.append(Part(str(path), local=True))
            continue
        try:
            size = os.fstat(fd).st_size
            if os.pread(fd, len(MAGIC), 0) != MAGIC:
                found.append(Part(str(path), local=True))
                continue
            found += _cut(str(path), size, chunk_offsets(fd, size), part_bytes)
        except OSError:
            found.append(Part(str(path), local=True))
        finally:
            os.close(fd)
    return found


def _cut(path: str, size: int, chunks: list[tuple[int, int]], part_bytes: int) -> list[Part]:
    """Parts of about ``part_bytes`` of chunks; one whole-file part for one part's worth."""
    starts, gathered = [len(MAGIC)], 0
    for offset, length in chunks:
        if gathered >= part_bytes:
            starts.append(offset)
            gathered = 0
        gathered += length
    if len(starts) == 1:
        return [Part(path)]
    stops = starts[1:] + [size]
    return [Part(path, a, b) for a, b in zip(starts, stops, strict=True)]


def chunk_offsets(fd: int, size: int) -> list[tuple[int, int]]:
    """(offset, length) of each chunk the summary of the open file ``fd`` indexes, in file
    order; empty when there is no summary, or it does not check."""
    footer_at = size - len(MAGIC) - FOOTER_BYTES
    if footer_at <= len(MAGIC) or os.pread(fd, len(MAGIC), size - len(MAGIC)) != MAGIC:
        return []
    opcode, length, start, _, crc = struct.unpack("<BQQQI", os.pread(fd, FOOTER_BYTES, footer_at))
    if opcode != FOOTER or length != 20 or not len(MAGIC) < start < footer_at:
        return []
    if crc != 0 and _crc(fd, start, footer_at + FOOTER_BYTES - 4) != crc:
        return []
    chunks = []
    pos = start
    while pos + 9 <= footer_at:
        op, n = struct.unpack("<BQ", os.pread(fd, 9, pos))
        if pos + 9 + n > footer_at:
            return []
        if op == CHUNK_INDEX:
            if n < 32:
                return []
            chunks.append(struct.unpack("<QQ", os.pread(fd, 16, pos + 9 + 16)))
        pos += 9 + n
    return chunks if _plausible(fd, chunks, start) else []


def _crc(fd: int, start: int, stop: int) -> int:
    computed = 0
    for at in range(start, stop, PIECE_BYTES):
        computed = zlib.crc32(os.pread(fd, min(PIECE_BYTES, stop - at), at), computed)
    return computed


def _plausible(fd: int, chunks: list[tuple[int, int]], summary_at: int) -> bool:
    """Each chunk after the one before it, inside the data section, at a Chunk opcode."""
    end = len(MAGIC)
    for offset, length in chunks:
        if offset < end or offset + length > summary_at:
            return False
        if os.pread(fd, 1, offset) != bytes([CHUNK]):
            return False
        end = offset + length
    return True
