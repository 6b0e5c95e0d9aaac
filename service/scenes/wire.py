"""A canvas's ``foxglove.SceneUpdate`` as protobuf bytes, with numpy: the fast path of
:meth:`plotgate.service.scenes.draw.Canvas.entity` followed by the SDK's ``encode()``.

Built with the SDK's classes, a picture costs one Python object per point (four per
cross), about 0.3 ms for a gate test of 100 plots, which made ``plotgate view`` ten times
slower than reading the recording. Here the points of a line are written as one array:
each ``Point3`` is its tag, its length and its non-zero coordinates (proto3 leaves a zero
out, as the SDK's encoder does), picked from a fixed-width table by a mask. The rest of
the message is the few fields this module writes by hand, in the SDK's field order; the
bytes are the SDK's, byte for byte (``tests/service/test_scenes.py`` holds the two
together on every operation's picture and on random ones, zeros and negative zeros
included). The schema is still the SDK's (``SceneUpdate.get_schema()``): only the encoding
of the primitives this package draws is written here.

Field numbers are those of Foxglove's published ``.proto`` files (``foxglove/*.proto``).
"""

import functools
import struct

import numpy as np

__all__ = ["Line", "Points", "Text", "point_fields", "scene_update", "split_points"]

Color = tuple[float, float, float, float]
Line = tuple[int, np.ndarray, Color]
"""A line primitive: its type (0 strip, 1 loop, 2 list), its (N, 2 or 3) points, color."""
Text = tuple[float, float, str, Color]
"""A label: x, y, text, color."""
Points = bytes | memoryview
"""A line's encoded points (a view into the points of many lines)."""

_LENGTH_DELIMITED = 2
_DOUBLE = 1
_VARINT = 0


def _varint(value: int) -> bytes:
    if value < 0x80:  # most lengths and every tag here: one byte
        return _BYTES[value]
    if value < 0x4000:  # a line's points, an entity: two
        return bytes(((value & 0x7F) | 0x80, value >> 7))
    out = bytearray()
    while value > 0x7F:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


_BYTES = [bytes([b]) for b in range(0x80)]
_FIELD_TAGS = [_varint(field << 3 | _LENGTH_DELIMITED) for field in range(16)]
"""The tag of a length-delimited field, by field number (every one here is below 16)."""


@functools.lru_cache(maxsize=64)
def _tag(field: int, wire: int) -> bytes:
    return _varint(field << 3 | wire)


def _message(field: int, payload: bytes) -> bytes:
    return _FIELD_TAGS[field] + _varint(len(payload)) + payload


def _doubles(values: tuple[float, ...]) -> bytes:
    """Fields 1.. of doubles (Vector3, Quaternion, Color), zeros left out."""
    return b"".join(
        _tag(i, _DOUBLE) + struct.pack("<d", v) for i, v in enumerate(values, 1) if v != 0.0
    )


def _string(field: int, text: str) -> bytes:
    return _message(field, text.encode()) if text else b""


def _time(field: int, log_time: int) -> bytes:
    """A google.protobuf.Timestamp (seconds 1, nanos 2) from ns."""
    sec, nsec = divmod(log_time, 1_000_000_000)
    body = (_tag(1, _VARINT) + _varint(sec) if sec else b"") + (
        _tag(2, _VARINT) + _varint(nsec) if nsec else b""
    )
    return _message(field, body)


def _pose(field: int, x: float = 0.0, y: float = 0.0) -> bytes:
    """A Pose (position 1, orientation 2) at (x, y, 0), unrotated."""
    return _message(field, _message(1, _doubles((x, y, 0.0))) + _UNROTATED)


_UNROTATED = _message(2, _doubles((0, 0, 0, 1)))


_POINT_TAGS = np.array([_tag(i, _DOUBLE)[0] for i in (1, 2, 3)], dtype=np.uint8)
_POINT_TAG = _tag(5, _LENGTH_DELIMITED)[0]


def _points(lines: list[Line]) -> list[Points]:
    """Each line's repeated Point3 (x 1, y 2, z 3) in field 5, all lines at once (a few
    numpy calls per exchange, not per line)."""
    sizes = [len(xyz) for _, xyz, _ in lines]
    n = sum(sizes)
    if n == 0:
        return [b"" for _ in lines]
    coords = np.zeros((n, 3), dtype="<f8")
    start = 0
    for size, (_, xyz, _) in zip(sizes, lines, strict=True):
        coords[start : start + size, : xyz.shape[1]] = xyz[:, :3]
        start += size
    return split_points(*point_fields(coords), sizes)


def point_fields(coords: np.ndarray) -> tuple[bytes, np.ndarray]:
    """Every point of the (N, 3) ``coords`` as a Point3 in field 5, and each point's end in
    the bytes: the points of many lines, or of many exchanges' lines, in one pass."""
    present = coords != 0.0
    flags = present.view(np.uint8)  # sums of columns, not numpy's slower bool reductions
    lengths = 9 * (flags[:, 0] + flags[:, 1] + flags[:, 2]).astype(np.int64)  # at most 27
    axes = [axis for axis in range(3) if present[:, axis].any()]
    odd = np.flatnonzero(lengths != 9 * len(axes)).tolist()
    if 64 * len(odd) > len(coords):  # more than a few points with a zero others do not have
        data = _masked(coords, present, lengths)
    else:
        data = _patched(_same_fields(coords, axes), odd, coords, present, lengths)
    return data, np.cumsum(lengths + 2)


def split_points(data: bytes, ends: np.ndarray, sizes: list[int]) -> list[Points]:
    """The bytes of :func:`point_fields` cut into lines of ``sizes`` points each (views of
    ``data``, not copies: :func:`scene_update` copies each once, into its message)."""
    cuts = np.cumsum(sizes) - 1
    stops = ends[np.maximum(cuts, 0)].tolist()
    view = memoryview(data)
    out: list[Points] = []
    start = 0
    for stop, size in zip(stops, sizes, strict=True):
        if size:
            out.append(view[start:stop])
            start = stop
        else:
            out.append(b"")
    return out


def _same_fields(coords: np.ndarray, axes: list[int]) -> np.ndarray:
    """Every point as if each of ``axes`` were non-zero in it (a 2D picture: x and y, z
    left out): rows of a fixed width, written as a packed record array a field at a time."""
    width = 2 + 9 * len(axes)
    names, formats, offsets = ["tag", "length"], ["u1", "u1"], [0, 1]
    for i in range(len(axes)):
        names += [f"tag{i}", f"value{i}"]
        formats += ["u1", "<f8"]
        offsets += [2 + 9 * i, 3 + 9 * i]
    layout = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": width})
    rows = np.empty(len(coords), dtype=layout)
    rows["tag"] = _POINT_TAG
    rows["length"] = 9 * len(axes)
    for i, axis in enumerate(axes):
        rows[f"tag{i}"] = _POINT_TAGS[axis]
        rows[f"value{i}"] = coords[:, axis]
    return rows.view(np.uint8).reshape(len(coords), width)


def _patched(
    rows: np.ndarray, odd: list[int], coords: np.ndarray, present: np.ndarray, lengths: np.ndarray
) -> bytes:
    """The fixed-width ``rows`` as bytes, the few ``odd`` ones (a zero among their
    axes: a cross's arm on x = 0) written again without their zero fields
    (:func:`_masked`, all at once) and put in their place."""
    width = rows.shape[1]
    if not odd:
        return rows.tobytes()
    flat = memoryview(rows.reshape(-1).data)  # slices of it are not copies
    fixed = _masked(coords[odd], present[odd], lengths[odd])
    ends = np.cumsum(lengths[odd] + 2).tolist()
    pieces: list[memoryview | bytes] = []
    done, start = 0, 0
    for i, end in zip(odd, ends, strict=True):
        pieces += [flat[done * width : i * width], fixed[start:end]]
        done, start = i + 1, end
    pieces.append(flat[done * width :])
    return b"".join(pieces)


def _masked(coords: np.ndarray, present: np.ndarray, lengths: np.ndarray) -> bytes:
    """Points of any mix of zero coordinates: each point is a row of tag, length and three
    tagged doubles, and a mask keeps the non-zero ones."""
    n = len(coords)
    rows = np.empty((n, 2 + 3 * 9), dtype=np.uint8)
    rows[:, 0] = _POINT_TAG
    rows[:, 1] = lengths
    cells = rows[:, 2:].reshape(n, 3, 9)
    cells[:, :, 0] = _POINT_TAGS
    cells[:, :, 1:] = coords.view(np.uint8).reshape(n, 3, 8)
    keep = np.ones((n, 2 + 3 * 9), dtype=bool)
    keep[:, 2:] = np.repeat(present, 9, axis=1)
    return rows[keep].tobytes()


@functools.lru_cache(maxsize=16)
def _line_head(kind: int, thickness: float) -> bytes:
    """A LinePrimitive's fields before its points (type 1, pose 2, thickness 3,
    scale_invariant 4; then points 5 and color 6): the same for every line of a type."""
    head = (_tag(1, _VARINT) + _varint(kind) if kind else b"") + _pose(2)
    return head + _tag(3, _DOUBLE) + struct.pack("<d", thickness) + _tag(4, _VARINT) + b"\x01"


@functools.lru_cache(maxsize=256)
def _color(field: int, color: Color) -> bytes:
    """A Color in ``field``: the palette's few, written thousands of times (cached)."""
    return _message(field, _doubles(color))


def _text(x: float, y: float, text: str, color: Color, font_px: float) -> bytes:
    """A TextPrimitive: pose 1, billboard 2, font_size 3, scale_invariant 4, color 5,
    text 6."""
    return _pose(1, x, y) + _text_middle(font_px, color) + _string(6, text)


@functools.lru_cache(maxsize=64)
def _text_middle(font_px: float, color: Color) -> bytes:
    """A TextPrimitive's fields between its pose and its text: the same for every label
    of a color."""
    body = _tag(2, _VARINT) + b"\x01" + _tag(3, _DOUBLE)
    body += struct.pack("<d", font_px) + _tag(4, _VARINT) + b"\x01"
    return body + _color(5, color)


@functools.lru_cache(maxsize=16)
def _entity_head(frame: str, entity_id: str) -> bytes:
    """An entity's frame_id 2, id 3 and lifetime 4 (zero: present, empty)."""
    return _string(2, frame) + _string(3, entity_id) + _message(4, b"")


@functools.lru_cache(maxsize=1024)
def _pair(key: str, value: str) -> bytes:
    """A metadata KeyValuePair in field 6 (cached: a status and an operation repeat)."""
    return _message(6, _string(1, key) + _string(2, value))


def scene_update(
    frame: str,
    entity_id: str,
    log_time: int,
    metadata: dict[str, str],
    lines: list[Line],
    texts: list[Text],
    thickness: float,
    font_px: float,
    points: list[Points] | None = None,
) -> bytes:
    """The SceneUpdate of one entity (entities: field 2): timestamp 1, frame_id 2, id 3,
    lifetime 4 (zero: present, empty), metadata 6, lines 11, texts 13 (frame_locked 5 is
    false, left out). ``points`` are the lines' points already encoded
    (:func:`split_points`), or None to encode them here."""
    parts: list[Points] = [_time(1, log_time), _entity_head(frame, entity_id)]
    parts += [_pair(key, value) for key, value in metadata.items()]
    if points is None:
        points = _points(lines)
    for (kind, _, color), line_points in zip(lines, points, strict=True):
        head, tail = _line_head(kind, thickness), _color(6, color)
        size = len(head) + len(line_points) + len(tail)
        parts += [_FIELD_TAGS[11], _varint(size), head, line_points, tail]
    for text in texts:
        body = _text(*text, font_px)
        parts += [_FIELD_TAGS[13], _varint(len(body)), body]
    entity = b"".join(parts)  # each line's points copied once
    return _FIELD_TAGS[2] + _varint(len(entity)) + entity
