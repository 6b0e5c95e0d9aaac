"""Reading damaged recordings: everything before the damage is kept, and the reason is said."""

import pytest
from fastapi.testclient import TestClient
from mcap.reader import make_reader

from clients.recordings import read_recording
from service.app import create_app
from tests.conftest import cartesian

BODY = {"gate": {"kind": "ring", "tau": 1.0, "v_max": 10.0}, "first": cartesian(0.0, 0.0),
        "candidates": [cartesian(0.0, 5.0)]}


def _recorded(settings, n: int):
    with TestClient(create_app(settings)) as c:
        for _ in range(n):
            assert c.post("/v1/gates/test", json=BODY).status_code == 200
    [path] = settings.log_dir.glob("*.mcap")
    return path


# Chunk record: opcode 1, length 8, start and end times 8 + 8, uncompressed size 8, then
# its CRC (4 bytes, at +33); compression name 4 + 3 ("lz4"), data length 8, then the LZ4
# frame, whose magic number starts at +52.
@pytest.mark.parametrize(
    ("at", "damage"), [(33, "CRCValidationError"), (52, "RuntimeError: LZ4F_")],
    ids=["crc", "lz4"],
)
def test_flipped_byte_in_the_last_chunk(settings, at, damage):
    path = _recorded(settings, 5)
    complete = read_recording(path)
    with open(path, "rb") as f:
        last = max(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    data = bytearray(path.read_bytes())
    data[last.chunk_start_offset + at] ^= 0xFF
    path.write_bytes(bytes(data))
    damaged = read_recording(path)
    assert damaged.stopped_by.startswith(damage) and not damaged.complete
    assert len(damaged.exchanges) < len(complete.exchanges)


def test_cut_anywhere_keeps_a_prefix(settings):
    path = _recorded(settings, 5)
    data = path.read_bytes()
    full = [ex.request_id for ex in read_recording(path).exchanges]
    for cut in range(0, len(data), max(1, len(data) // 40)):
        path.write_bytes(data[:cut])
        got = [ex.request_id for ex in read_recording(path).exchanges]
        assert got == full[: len(got)]
