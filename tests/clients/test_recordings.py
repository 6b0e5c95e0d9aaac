"""Reading damaged recordings: damage is reported with its offset, every intact record kept."""

import pytest
from fastapi.testclient import TestClient
from mcap.reader import make_reader

from plotgate.clients.recordings import Reader, read_recording, recording_files
from plotgate.service.app import create_app
from tests.support.recordings import chunk_per_exchange
from tests.support.requests import cartesian

BODY = {
    "gate": {"kind": "ring", "tau": 1.0, "v_max": 10.0},
    "first": cartesian(0.0, 0.0),
    "candidates": [cartesian(0.0, 5.0)],
}


def _recorded(settings, n: int):
    with TestClient(create_app(settings)) as c:
        for i in range(n):
            r = c.post("/v1/gates/test", json=BODY, headers={"x-request-id": f"r{i}"})
            assert r.status_code == 200
    [path] = settings.log_dir.glob("*.mcap")
    chunk_per_exchange(path)
    return path


# Chunk record: opcode 1, length 8, start and end times 8 + 8, uncompressed size 8, then
# its CRC (4 bytes, at +33); compression name 4 + 3 ("lz4"), data length 8, then the LZ4
# frame, whose magic number starts at +52.
@pytest.mark.parametrize(
    ("at", "damage"), [(33, "CRC mismatch"), (52, "does not decompress")], ids=["crc", "lz4"]
)
def test_a_flipped_byte_drops_its_chunk_only(settings, at, damage):
    path = _recorded(settings, 8)
    with open(path, "rb") as f:
        indexes = sorted(
            make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset
        )
    middle = indexes[len(indexes) // 2]
    data = bytearray(path.read_bytes())
    data[middle.chunk_start_offset + at] ^= 0xFF
    path.write_bytes(bytes(data))

    damaged = read_recording(path)
    assert damaged.complete  # the footer is intact: only the chunk is damaged
    assert damaged.damage_count == 1 and damaged.chunks_damaged == 1
    assert damaged.damage[0].startswith(f"offset {middle.chunk_start_offset}: damaged chunk")
    assert damage in damaged.damage[0]
    answered = [ex.request_id for ex in damaged.exchanges if ex.response is not None]
    assert len(answered) == 7 and damaged.chunks == len(indexes) - 1
    assert answered == sorted(answered, key=lambda rid: int(rid[1:]))


def test_cut_anywhere_keeps_a_prefix(settings):
    path = _recorded(settings, 5)
    data = path.read_bytes()
    full = [ex.request_id for ex in read_recording(path).exchanges]
    for cut in range(0, len(data), max(1, len(data) // 40)):
        path.write_bytes(data[:cut])
        if cut < 8:
            assert read_recording(path).skipped is not None  # no magic: not a recording
            continue
        rec = read_recording(path)
        got = [ex.request_id for ex in rec.exchanges]
        assert got == full[: len(got)]
        assert not rec.complete


def test_a_response_in_the_next_file_pairs_with_its_request(settings, tmp_path):
    """Rotation: the request record in one file, its response in the next, read as one
    exchange; a request record written again after its file was lost counts once."""
    from plotgate.service.recording import Recorder, request_record, response_record
    from plotgate.service.registry import OPERATIONS

    recorder = Recorder(tmp_path / "rec", OPERATIONS.values(), max_bytes=1).start()
    body = b'{"gate": {}}'
    first = recorder.request("gates.test", request_record("a", "gates.test", body), 1000)
    recorder.flush()
    second = recorder.request("gates.test", request_record("b", "gates.test", body), 2000)
    recorder.response(first, response_record("a", "gates.test", 200, 0.1, b"{}"), 3000)
    recorder.flush()
    again = recorder.request("gates.test", request_record("b", "gates.test", body), 2000)
    recorder.response(
        second,
        response_record(
            "b",
            "gates.test",
            422,
            0.1,
            b'{"type": "t", "title": "t", "status": 422, "detail": "d"}',
        ),
        4000,
    )
    recorder.flush()
    recorder.forget(again)
    recorder.close()
    files = sorted((tmp_path / "rec").glob("*.mcap"))
    assert len(files) >= 3
    reader = Reader(files)
    exchanges = list(reader)
    assert [(ex.request_id, ex.response["status"]) for ex in exchanges] == [("a", 200), ("b", 422)]
    assert reader.written_twice == 1
    assert all(rec.complete and not rec.damage for rec in reader.files)


def test_the_same_id_and_time_with_other_bytes_is_a_conflict_not_a_record_written_twice(
    tmp_path,
):
    """The recorder writes a record again only byte for byte: two records of one key and
    time that differ are a conflict, reported with both places, the first read kept."""
    from plotgate.service.recording import Recorder, request_record, response_record
    from plotgate.service.registry import OPERATIONS

    recorder = Recorder(tmp_path, OPERATIONS.values(), max_bytes=1).start()
    for body in (b'{"gate": {}}', b'{"gate": {"other": 1}}'):
        exchange = recorder.request("gates.test", request_record("a", "gates.test", body), 1000)
        recorder.response(exchange, response_record("a", "gates.test", 200, 0.1, b"{}"), 2000)
        recorder.flush()
        recorder.forget(exchange)
    recorder.close()
    first, second = sorted(tmp_path.glob("*.mcap"))
    reader = Reader([first, second])
    [exchange] = list(reader)
    assert exchange.request == {"request_id": "a", "operation": "gates.test", "body": {"gate": {}}}
    assert (reader.written_twice, reader.conflict_count) == (1, 1)  # the response is the same
    [conflict] = reader.conflicts
    assert conflict.startswith("gates.test a at 1970-01-01T00:00:00.000001Z: the request record")
    assert f"{second} at offset " in conflict and f"the one at {first} at offset " in conflict


def test_a_file_gone_since_the_folder_was_listed_is_not_an_error(tmp_path):
    """A live server removes a file none of whose flushes succeeded (a full disk); one gone
    between the listing and the look at it (here a link to nothing) is simply not read."""
    (tmp_path / "a.mcap").write_bytes(b"")
    (tmp_path / "gone.mcap").symlink_to(tmp_path / "nowhere")
    assert recording_files(tmp_path) == [tmp_path / "a.mcap"]
